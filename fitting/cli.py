"""``tofjax calibrate``: registered with the ``tofjax`` command through the ``tofjax.commands``
entry point (see :mod:`tofjax.cli`)."""

from __future__ import annotations

import argparse
import math
import shlex
import sys
import warnings
from pathlib import Path

from tofjax.cli import add_output_options, positive_float, positive_int


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
                    "Levenberg-Marquardt least squares, optionally followed by emcee posterior sampling. A file's "
                    "bounds (a published specification, format 4) constrain the fit; with bounds only, the fit is the "
                    "smallest change from the configuration that meets every bound. Writes calibrated.toml (usable by "
                    "tofjax simulate), calibration.json, figures, report.md and report.html.")
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
    p.add_argument("--leave-out-invalid", action="store_true",
                   help="leave out the rows the fitted model saturates and refit, instead of holding every measured "
                        "row where the model measures it (the default: a camera that delivered a row was not "
                        "saturated there)")
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
    add_output_options(p, resume="--resume (the --backend chain)")
    p.set_defaults(run=run)


def _check_outputs(args) -> None:
    """Every output before any work (a fit must not end in "cannot write" after a minute)."""
    from tofjax.cli import CommandError, check_output_dir, check_output_file, require
    from tofjax.outputs import relative_inside

    if args.mcmc:  # the sampler and the corner plot: the [fit] extra
        require("emcee", "fit", "--mcmc")
        require("corner", "fit", "--mcmc")
    if args.resume and args.backend is None:
        raise CommandError("--resume continues the chain stored in --backend FILE.h5: give --backend", 2)
    if args.backend is not None:
        if not args.mcmc:
            raise CommandError("--backend stores the posterior chain: it needs --mcmc", 2)
        require("h5py", "hdf5", "--backend")
        if relative_inside(args.backend, args.out) is not None:
            raise CommandError(f"--backend {args.backend} lies inside --out {args.out}, which is replaced as a whole "
                               "when the run ends: keep the chain outside it", 2)
        if not (args.resume and args.backend.exists()):
            check_output_file(args.backend, "--backend", args, resume_option="--resume")
    check_output_dir(args.out, "--out", args)


def offset_note(ls) -> str | None:
    """A note when a file's mean readings lie more than 3 sigma from the model's on average and the
    fit leaves the camera's phase offset out (a constant depth offset the model lacks), else ``None``."""
    offset = [s for s in ls.residual_summary if s["observable"] == "depth_mean_m" and s["rows"] and abs(s["mean"]) > 3.0]
    if not offset or "pixel.phase_offset_rad" in ls.names:
        return None
    return (f"note: the mean readings of {offset[0]['file']} lie {offset[0]['mean']:+.1f} sigma from the model's on "
            "average: a camera's depth offset; fit it too (--fit ...,pixel.phase_offset_rad)")


def _print_estimates(ls, posterior=None) -> None:
    width = max(len(n) for n in ls.names)
    for n, u, e, s in zip(ls.names, ls.units, ls.estimate, ls.sigma, strict=True):
        line = f"  {n:<{width}} = {e:.6g} +- {s:.3g}" + ("" if u in ("1", "") else f" {u}")  # "1": unitless
        if posterior is not None:
            k = posterior.names.index(n)
            line += f"   posterior {posterior.median[k]:.6g} [{posterior.p16[k]:.6g}, {posterior.p84[k]:.6g}]"
        print(line, flush=True)


def _print_changes(ls) -> None:
    """The estimates of a fit of bounds only, with their change from the initial values (a
    specification states no uncertainty, so no sigma)."""
    width = max(len(n) for n in ls.names)
    for n, u, e, i in zip(ls.names, ls.units, ls.estimate, ls.initial, strict=True):
        change = f"x {e / i:.4g} of {i:.6g}" if i > 0 and e > 0 else f"{e - i:+.4g} from {i:.6g}"
        unit = f" {u}" if u not in ("1", "-", "") else ""
        print(f"  {n:<{width}} = {e:.6g}{unit} ({change})", flush=True)


def run(args) -> int:
    import tofjax as tj
    from tofjax.cli import CommandError, on_interrupt, output_dir, untouched_note
    from tofjax.progress import Progress, compiling, reporting

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
        bounded = sum(int(r.bounded.sum()) for r in rows)
        print(f"plan: fit {', '.join(p.name for p in parameters)} to {used} measured values"
              + (f" and {bounded} rows of bounds" if bounded else "") + f" in {len(rows)} file(s); into {args.out}")
        return 0
    on_interrupt(untouched_note(args.out))
    try:
        with reporting(Progress(args.max_steps, "least squares", unit="step", enabled=not args.quiet,
                                upper_bound=True)), compiling(enabled=not args.quiet):
            cal = calibrate(args.sweeps, config, fit=names, bounds=dict(args.bounds), priors=dict(args.prior),
                            relative_error=args.relative_error, min_snr=args.min_snr, max_steps=args.max_steps,
                            initial=dict(args.initial), leave_out_invalid=args.leave_out_invalid)
    except ConvergenceError as err:  # name the option, not the API argument
        raise CommandError(str(err).replace("`max_steps`", f"--max-steps (now {args.max_steps})"), 1) from None
    cal.command = " ".join(["tofjax", *map(shlex.quote, sys.argv[1:])]) if sys.argv[1:2] == ["calibrate"] else ""
    ls = cal.least_squares
    for e in cal.excluded_at_solution:
        print(f"left out {e['file']}:{e['line']}: {e['reason']} (refitted without it)")
    for e in cal.unexplained:
        print(f"warning: {e['file']}:{e['line']}: {e['reason']}: the model cannot explain this row (kept in the fit)")
    if cal.at_limit:
        print(f"note: {len(cal.at_limit)} measured row(s) hold the fit at the edge of saturation or an ADC rail "
              f"(first {cal.at_limit[0]['file']}:{cal.at_limit[0]['line']}): the data ask for more dynamic range than "
              "the configuration has; free the limit your data sheet leaves open with --fit (pixel.v_saturated_v, "
              "pixel.full_well_e with --initial, adc.v_ref_pos_v; report.md lists the rows)")
    if ls.converged:  # the estimates as soon as the fit ends (a posterior may take minutes more)
        if cal.problem.bounds_only:
            print(f"least squares: converged in {ls.steps} steps: no measured row, so the smallest change from the "
                  "configuration that meets every bound (a factor 2 of a positive parameter costs one unit)")
            _print_changes(ls)
        else:
            print(f"least squares: converged in {ls.steps} steps, chi^2/dof = {ls.chi2_per_dof:.3f} ({ls.dof} dof)")
            _print_estimates(ls)
        note = offset_note(ls)
        if note:
            print(note)
        if cal.bounds is not None:
            from ._bounds import headline, interval_line, row_lines

            print(f"bounds: {headline(cal.bounds)}")
            for line in row_lines(cal.bounds, limit=3):
                print(f"  {line}")
            for p in cal.bounds.intervals:
                print(f"  {interval_line(p)}")
        if args.mcmc:
            from ._posterior import ShortChainWarning

            if args.backend is not None:
                on_interrupt(f"during the posterior: the chain so far is in {args.backend} (continue with --resume); "
                             f"nothing was written to {args.out}")
            with warnings.catch_warnings():  # a short chain is reported below as a "warning:" line
                warnings.simplefilter("ignore", ShortChainWarning)
                cal = cal.with_posterior(walkers=args.walkers, steps=args.steps, seed=args.seed, backend=args.backend,
                                         resume=args.resume, progress=not args.quiet)
            post = cal.posterior
            print(f"posterior: {post.walkers} walkers x {post.steps} steps (burn-in {post.burn_in}, thin {post.thin}), "
                  "median [16 %, 84 %]:")
            _print_estimates(ls, post)
            from ._calibrate import posterior_notes

            for note in posterior_notes(cal):
                print(f"note: {note}")
    if not args.quiet:
        print(f"writing the results, figures and report into {args.out} ...", file=sys.stderr, flush=True)
    try:
        with output_dir(args.out, "tofjax calibrate", args) as folder:
            written = cal.write(folder.staging)
    except OSError as err:
        raise CommandError(f"cannot write {args.out}: {err.strerror or err}", 2) from None
    if not ls.converged:
        raise CommandError(f"least squares did not converge after {ls.steps} steps (--max-steps {args.max_steps}): "
                           f"{ls.solver_message}; the last iterate, residuals and figures are in {args.out} "
                           f"(report.md); raise --max-steps, start closer (--initial) or fit fewer parameters", 1)
    for flag in ls.bound_flags:
        print(f"warning: {flag['message']}")
    for flag in cal.bounds.physical if cal.bounds is not None else ():
        print(f"warning: {flag['message']}")
    if cal.refused:
        print(f"warning: calibrated.toml not written: the configuration refuses the estimates: {cal.refused}")
    for message in ls.degeneracies:
        print(f"note: {message}")
    if cal.posterior is not None:
        for message in cal.posterior.warnings:
            print(f"warning: {message}")
    print(f"wrote {len(written)} files to {args.out}: " + ", ".join(p.name for p in written))
    return 0
