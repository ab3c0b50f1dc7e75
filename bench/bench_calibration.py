"""Calibration benchmark and parameter-recovery study.

1. Recovery: for each seed, three sweeps (distance 0.5-4.5 m at 0 lx, integration time 0.2-5 ms at
   1.5 m, halogen 0-3000 lx at 1 m; 50 rows each, 200 frames per row) are simulated by Monte Carlo
   from known parameters, then contrast, responsivity and dark slope are fitted back by least
   squares. Reported per parameter: mean pull (estimate - truth) / sigma, the fraction within 3
   sigma, and the ratio of the estimates' spread to the mean reported sigma (ideal 1).
2. Timing: least squares with 4 parameters (adds k_lens, degenerate with responsivity) on the three
   sweeps, and emcee with 32 walkers x 2000 steps on the 3-parameter problem; the posterior's
   standard deviations are compared with the least-squares sigmas.

Run:  python bench/bench_calibration.py [--seeds 20] [--steps 2000] [--out FILE.json]
"""

from __future__ import annotations

import argparse
import json
import tempfile
import time
from pathlib import Path

import jax
import numpy as np
import tofjax as tj

import fitting as ft
from fitting._synthetic import write_simulated_sweep
from fitting.examples.make_examples import TRUE, true_params

NAMES = list(TRUE)


def make_sweeps(directory: Path, seed: int, rows: int = 50, frames: int = 200) -> list[Path]:
    config = tj.Config()
    keys = jax.random.split(jax.random.key(seed), 3)
    lts = true_params(config.params)
    halogen = true_params(config.replace("scene.background", "halogen").params)
    d = np.linspace(0.5, 4.5, rows)
    t = np.linspace(0.2e-3, 5e-3, rows)
    lux = np.linspace(0.0, 3000.0, rows)
    specs = [
        ("distance", lts, tj.Sweep.points("distance", d, 0 * d, 0 * d + 2e-3), {}),
        ("integration_time", lts, tj.Sweep.points("integration_time", 0 * t + 1.5, 0 * t, t), {}),
        ("illuminance", halogen, tj.Sweep.points("illuminance", 0 * lux + 1.0, lux, 0 * lux + 2e-3),
         {"scene.background": "halogen"}),
    ]
    paths = []
    for (name, params, sweep, overrides), key in zip(specs, keys, strict=True):
        path = directory / f"{name}_{seed}.csv"
        write_simulated_sweep(path, params, sweep, frames, key, true_values=TRUE, overrides=overrides)
        paths.append(path)
    return paths


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--seeds", type=int, default=20)
    parser.add_argument("--steps", type=int, default=2000)
    parser.add_argument("--out", type=Path, default=Path(__file__).parent / "results" / "bench_calibration.json")
    args = parser.parse_args()
    truth = np.array([TRUE[n] for n in NAMES])
    estimates, sigmas, fit_times = [], [], []
    with tempfile.TemporaryDirectory() as tmp:
        for seed in range(args.seeds):
            paths = make_sweeps(Path(tmp), seed)
            t0 = time.perf_counter()
            cal = ft.calibrate(paths, fit=NAMES)
            fit_times.append(time.perf_counter() - t0)
            estimates.append(cal.least_squares.estimate)
            sigmas.append(cal.least_squares.sigma)
            print(f"seed {seed:2d}: " + "  ".join(f"{n.split('.')[1]} {e:.4g}+-{s:.2g}" for n, e, s in
                                                 zip(NAMES, cal.least_squares.estimate, cal.least_squares.sigma,
                                                     strict=True))
                  + f"  chi2/dof {cal.least_squares.chi2_per_dof:.2f}  ({fit_times[-1]:.1f} s)")
        estimates, sigmas = np.array(estimates), np.array(sigmas)
        pulls = (estimates - truth) / sigmas
        spread_ratio = np.std(estimates, axis=0, ddof=1) / np.mean(sigmas, axis=0)

        paths = make_sweeps(Path(tmp), 1000)
        four = NAMES + ["camera.k_lens"]
        ft.calibrate(paths, fit=four)  # compile
        t0 = time.perf_counter()
        cal4 = ft.calibrate(paths, fit=four)
        ls4_time = time.perf_counter() - t0
        cal3 = ft.calibrate(paths, fit=NAMES)
        t0 = time.perf_counter()
        post = ft.sample_posterior(cal3.problem, cal3.least_squares, walkers=32, steps=args.steps, seed=1,
                                   progress=False)
        mcmc_time = time.perf_counter() - t0
    post_ratio = post.std / cal3.least_squares.sigma

    print()
    print(f"{'parameter':<34} {'truth':>8} {'mean pull':>10} {'within 3 sigma':>15} {'spread/sigma':>13} "
          f"{'posterior/LS sigma':>19}")
    for k, n in enumerate(NAMES):
        print(f"{n:<34} {truth[k]:8.4g} {np.mean(pulls[:, k]):+10.2f} {np.mean(np.abs(pulls[:, k]) < 3):15.0%} "
              f"{spread_ratio[k]:13.2f} {post_ratio[k]:19.2f}")
    print(f"least squares, 3 params x 3 sweeps x 50 rows: median {np.median(fit_times[1:]):.2f} s per fit "
          f"(first, with compilation: {fit_times[0]:.1f} s)")
    print(f"least squares, 4 params (with k_lens): {ls4_time:.2f} s, {cal4.least_squares.steps} steps; notes: "
          + "; ".join(cal4.least_squares.degeneracies))
    print(f"emcee 32 walkers x {args.steps} steps: {mcmc_time:.1f} s; acceptance {post.acceptance_fraction:.2f}; "
          f"autocorrelation times {np.round(post.autocorr_time, 1).tolist()}")
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps({
        "seeds": args.seeds, "names": NAMES, "truth": truth.tolist(), "estimates": estimates.tolist(),
        "sigmas": sigmas.tolist(), "mean_pull": np.mean(pulls, axis=0).tolist(),
        "within_3_sigma": np.mean(np.abs(pulls) < 3, axis=0).tolist(), "spread_over_sigma": spread_ratio.tolist(),
        "posterior_over_ls_sigma": post_ratio.tolist(), "seconds": {
            "ls_3_params_median": float(np.median(fit_times[1:])), "ls_first_with_compile": fit_times[0],
            "ls_4_params": ls4_time, "emcee": mcmc_time},
        "emcee": {"walkers": 32, "steps": args.steps, "acceptance": post.acceptance_fraction,
                  "autocorr_time": post.autocorr_time.tolist()},
    }, indent=2))
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
