"""Benchmark of the signal chain: the default distance sweep (1000 samples x 2000 frames, 4 phases,
Monte Carlo) and the analytic path, against the time needed just to draw the same number of
normal variates on this machine.

Run:  python bench/bench_simulate.py [--samples N] [--iterations N] [--repeats N] [--out FILE.json]

All times are after compilation (the first call is timed separately as "compile + run"); each
figure is the best of ``--repeats`` runs. Quote the ratios, not the absolute times.
"""

from __future__ import annotations

import argparse
import json
import platform
import time
from pathlib import Path

import jax
import jax.numpy as jnp

import tofjax as tj


def _best(fn, repeats: int) -> float:
    times = []
    for i in range(repeats):
        t0 = time.perf_counter()
        jax.block_until_ready(fn(i))
        times.append(time.perf_counter() - t0)
    return min(times)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=1000)
    parser.add_argument("--iterations", type=int, default=2000)
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--out", type=Path, default=Path(__file__).parent / "results" / "bench_simulate.json")
    args = parser.parse_args()

    config = tj.Config()
    params = config.params
    sweep = config.sweep("distance", samples=args.samples)
    n_phases = params.pixel.n_phases
    # The Monte Carlo draws 4 normals per phase image and frame (shot+reset of A and B, hold of A and B).
    n_normals = args.samples * args.iterations * n_phases * 4

    t0 = time.perf_counter()
    jax.block_until_ready(tj.simulate(params, sweep, jax.random.key(0), args.iterations))
    mc_first = time.perf_counter() - t0
    mc = _best(lambda i: tj.simulate(params, sweep, jax.random.key(i + 1), args.iterations), args.repeats)

    t0 = time.perf_counter()
    jax.block_until_ready(tj.predict(params, sweep))
    an_first = time.perf_counter() - t0
    an = _best(lambda i: tj.predict(params, sweep), args.repeats)

    draw = jax.jit(lambda k: jax.random.normal(k, (args.samples, args.iterations, n_phases, 4), dtype=jnp.float64))
    jax.block_until_ready(draw(jax.random.key(0)))
    normals = _best(lambda i: draw(jax.random.key(i + 1)), args.repeats)

    rows = [
        ("normal variates only", normals, None, 1.0),
        ("Monte Carlo simulate", mc, mc_first, mc / normals),
        ("analytic predict", an, an_first, an / normals),
    ]
    print(f"tofjax benchmark: distance sweep, {args.samples} samples x {args.iterations} frames, {n_phases} phases, "
          f"{n_normals:.3g} normal variates; best of {args.repeats}; {jax.devices()[0].platform}")
    print(f"{'case':<24} {'time [s]':>10} {'first call [s]':>15} {'ratio to normals':>17}")
    for name, t, first, ratio in rows:
        print(f"{name:<24} {t:10.4f} {first if first is not None else float('nan'):15.3f} {ratio:17.3f}")
    print(f"Monte Carlo / analytic: {mc / an:.1f}")
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps({
        "samples": args.samples, "iterations": args.iterations, "phases": n_phases, "normals": n_normals,
        "repeats": args.repeats, "platform": platform.platform(), "jax": jax.__version__,
        "cpu_count": __import__("os").cpu_count(),
        "seconds": {"normals": normals, "mc": mc, "mc_first_call": mc_first, "analytic": an,
                    "analytic_first_call": an_first},
        "ratio_to_normals": {"mc": mc / normals, "analytic": an / normals},
    }, indent=2))
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
