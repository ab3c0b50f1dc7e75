"""Where a call's time goes, from a Perfetto trace of ``jax.profiler`` (``bench_device.py --trace``
writes them): per thread (the Python thread, XLA's CPU threads, each GPU stream), its total time and
its events with the most time, and with ``--call NAME`` the events inside the ``which``-th event
whose name contains NAME, in order, indented by nesting (a call's host-side steps beside the
kernels it launched).

Run:  python bench/trace_summary.py TRACE.json.gz [--top 12] [--call NAME [--which 1] [--min-us 5]]
"""

from __future__ import annotations

import argparse
import collections
import gzip
import json
import sys


def load(path: str) -> tuple[list[dict], dict, dict]:
    """The complete events (``ph == "X"``) of a trace, and its thread and process names."""
    with gzip.open(path) if path.endswith(".gz") else open(path, "rb") as fh:
        data = json.load(fh)
    events = data["traceEvents"] if isinstance(data, dict) else data
    threads = {(e["pid"], e["tid"]): e["args"]["name"] for e in events
               if e.get("ph") == "M" and e.get("name") == "thread_name"}
    processes = {e["pid"]: e["args"]["name"] for e in events if e.get("ph") == "M" and e.get("name") == "process_name"}
    return [e for e in events if e.get("ph") == "X"], threads, processes


def summary(events, threads, processes, top: int) -> None:
    time = collections.defaultdict(collections.Counter)
    count = collections.defaultdict(collections.Counter)
    for e in events:
        where = (processes.get(e["pid"], str(e["pid"])), threads.get((e["pid"], e["tid"]), str(e["tid"])))
        time[where][e["name"]] += e.get("dur", 0)
        count[where][e["name"]] += 1
    for where, names in sorted(time.items(), key=lambda kv: -sum(kv[1].values())):
        print(f"{where[0]} / {where[1]}: {sum(names.values()) / 1e3:.3f} ms in {sum(count[where].values())} events")
        for name, us in names.most_common(top):
            print(f"    {us / 1e3:9.3f} ms  x{count[where][name]:<5d} {name[:110]}")


def timeline(events, threads, name: str, which: int, min_us: float) -> None:
    calls = sorted((e for e in events if name in e["name"]), key=lambda e: e["ts"])
    if which >= len(calls):
        sys.exit(f"--which = {which} is out of range: {len(calls)} events contain {name!r}")
    call = calls[which]
    start, end = call["ts"], call["ts"] + call["dur"]
    open_until: dict = collections.defaultdict(list)
    for e in sorted((e for e in events if start <= e["ts"] <= end), key=lambda e: e["ts"]):
        where = threads.get((e["pid"], e["tid"]), str(e["tid"]))
        stack = open_until[where]
        while stack and stack[-1] <= e["ts"]:
            stack.pop()
        if e.get("dur", 0) >= min_us:
            print(f"{e['ts'] - start:9.1f} us {e.get('dur', 0):8.1f} us {'  ' * len(stack)}{e['name'][:90]}  [{where[:30]}]")
        stack.append(e["ts"] + e.get("dur", 0))


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("trace")
    parser.add_argument("--top", type=int, default=12)
    parser.add_argument("--call", help="show the events inside one event whose name contains this")
    parser.add_argument("--which", type=int, default=1, help="which such event (0: the first)")
    parser.add_argument("--min-us", type=float, default=5.0)
    args = parser.parse_args(argv)
    events, threads, processes = load(args.trace)
    if args.call:
        timeline(events, threads, args.call, args.which, args.min_us)
    else:
        summary(events, threads, processes, args.top)
    return 0


if __name__ == "__main__":
    sys.exit(main())
