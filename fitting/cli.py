"""``tofjax calibrate``: registered with the ``tofjax`` command through the ``tofjax.commands``
entry point (see :mod:`tofjax.cli`)."""

from __future__ import annotations

import argparse
import math
import shlex
import sys
import warnings
from pathlib import Path

from tofjax.cli import positive_float, positive_int


def _pair(text: str) -> tuple[str, tuple[float, float]]:
    name, sep, rest = text.partition("=")
    lo, colon, hi = rest.partition(":")
    try:
        values = (float(lo), float(hi))
    except ValueError:
        values = (math.nan, math.nan)
    if not sep or not colon or not all(math.isfinite(v) for v in values):
        raise argparse.ArgumentTypeError(f"{text!r} is not NAME=A:B with two numbers")
    return name.strip(), values


def _value(text: str) -> tuple[str, float]:
    name, sep, rest = text.partition("=")
    try:
        value = float(rest)
    except ValueError:
        value = math.nan
    if not sep or not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"{text!r} is not NAME=VALUE with a finite number")
    return name.strip(), value


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "calibrate", help="fit sensor parameters to measured sweeps (least squares, optional emcee posterior)",
        description="Fit configuration parameters to the amplitude and depth-noise rows of tofjax-sweep files by "
                    "Levenberg-Marquardt least squares, optionally followed by emcee posterior sampling. Writes "
                    "calibrated.toml (usable by tofjax simulate), calibration.json, figures and report.md.")
    p.add_argument("sweeps", nargs="+", type=Path, metavar="SWEEP.csv", help="tofjax-sweep files")
    p.add_argument("--config", type=Path, help="camera configuration TOML (default: built-in defaults)")
    p.add_argument("--fit", required=True, help="comma-separated dotted names, e.g. "
                   "pixel.demodulation_contrast,pixel.photo_responsivity_a_per_w")
    p.add_argument("--bounds", type=_pair, action="append", default=[], metavar="NAME=LO:HI",
                   help="bounds of a fitted parameter (default: its configuration range); repeatable")
    p.add_argument("--prior", type=_pair, action="append", default=[], metavar="NAME=MEAN:SIGMA",
                   help="Gaussian prior of a fitted parameter for --mcmc (default: uniform within bounds)")
    p.add_argument("--initial", type=_value, action="append", default=[], metavar="NAME=VALUE",
                   help="starting value of a fitted parameter (default: the configuration's); repeatable")
    p.add_argument("--relative-error", type=positive_float,
                   help="use this fraction of each value as its uncertainty instead of deriving it from n_frames")
    p.add_argument("--min-snr", type=positive_float, default=5.0,
                   help="leave out rows whose amplitude mean/std is below this (default 5)")
    p.add_argument("--max-steps", type=positive_int, default=1000, help="least-squares step limit (default 1000)")
    p.add_argument("--mcmc", action="store_true", help="sample the posterior with emcee after the least squares")
    p.add_argument("--walkers", type=positive_int, default=32, help="emcee walkers (default 32)")
    p.add_argument("--steps", type=positive_int, default=2000, help="emcee steps (default 2000)")
    p.add_argument("--backend", type=Path, help="HDF5 file for the chain (needs h5py)")
    p.add_argument("--resume", action="store_true", help="continue the chain stored in --backend")
    p.add_argument("--seed", type=int, default=0, help="random seed of the sampler (default 0)")
    p.add_argument("--out", type=Path, required=True, help="output directory")
    p.add_argument("--check", action="store_true", help="validate the files, names, bounds and outputs, print what "
                                                        "would be fitted, fit nothing")
    p.add_argument("--quiet", action="store_true", help="no progress report")
    p.set_defaults(run=run)


def _check_outputs(args) -> None:
    """Every output before any work (a fit must not end in "cannot write" after a minute)."""
    from tofjax.cli import CommandError, check_output_dir, check_output_file

    if args.resume and args.backend is None:
        raise CommandError("--resume continues the chain stored in --backend FILE.h5: give --backend", 2)
    if args.backend is not None:
        if not args.mcmc:
            raise CommandError("--backend stores the posterior chain: it needs --mcmc", 2)
        try:
            import h5py  # noqa: F401
        except ImportError:
            raise CommandError("--backend needs h5py: pip install h5py (or \"tofjax[hdf5]\")", 2) from None
        check_output_file(args.backend, "--backend")
    check_output_dir(args.out, "--out")


def run(args) -> int:
    import tofjax as tj
    from tofjax.cli import CommandError
    from tofjax.progress import Progress, reporting

    from ._calibrate import calibrate, check_inputs
    from ._least_squares import ConvergenceError

    _check_outputs(args)
    config = tj.load_config(args.config) if args.config else tj.Config()
    names = [n.strip() for n in args.fit.split(",") if n.strip()]
    if args.check:
        rows, parameters = check_inputs(args.sweeps, config, fit=names, bounds=dict(args.bounds),
                                        priors=dict(args.prior), relative_error=args.relative_error,
                                        min_snr=args.min_snr, initial=dict(args.initial))
        used = sum(len(r.used(o)) for r in rows for o in r.data)
        print(f"plan: fit {', '.join(p.name for p in parameters)} to {used} measured values in {len(rows)} file(s); "
              f"into {args.out}")
        return 0
    try:
        with warnings.catch_warnings():  # a short chain is reported below as a "warning:" line
            if args.mcmc:  # emcee is imported only for a posterior
                from ._posterior import ShortChainWarning

                warnings.simplefilter("ignore", ShortChainWarning)
            with reporting(Progress(args.max_steps, "least squares", unit="step", enabled=not args.quiet,
                                    upper_bound=True)):
                cal = calibrate(args.sweeps, config, fit=names, bounds=dict(args.bounds), priors=dict(args.prior),
                                relative_error=args.relative_error, min_snr=args.min_snr, mcmc=args.mcmc,
                                walkers=args.walkers, steps=args.steps, seed=args.seed, backend=args.backend,
                                resume=args.resume, progress=args.mcmc and not args.quiet, max_steps=args.max_steps,
                                initial=dict(args.initial))
    except ConvergenceError as err:  # name the option, not the API argument
        raise CommandError(str(err).replace("`max_steps`", f"--max-steps (now {args.max_steps})"), 1) from None
    cal.command = " ".join(["tofjax", *map(shlex.quote, sys.argv[1:])]) if sys.argv[1:2] == ["calibrate"] else ""
    try:
        written = cal.write(args.out)
    except OSError as err:
        raise CommandError(f"cannot write {args.out}: {err.strerror or err}", 2) from None
    ls = cal.least_squares
    width = max(len(n) for n in ls.names)
    for e in cal.excluded_at_solution:
        print(f"left out {e['file']}:{e['line']}: {e['reason']} (refitted without it)")
    if not ls.converged:
        raise CommandError(f"least squares did not converge after {ls.steps} steps (--max-steps {args.max_steps}): "
                           f"{ls.solver_message}; the last iterate, residuals and figures are in {args.out} "
                           f"(report.md); raise --max-steps, start closer (--initial) or fit fewer parameters", 1)
    print(f"least squares: converged in {ls.steps} steps, chi^2/dof = {ls.chi2_per_dof:.3f} ({ls.dof} dof)")
    for n, u, e, s in zip(ls.names, ls.units, ls.estimate, ls.sigma, strict=True):
        line = f"  {n:<{width}} = {e:.6g} +- {s:.3g} {u}"
        if cal.posterior is not None:
            k = cal.posterior.names.index(n)
            post = cal.posterior
            line += f"   posterior {post.median[k]:.6g} [{post.p16[k]:.6g}, {post.p84[k]:.6g}]"
        print(line)
    for flag in ls.bound_flags:
        print(f"warning: {flag['message']}")
    for message in ls.degeneracies:
        print(f"note: {message}")
    if cal.posterior is not None:
        for message in cal.posterior.warnings:
            print(f"warning: {message}")
    print(f"wrote {len(written)} files to {args.out}: " + ", ".join(p.name for p in written))
    return 0
