"""tofjax against the NumPy baseline (bench/numpy_baseline.py) and the random-number floor, on
this machine, in one run: each case alternates tofjax and its baselines (A, B, A, B, ...) and
reports medians and ratios, so that drifts of the machine hit both sides alike.

Cases (issue 10's targets in brackets):
- ``mc_sweep``: the default Monte Carlo distance sweep, 1000 points x 2000 frames x 4 phases
  [>= 2x the NumPy baseline on two threads];
- ``frame_224x172``, ``frame_640x480``: one noisy frame of a tilted wall (1 iteration per pixel)
  [>= 2x the tabulated NumPy baseline and >= 100 frames/s; 640 x 480 >= 25 frames/s];
- ``predict_1e5``: the analytic path against NumPy computing only the expected tap charges
  [within 2x]; ``predict_1e6``: runs;
- ``memory_1000x20000``: peak memory of that Monte Carlo, in a fresh process [<= 1 GB];
- ``calibrate``: ``tofjax calibrate`` of the example (3 parameters, 3 files), cold (empty
  compilation cache) and warm [< 20 s, < 5 s]; ``help``: ``tofjax --help`` [< 1 s];
- ``main_job``: README's first command, ``tofjax simulate --sweep distance`` (progress on), cold and
  warm (the better of two warm runs), in fresh processes.

Also reported: the floor, i.e. the time to draw just the normals each side draws (tofjax's
Philox normals, one per phase image on the Monte Carlo's linear path; NumPy's PCG64, 4 per phase
image), and agreement of the statistics (median relative difference, tofjax vs NumPy).

Run:  python bench/bench.py [--repeats 5] [--quick] [--skip-subprocess] [--out bench/results/bench.json]
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import random
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np

import tofjax as tj
from tofjax._random import key_words, normals

sys.path.insert(0, str(Path(__file__).parent))
from numpy_baseline import Baseline  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
EXAMPLES = ROOT / "fitting" / "examples"
FIT = "pixel.demodulation_contrast,pixel.photo_responsivity_a_per_w,pixel.dark_slope_mean_v_per_s"


def interleaved(cases: dict, repeats: int, seed: int = 0) -> dict[str, float]:
    """Median seconds per case; every repeat runs each case once (after one warm-up), in an order
    shuffled anew for each repeat (``seed``): in a fixed order the case after the largest one always
    started with caches and freed memory that case had just thrown out (640 x 480: a prepared
    camera's frame after NumPy's 1.2 GB batch of normals took 38 ms instead of 27)."""
    times = {name: [] for name in cases}
    for fn in cases.values():
        fn(-1)  # compile / warm up
    order = list(cases)
    rng = random.Random(seed)
    for i in range(repeats):
        rng.shuffle(order)
        for name in order:
            t0 = time.perf_counter()
            cases[name](i)
            times[name].append(time.perf_counter() - t0)
    return {name: statistics.median(t) for name, t in times.items()}


def ready(x):
    return jax.block_until_ready(x)


def wall(size: tuple[int, int], d_near: float = 0.6, d_far: float = 4.0) -> np.ndarray:
    """Distances of a wall tilted left to right (rows x columns)."""
    return np.broadcast_to(np.linspace(d_near, d_far, size[1]), size).copy()


def relative(a, b) -> float:
    a, b = np.asarray(a, dtype=float).ravel(), np.asarray(b, dtype=float).ravel()
    ok = np.isfinite(a) & np.isfinite(b) & (b != 0)
    return float(np.median(np.abs(a[ok] / b[ok] - 1.0)))


def mc_sweep(config, baseline: Baseline, repeats: int, frames: int) -> dict:
    params = config.params
    sweep = config.sweep("distance", samples=1000)
    d = np.asarray(sweep.values)
    lux, t_s = float(params.scene.illuminance_lx), float(params.scene.integration_time_s)
    n_phases = params.pixel.n_phases
    words = key_words(jax.random.key(7))
    floor_jax = jax.jit(lambda f0: jnp.sum(normals(words, f0 + jnp.arange(frames, dtype=jnp.uint32)[None, :],
                                                   jnp.arange(d.size, dtype=jnp.uint32)[:, None], 0, n_phases)))
    rng = np.random.default_rng(1)
    chunk = max(1, (1 << 21) // (frames * n_phases * 4))

    def floor_numpy(i):
        for _ in range(0, d.size, chunk):
            rng.standard_normal((4, min(chunk, d.size), frames, n_phases))

    cases = {
        "tofjax": lambda i: ready(tj.simulate(params, sweep, jax.random.key(i + 10), frames)),
        "tofjax_analytic": lambda i: ready(tj.predict(params, sweep)),
        "numpy_1_thread": lambda i: baseline.simulate(i + 10, d, lux, t_s, frames, threads=1),
        "numpy_2_threads": lambda i: baseline.simulate(i + 10, d, lux, t_s, frames, threads=2),
        "floor_tofjax_normals": lambda i: ready(floor_jax(jnp.uint32(frames * (i + 2)))),
        "floor_numpy_normals": floor_numpy,
    }
    t = interleaved(cases, repeats)
    r = tj.simulate(params, sweep, jax.random.key(0), frames)
    b = baseline.simulate(0, d, lux, t_s, frames)
    agree = {k: relative(getattr(r, k), b[k]) for k in ("depth_std_m", "amplitude_mean_lsb", "amplitude_std_lsb")}
    return {"seconds": t, "agreement_median_rel": agree, "phase_images": d.size * frames * n_phases,
            "ratios": {"numpy_1_thread/tofjax": t["numpy_1_thread"] / t["tofjax"],
                       "tofjax/tofjax_analytic": t["tofjax"] / t["tofjax_analytic"],
                       "numpy_2_threads/tofjax": t["numpy_2_threads"] / t["tofjax"],
                       "tofjax/floor_tofjax_normals": t["tofjax"] / t["floor_tofjax_normals"],
                       "numpy_1_thread/floor_numpy_normals": t["numpy_1_thread"] / t["floor_numpy_normals"]},
            "ns_per_phase_image": {k: v / (d.size * frames * n_phases) * 1e9 for k, v in t.items()}}


def frame_case(config, baseline: Baseline, size: tuple[int, int], repeats: int) -> dict:
    params = config.params
    d = wall(size)
    sweep = tj.Sweep("distance", d)
    lux, t_s = float(params.scene.illuminance_lx), float(params.scene.integration_time_s)
    rng = np.random.default_rng(3)
    baseline.table()  # the table is per camera, built once

    def run_tofjax(i):
        r = tj.simulate(params, sweep, jax.random.key(i + 100), 1, keep_frames=1)
        return ready(r.depth_m)

    cases = {"tofjax": run_tofjax, "numpy_table": lambda i: baseline.frame(rng, d, lux, t_s)}
    t = interleaved(cases, repeats)
    r = tj.simulate(params, sweep, jax.random.key(0), 1, keep_frames=1)
    depth_np, _ = baseline.frame(rng, d, lux, t_s)
    depth_tj = np.asarray(r.depth_m)[..., 0]
    err_tj, err_np = depth_tj - d, depth_np - d
    return {"seconds": t, "frames_per_s": {k: 1.0 / v for k, v in t.items()},
            "ratios": {"numpy_table/tofjax": t["numpy_table"] / t["tofjax"]},
            "depth_error_rms_m": {"tofjax": float(np.sqrt(np.nanmean(err_tj**2))),
                                  "numpy_table": float(np.sqrt(np.nanmean(err_np**2)))}}


def predict_case(config, baseline: Baseline, samples: int, repeats: int) -> dict:
    params = config.params
    sweep = config.sweep("distance", samples=samples)
    d = np.asarray(sweep.values)
    lux, t_s = float(params.scene.illuminance_lx), float(params.scene.integration_time_s)
    faults = {"tofjax_predict": 0, "numpy_expected_charges": 0}

    def counted(name, fn):  # the minor page faults of each call (fresh pages of freed and new buffers)
        def call(i):
            before = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
            fn()
            faults[name] += resource.getrusage(resource.RUSAGE_SELF).ru_minflt - before
        return call

    cases = {"tofjax_predict": counted("tofjax_predict", lambda: ready(tj.predict(params, sweep))),
             "numpy_expected_charges": counted("numpy_expected_charges", lambda: baseline.expected_charges(d, lux, t_s))}
    t = interleaved(cases, repeats)
    return {"seconds": t, "us_per_sample": {k: v / samples * 1e6 for k, v in t.items()},
            "page_faults_per_call": {k: v / (repeats + 1) for k, v in faults.items()},
            "ratios": {"tofjax/numpy_expected_charges": t["tofjax_predict"] / t["numpy_expected_charges"]}}


_MEMORY_CHILD = r"""
import sys, time, jax, tofjax as tj
config = tj.Config()
sweep = config.sweep("distance", samples=1000)
frames = int(sys.argv[1])
t0 = time.perf_counter()
jax.block_until_ready(tj.simulate(config.params, sweep, jax.random.key(0), frames))
elapsed = time.perf_counter() - t0
# VmHWM: this process's peak resident set (ru_maxrss would carry the forking parent's over exec).
peak = [line for line in open("/proc/self/status") if line.startswith("VmHWM:")][0].split()[1]
print(int(peak) * 1024, elapsed)
"""


def memory_case() -> dict:
    """Peak resident memory of a process running the 1000 x 20000 Monte Carlo, and of one running
    1000 x 2 (the JAX runtime and compiler alone), each fresh."""
    out = {}
    for frames in (2, 20000):
        line = subprocess.run([sys.executable, "-c", _MEMORY_CHILD, str(frames)], capture_output=True, text=True,
                              check=True, env={**os.environ, "TOFJAX_CACHE_DIR": "off"}).stdout.split()
        out[f"peak_rss_bytes_1000x{frames}"] = int(line[0])
        out[f"seconds_1000x{frames}"] = float(line[1])
    out["peak_rss_increase_bytes"] = out["peak_rss_bytes_1000x20000"] - out["peak_rss_bytes_1000x2"]
    config = tj.Config()
    from tofjax._chain import build_chain
    from tofjax._montecarlo import monte_carlo

    sweep = config.sweep("distance", samples=1000)
    lowered = jax.jit(lambda p, k: monte_carlo(build_chain(p, None, 1000), sweep, k, 20000, 0)).lower(
        config.params, jax.random.key(0))
    out["compiled_temp_bytes"] = int(lowered.compile().memory_analysis().temp_size_in_bytes)
    return out


def _fresh_processes(command: list[str], names: tuple[str, ...], suffix: str = "") -> dict:
    """Seconds of ``command --out TMP/<name><suffix>`` for each of ``names`` in turn, each in a fresh
    process, all sharing one compilation cache that starts empty (so the first run is cold)."""
    out = {}
    with tempfile.TemporaryDirectory() as tmp:
        env = {**os.environ, "TOFJAX_CACHE_DIR": os.path.join(tmp, "cache")}
        for name in names:
            t0 = time.perf_counter()
            subprocess.run([*command, "--out", os.path.join(tmp, name + suffix)], check=True, env=env, capture_output=True)
            out[f"{name}_s"] = time.perf_counter() - t0
    return out


def calibrate_case() -> dict:
    command = [sys.executable, "-m", "tofjax.cli", "calibrate", *sorted(str(p) for p in EXAMPLES.glob("*.csv")),
               "--config", str(EXAMPLES / "camera.toml"), "--fit", FIT]
    out = _fresh_processes(command, ("cold", "warm"))
    helps = []
    for _ in range(3):
        t0 = time.perf_counter()
        subprocess.run([sys.executable, "-m", "tofjax.cli", "--help"], check=True, capture_output=True)
        helps.append(time.perf_counter() - t0)
    out["help_s"] = statistics.median(helps)
    return out


def main_job_case() -> dict:
    """README's first command (``tofjax simulate --sweep distance``: 1000 points x 2000 frames, progress
    on), cold (empty compilation cache) and warm, in fresh processes as users run it."""
    return _fresh_processes([sys.executable, "-m", "tofjax.cli", "simulate", "--sweep", "distance"],
                            ("cold", "warm", "warm_again"), ".csv")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--quick", action="store_true", help="200 frames in the sweep, no 640 x 480 frame")
    parser.add_argument("--skip-subprocess", action="store_true", help="skip memory, calibrate and --help")
    parser.add_argument("--out", type=Path, default=Path(__file__).parent / "results" / "bench.json")
    args = parser.parse_args()
    config = tj.Config()
    baseline = Baseline(config.params)
    results = {"platform": platform.platform(), "processor": platform.processor(), "cpu_count": os.cpu_count(),
               "jax": jax.__version__, "numpy": np.__version__, "device": str(jax.devices()[0]),
               "repeats": args.repeats}
    results["mc_sweep"] = mc_sweep(config, baseline, args.repeats, 200 if args.quick else 2000)
    results["frame_224x172"] = frame_case(config, baseline, (172, 224), max(args.repeats, 20))
    if not args.quick:
        results["frame_640x480"] = frame_case(config, baseline, (480, 640), args.repeats)
    # 20 repeats at least: a call's time moves by half with the allocator's state (page faults per
    # call, reported; docs/model.md, "Performance", measurement 24).
    results["predict_1e5"] = predict_case(config, baseline, 100_000, max(args.repeats, 20))
    t0 = time.perf_counter()
    ready(tj.predict(config.params, config.sweep("distance", samples=1_000_000)))
    results["predict_1e6"] = {"seconds_first_call": time.perf_counter() - t0}
    if not args.skip_subprocess:
        results["memory_1000x20000"] = memory_case()
        results["calibrate"] = calibrate_case()
        results["main_job"] = main_job_case()
    print(table(results))
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(results, indent=2))
    print(f"wrote {args.out}")


def table(r: dict) -> str:
    rows = [("case", "tofjax", "baseline", "ratio (baseline/tofjax)", "target")]
    mc = r["mc_sweep"]
    s = mc["seconds"]
    frames = mc["phase_images"] // (1000 * 4)
    rows.append((f"MC sweep 1000x{frames}x4 vs NumPy 1 thread", f"{s['tofjax']:.3f} s", f"{s['numpy_1_thread']:.3f} s",
                 f"{mc['ratios']['numpy_1_thread/tofjax']:.1f}x", ""))
    rows.append(("MC sweep vs NumPy 2 threads", "", f"{s['numpy_2_threads']:.3f} s",
                 f"{mc['ratios']['numpy_2_threads/tofjax']:.1f}x", ">= 2x"))
    rows.append(("analytic (tofjax.predict) on the same sweep", f"{s['tofjax_analytic']:.3f} s", "",
                 f"MC/analytic {mc['ratios']['tofjax/tofjax_analytic']:.1f}x", ""))
    rows.append(("MC sweep: normals only (floor)", f"{s['floor_tofjax_normals']:.3f} s",
                 f"{s['floor_numpy_normals']:.3f} s",
                 f"tofjax/floor {mc['ratios']['tofjax/floor_tofjax_normals']:.1f}", ""))
    for name, target in (("frame_224x172", ">= 2x, >= 100 fps"), ("frame_640x480", ">= 25 fps")):
        if name in r:
            f = r[name]
            rows.append((f"one noisy frame {name[6:]}", f"{f['frames_per_s']['tofjax']:.0f} fps",
                         f"{f['frames_per_s']['numpy_table']:.0f} fps", f"{f['ratios']['numpy_table/tofjax']:.1f}x", target))
    p = r["predict_1e5"]
    rows.append(("predict 1e5 vs NumPy expected charges", f"{p['seconds']['tofjax_predict']:.3f} s",
                 f"{p['seconds']['numpy_expected_charges']:.3f} s",
                 f"{1.0 / p['ratios']['tofjax/numpy_expected_charges']:.2f}x", ">= 0.5x"))
    rows.append(("  page faults per call", f"{p['page_faults_per_call']['tofjax_predict']:.0f}",
                 f"{p['page_faults_per_call']['numpy_expected_charges']:.0f}", "", ""))
    rows.append(("predict 1e6 (first call)", f"{r['predict_1e6']['seconds_first_call']:.2f} s", "", "", "runs"))
    if "memory_1000x20000" in r:
        m = r["memory_1000x20000"]
        rows.append(("MC 1000x20000 peak RSS (1000x2: runtime)", f"{m['peak_rss_bytes_1000x20000'] / 2**20:.0f} MiB",
                     f"{m['peak_rss_bytes_1000x2'] / 2**20:.0f} MiB",
                     f"temp {m['compiled_temp_bytes'] / 2**20:.1f} MiB", "<= 1 GiB"))
    if "calibrate" in r:
        c = r["calibrate"]
        rows.append(("tofjax calibrate example cold / warm", f"{c['cold_s']:.1f} s / {c['warm_s']:.1f} s", "", "",
                     "< 20 s / < 5 s"))
        rows.append(("tofjax --help", f"{c['help_s']:.2f} s", "", "", "< 1 s"))
    if "main_job" in r:
        j = r["main_job"]
        rows.append(("tofjax simulate --sweep distance cold / warm", f"{j['cold_s']:.1f} s / "
                     f"{min(j['warm_s'], j['warm_again_s']):.1f} s", "", "", ""))
    widths = [max(len(row[i]) for row in rows) for i in range(5)]
    lines = ["  ".join(cell.ljust(w) for cell, w in zip(row, widths, strict=True)) for row in rows]
    agree = ", ".join(f"{k} {v:.1%}" for k, v in mc["agreement_median_rel"].items())
    lines.append(f"MC statistics, tofjax vs NumPy (median relative difference): {agree}")
    return "\n".join(lines)


if __name__ == "__main__":
    main()
