"""The ``tofjax`` command: ``simulate`` and ``config``, plus the subcommands registered beside them
(``render`` from :mod:`tofjax.render_cli`, ``calibrate`` and ``compare`` from ``fitting``,
``record`` from ``measurements``).

Those register through the entry-point group ``tofjax.commands``: each entry point is a function
``register(subparsers)`` that adds its parser and sets ``run=handler`` (``handler(args) -> int``).
So this command reaches every package while ``tofjax`` itself imports none of them.

Errors in the user's input (arguments, configuration values, files) are printed as one line,
``tofjax: error: ...``, without a traceback, and exit with status 2; a :class:`CommandError`
carries its own message and exit status.

Start-up: this module and the subcommands' ``register`` functions import neither JAX nor NumPy, so
``tofjax --help`` answers at once; a command imports what it runs. Commands that compute use JAX's
persistent compilation cache (:func:`tofjax.enable_compilation_cache`): the second run of a command
starts warm.
"""

from __future__ import annotations

import argparse
import contextlib
import math
import os
import signal
import sys
import threading
from importlib.metadata import entry_points
from pathlib import Path

from . import __version__
from ._cache import CACHE_ENV, FAST_COMPILE_XLA_FLAG, compilation_cache_dir, enable_compilation_cache  # noqa: F401
from ._schema import SWEEP_AXES, SWEEPS  # the schema's tables need neither JAX nor NumPy


class CommandError(Exception):
    """A failure a subcommand reports as one line with its own exit status (default 1)."""

    def __init__(self, message: str, exit_code: int = 1):
        super().__init__(message)
        self.exit_code = exit_code


class _UsageError(CommandError):
    def __init__(self, message: str):
        super().__init__(message, 2)


def require(module: str, extra: str, what: str):
    """``module`` imported, or a :class:`CommandError` (exit 2) naming what needs it and the extra of
    this distribution that installs it, e.g. ``--mcmc needs emcee: pip install "tofjax[fit]"``."""
    import importlib

    try:
        return importlib.import_module(module)
    except ImportError:
        raise CommandError(f'{what} needs {module}, which is not installed: pip install "tofjax[{extra}]"', 2) from None


class _Parser(argparse.ArgumentParser):
    def error(self, message):  # argparse prints usage and exits 2; keep that, but say "tofjax: error:"
        self.print_usage(sys.stderr)
        self.exit(2, f"tofjax: error: {message}\n")


def add_output_options(parser, *, resume: str | None = None) -> None:
    """``--overwrite`` and ``--force-replace-measurement`` (:mod:`tofjax.outputs`), the same for
    every command that writes; ``resume``: the command's option that continues an output instead."""
    more = f" ({resume} continues it instead)" if resume else ""
    parser.add_argument("--overwrite", action="store_true",
                        help=f"replace an existing output{more}; without it an existing non-empty output is refused")
    parser.add_argument("--force-replace-measurement", action="store_true",
                        help="also replace a measured sweep file (source: measurement), which --overwrite never does")


def check_output_file(path: Path, option: str, args=None, *, resume_option: str | None = None) -> None:
    """Before any work: may the file ``path`` be written? An existing non-empty one is refused
    unless ``args.overwrite``, a measurement unless ``args.force_replace_measurement`` as well
    (:func:`tofjax.outputs.check_output`); makes its directory and proves it writable. Raises
    :class:`CommandError` (exit status 2) naming ``option``."""
    _check_output(path, option, args, directory=False, resume_option=resume_option)


def check_output_dir(path: Path, option: str, args=None, *, resume_option: str | None = None,
                     overwrite: bool | None = None) -> None:
    """Before any work: may the output directory ``path`` be written (as :func:`check_output_file`;
    a directory holding files tofjax did not write is refused even with ``--overwrite``)?
    ``overwrite``: instead of ``args.overwrite`` (``record --resume`` adds to its ``--raw-dir``)."""
    _check_output(path, option, args, directory=True, resume_option=resume_option, overwrite=overwrite)


def _check_output(path, option, args, *, directory: bool, resume_option: str | None = None,
                  overwrite: bool | None = None) -> None:
    from .outputs import OutputError, check_output

    try:
        check_output(path, option, overwrite=bool(getattr(args, "overwrite", False)) if overwrite is None else overwrite,
                     force_measurement=bool(getattr(args, "force_replace_measurement", False)),
                     resume_option=resume_option, directory=directory)
    except OutputError as err:
        raise CommandError(str(err), 2) from None


def output_dir(path: Path, command: str, args=None):
    """The :class:`tofjax.outputs.OutputDir` of a command's output directory (replaced as a whole)."""
    from .outputs import OutputDir

    return OutputDir(path, command, replace=bool(getattr(args, "overwrite", False)))


#: The exit status of an interrupted command (Ctrl-C): 128 + SIGINT, as a shell reports it.
INTERRUPTED = 130


#: What the command has kept so far, for the line an interrupt (Ctrl-C) prints (:func:`on_interrupt`).
_interrupt_note: str | None = None


def on_interrupt(note: str | None) -> None:
    """Say what an interrupt now would leave behind, as the end of ``tofjax: interrupted ...``
    (``"after 5 of 20 points; every completed point is in ow.csv; continue with --resume"``); a
    command updates it as it goes."""
    global _interrupt_note
    _interrupt_note = note


def positive_int(text: str) -> int:
    """argparse type: an integer >= 1 (shared with the other packages' subcommands)."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not an integer") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"{value} is out of range: allowed integer >= 1")
    return value


def _seed(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not an integer") from None
    if not 0 <= value < 2**63:
        raise argparse.ArgumentTypeError(f"{value} is out of range: allowed 0 <= seed < 2^63")
    return value


def positive_float(text: str) -> float:
    """argparse type: a finite number > 0."""
    value = finite_float(text)
    if not value > 0:
        raise argparse.ArgumentTypeError(f"{value} is out of range: allowed value > 0")
    return value


def finite_float(text: str) -> float:
    """argparse type: a finite number."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"{text!r} is not a finite number")
    return value


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="tofjax", description="Physical, differentiable CW Time-of-Flight camera model.")
    parser.add_argument("--version", action="version", version=f"tofjax {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)

    sim = sub.add_parser("simulate", help="run a sweep and write a tofjax-sweep CSV",
                         description="Run a sweep over distance, background illuminance, integration time or "
                                     "the sensor's temperature and write the tofjax-sweep CSV. Sweep ranges, samples and iterations "
                                     "default to the configuration ([scene] *_from/*_to, samples; "
                                     "[pixel] iterations).")
    sim.add_argument("--config", type=Path, help="TOML configuration (default: built-in defaults)")
    sim.add_argument("--sweep", required=True, choices=SWEEPS, help="the swept quantity")
    units = ", ".join(axis.unit for axis in SWEEP_AXES.values())
    sim.add_argument("--from", dest="start", type=finite_float, help=f"sweep start, SI units ({units})")
    sim.add_argument("--to", dest="stop", type=finite_float, help=f"sweep end, SI units ({units})")
    sim.add_argument("--samples", type=positive_int, help="number of sweep samples")
    sim.add_argument("--iterations", type=positive_int, help="Monte Carlo frames per sample")
    sim.add_argument("--method", choices=("mc", "analytic"), default="mc",
                     help="mc: Monte Carlo frames (default); analytic: propagated variances")
    sim.add_argument("--seed", type=_seed, default=0, help="random seed of the Monte Carlo (default 0)")
    sim.add_argument("--fixed-pattern", action="store_true",
                     help="draw the taps' dark slopes from the pixel population (pixel.dark_slope_sigma_v_per_s)")
    sim.add_argument("--out", type=Path, help="output CSV (tofjax-sweep format); default DIR/sweep.csv with --report")
    sim.add_argument("--report", type=Path, metavar="DIR",
                     help="also write every applicable plot as PNG and a self-contained report.html into DIR")
    sim.add_argument("--check", action="store_true", help="validate everything, print the plan, compute nothing")
    sim.add_argument("--quiet", action="store_true", help="no progress report")
    add_output_options(sim)

    from ._presets import PRESETS

    cfg = sub.add_parser("config", help="print the full default configuration with comments",
                         description="Print the full default TOML configuration, a comment on every key "
                                     "(meaning, unit, allowed range). A file may name only what it changes. "
                                     "--preset prints a public camera instead, every key with its source or "
                                     "marked unknown.")
    cfg.add_argument("--preset", choices=tuple(PRESETS),
                     help="a public camera: " + "; ".join(f"{n}: {p.title}" for n, p in PRESETS.items()))
    cfg.add_argument("--out", type=Path, help="write to this file instead of standard output (its directory is made)")
    add_output_options(cfg)
    for ep in sorted(entry_points(group="tofjax.commands"), key=lambda e: e.name):
        ep.load()(sub)
    return parser


def _summary(result, elapsed_s: float, out: Path, timing: list[str]) -> str:
    """What ``tofjax simulate`` prints: up to ten rows of the sweep, the run, the caveats, the
    frame's ``timing`` lines (:func:`tofjax._timing.summary_lines`) (:class:`tofjax.report.Summary`
    as text)."""
    import numpy as np

    from .report import Section, Summary, Table

    axis = SWEEP_AXES[result.sweep_variable]
    values = np.asarray(result.sweep_values)
    rows = np.unique(np.linspace(0, len(values) - 1, min(len(values), 10)).round().astype(int))
    dist = np.asarray(result.distance_m)

    def cell(x, fmt):
        return "-" if np.isnan(float(x)) else format(float(x), fmt)

    # The swept quantity in the unit --from and --to take (seconds, not the plots' milliseconds).
    unit = axis.display_unit if axis.display_scale == 1.0 else axis.unit
    table = Table((f"{axis.name} [{unit}]", "unwrapped [m]", "depth std [mm]", "rel. std [%]",
                   "amplitude [LSB]", "valid [%]"), tuple(
        (format(values[i], ".4g"), cell(result.depth_unwrapped_mean_m[i], ".4f"),
         cell(1e3 * result.depth_std_m[i], ".3f"), cell(100 * result.depth_std_m[i] / dist[i], ".3f"),
         cell(result.amplitude_mean_lsb[i], ".1f"), cell(100 * result.valid_fraction[i], ".1f")) for i in rows))
    method = f"Monte Carlo, {result.n_frames} frames/sample" if result.method == "mc" else "analytic"
    lines = [f"{len(values)} samples ({method}); unambiguity range {float(result.unambiguity_range_m):.4f} m; "
             f"{elapsed_s:.2f} s; wrote {out}"]
    lines.extend(timing)
    lines.extend(f"note: {line}" for line in result.caveat_lines())
    du = float(result.unambiguity_range_m)
    spacing = float(np.max(np.abs(np.diff(dist)))) if len(dist) > 1 else 0.0
    if result.sweep_variable == "distance" and spacing > du / 2:
        lines.append(f"note: 'unwrapped' is the depth unwrapped along the sweep, which needs sample spacing below half the "
                     f"unambiguity range ({du / 2:.4g} m); here it is {spacing:.4g} m, so that column can be off by "
                     f"multiples of {du:.4g} m (the CSV's depth_unwrapped_mean_m; its depth_mean_m is the wrapped value); "
                     "take more --samples")
    return Summary(f"tofjax simulate: {axis.name} sweep", sections=[Section("", [table, *lines])]).text()


def _check_sweep_range(args) -> None:
    """``--from`` / ``--to`` against the swept quantity's range, naming the option (before any work)."""
    from ._schema import KEY_BY_DOTTED, in_range

    key = KEY_BY_DOTTED[SWEEP_AXES[args.sweep].key]
    for flag, x in (("--from", args.start), ("--to", args.stop)):
        if x is not None and not in_range(key, x):
            raise _UsageError(f"{flag} = {x!r} is out of range for the {args.sweep} sweep: allowed "
                              f"{key.range_text()} [{key.unit}]")
    if args.start is not None and args.stop is not None and not args.start < args.stop:
        raise _UsageError(f"--from = {args.start!r} must be less than --to = {args.stop!r}")
    # Sizes before any work: the results are held in memory (about 1 kB per sample; a million
    # samples peak at about 1.1 GB), the frames are chunked (any count runs in bounded memory).
    for flag, value, dotted, why in (("--samples", args.samples, "scene.samples",
                                      "a sweep's results are held in memory, about 1 kB per sample"),
                                     ("--iterations", args.iterations, "pixel.iterations", "frames per sample")):
        key = KEY_BY_DOTTED[dotted]
        if value is not None and not in_range(key, value):
            raise _UsageError(f"{flag} = {value} is out of range: allowed {key.range_text()}, as {dotted} ({why})")


def _simulate(args) -> int:
    import numpy as np

    from ._config import Config, load_config
    from ._run import fixed_pattern_problem, run_sweep, sweep_file_contents
    from .progress import Progress, compiling, reporting
    from .sweepfile import write_sweep

    if args.out is None and args.report is None:
        raise _UsageError("give --out FILE.csv, --report DIR, or both")
    out = args.out if args.out is not None else args.report / "sweep.csv"
    _check_sweep_range(args)
    config = load_config(args.config) if args.config else Config()
    sweep = config.sweep(args.sweep, args.start, args.stop, args.samples)
    params = config.params
    from ._camera import Camera
    from ._timing import summary_lines

    timing = summary_lines(Camera.from_config(config))  # refuses an impossible frame rate before any work
    iterations = args.iterations or config.iterations
    freqs = config.modulation_frequencies_hz
    problem = fixed_pattern_problem(config, args.method) if args.fixed_pattern else None
    if problem:
        raise _UsageError(f"--fixed-pattern {problem.replace('method ', '--method ')}")
    # Outputs before any work: a run must not end in "cannot write" after minutes.
    from .outputs import relative_inside

    in_report = relative_inside(out, args.report) if args.report is not None else None
    if args.report is not None:
        check_output_dir(args.report, "--report", args)
    if in_report is None:
        check_output_file(out, "--out", args)
    if args.method == "mc":
        images = sweep.samples * iterations * params.pixel.n_phases * len(freqs)
        plan = (f"{sweep.samples} samples x {iterations} frames x {params.pixel.n_phases} phase images"
                + (f" x {len(freqs)} frequencies" if len(freqs) > 1 else "") + f" = {images:.3g} phase images "
                "(Monte Carlo; memory bounded by chunks)")
    else:
        plan = f"{sweep.samples} samples (analytic)"
    if args.check:
        print(f"plan: {args.sweep} sweep, {plan}; into {out}" + (f" and {args.report}" if args.report else ""))
        return 0
    enable_compilation_cache(notice=False)  # the command says it (compiling, below), or --quiet does not
    on_interrupt(untouched_note(out, args.report))
    label = f"simulating {sweep.samples} samples" + (f" x {iterations} frames" if args.method == "mc" else "")
    with reporting(Progress(1, label, unit="chunk", enabled=not args.quiet)), compiling(enabled=not args.quiet):
        # The report's scatter plots show up to 200 frames per sample; a CSV needs none. The chunks
        # run from Python even when quiet, so that Ctrl-C stops the run between chunks.
        run = run_sweep(config, sweep, args.method, iterations, args.seed, args.fixed_pattern,
                        keep_frames=200 if args.report is not None else 0, progress=True)
    result, multi, elapsed = run.result, run.multifrequency, run.elapsed_s
    metadata, columns = sweep_file_contents(run, str(args.config) if args.config else "(built-in defaults)")
    replace = dict(replace=args.overwrite, replace_measurement=args.force_replace_measurement)
    with contextlib.ExitStack() as stack:
        folder = stack.enter_context(output_dir(args.report, "tofjax simulate", args)) if args.report else None
        try:
            write_sweep(out if in_report is None else folder.file(str(in_report)), metadata, columns, **replace)
            if folder is not None:
                from .report import write_report

                if not args.quiet:
                    print("writing the report ...", file=sys.stderr, flush=True)
                write_report(folder.staging, config, result, elapsed, out, multifrequency=multi, timing=timing)
        except OSError as err:
            raise _UsageError(f"cannot write {out}: {err.strerror or err}") from None
    print(_summary(result, elapsed, out, timing))
    if multi is not None:
        wrong = np.asarray(multi.wrong_unwrap_fraction)
        print(f"{len(freqs)} frequencies ({multi.fusion} fusion): extended range {float(multi.extended_range_m):.4f} m; "
              f"combined depth std {1e3 * np.nanmin(multi.depth_std_m):.3g}-{1e3 * np.nanmax(multi.depth_std_m):.3g} mm"
              + f"; wrong unwraps up to {100 * np.nanmax(wrong):.1f} % of valid frames"
              + (" (analytic: the closed form's union bound, an upper bound where it is large)"
                 if args.method == "analytic" else ""))
    if args.report is not None:
        print(f"report: {args.report / 'report.html'}")
    return 0


def untouched_note(*paths) -> str:
    """The interrupt note of a run that writes its outputs only at the end: ``before anything was
    written (sweep.csv is as before the run)``."""
    shown = [str(p) for p in paths if p is not None]
    existing = [p for p in shown if Path(p).exists()]
    if not existing:
        return "before anything was written (no output exists yet)"
    return "before anything was written (" + ", ".join(existing) + (" is" if len(existing) == 1 else " are") \
        + " as before the run)"


def _sigint(signum, frame):
    from .progress import interrupt, interrupt_now

    interrupt()
    if interrupt_now():  # else held_interrupt raises it when its step is done
        raise KeyboardInterrupt


def _unraisable(unraisable) -> None:
    """``sys.unraisablehook`` while a command runs: a Ctrl-C whose ``KeyboardInterrupt`` was raised where
    Python cannot raise it (a garbage-collector callback, JAX registers one; a weakref callback; a
    finaliser) is dropped there, printed as "Exception ignored in ..." with a traceback. Instead,
    nothing is printed and the interrupt is signalled again 20 ms later, when the run is past it
    (its own checks between chunks see the flag meanwhile). Anything else goes to the previous hook."""
    if isinstance(unraisable.exc_value, KeyboardInterrupt):
        threading.Timer(0.02, os.kill, (os.getpid(), signal.SIGINT)).start()
        return
    _previous_unraisable_hook(unraisable)


_previous_unraisable_hook = sys.unraisablehook


@contextlib.contextmanager
def interrupts():
    """Ctrl-C as a command takes it (on the main thread): :func:`_sigint` as the SIGINT handler and
    :func:`_unraisable` as ``sys.unraisablehook``, both restored afterwards."""
    global _previous_unraisable_hook
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous, _previous_unraisable_hook = signal.signal(signal.SIGINT, _sigint), sys.unraisablehook
    sys.unraisablehook = _unraisable
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)
        sys.unraisablehook = _previous_unraisable_hook


def main(argv: list[str] | None = None) -> int:
    on_interrupt(None)
    parser = build_parser()
    if not (sys.argv[1:] if argv is None else argv):  # `tofjax` alone: what it can do, not an error
        parser.print_help()
        return 0
    args = parser.parse_args(argv)
    from .progress import clear_interrupt

    clear_interrupt()
    with interrupts():
        return _run(args)


def _run(args) -> int:
    """A parsed command, its errors as one line and an exit status (inside :func:`interrupts`)."""
    from ._schema import ConfigError
    from .sweepfile import SweepFileError

    try:
        if getattr(args, "run", None) is not None:  # calibrate, record, ...: they compute, so cache
            enable_compilation_cache(fast_compile=args.command == "calibrate", notice=False)  # a command says it itself
            return args.run(args)
        if args.command == "config":
            from ._config import default_config_text
            from ._presets import preset_text

            text = preset_text(args.preset) if args.preset else default_config_text()
            if args.out:
                from .outputs import write_text

                check_output_file(args.out, "--out", args)  # makes the directory, as simulate does
                try:
                    write_text(args.out, text, replace=args.overwrite, replace_measurement=args.force_replace_measurement)
                except OSError as err:
                    raise _UsageError(f"cannot write {args.out}: {err.strerror or err}") from None
            else:
                print(text, end="")
            return 0
        return _simulate(args)
    except KeyboardInterrupt:
        print("tofjax: interrupted" + (f" {_interrupt_note}" if _interrupt_note else ""), file=sys.stderr, flush=True)
        return INTERRUPTED
    except CommandError as err:
        print(f"tofjax: error: {err}", file=sys.stderr)
        return err.exit_code
    except (ConfigError, SweepFileError, ValueError) as err:
        print(f"tofjax: error: {err}", file=sys.stderr)
        return 2


#: Commands of this package and its siblings that hold no device: their process ends without the
#: interpreter's teardown (:func:`entry_point`). ``record`` is not among them: it may hold a stage.
QUICK_EXIT = ("simulate", "config", "render", "compare", "calibrate")


def entry_point() -> None:  # pragma: no cover - thin wrapper for the console script
    """The ``tofjax`` command: :func:`main`'s status. After a command that holds no device, the process
    ends at once when its output is flushed: every file it wrote is complete and renamed into place
    by then (:mod:`tofjax.outputs`), and the interpreter's teardown (JAX's backends, the compiled
    programs, every module) took 0.4-0.6 s of a 6 s warm calibration.

    An interrupted command (status 130, ``record`` included) ends the same way, because a Ctrl-C
    that lands while JAX compiles leaves the compilation running: jaxlib waits for it in a way that
    checks for signals, so the ``KeyboardInterrupt`` comes out of that wait while XLA's thread pool
    goes on compiling (LLVM code generation). An ordinary exit then runs the C++ static destructors
    (LLVM's among them) under that thread, which aborted the process after the interrupt's line
    (``terminate called after throwing an instance of 'std::system_error'``, ``free(): invalid
    pointer``, ``LLVM ERROR``: exit status 134 or 139). By then the command has printed its line
    and closed its files and devices (``record``'s ``finally``), so nothing is left for the teardown
    to do."""
    code = main()
    if code == INTERRUPTED or (len(sys.argv) > 1 and sys.argv[1] in QUICK_EXIT):
        try:
            sys.stdout.flush()
            sys.stderr.flush()
        except OSError:  # a closed pipe: the ordinary exit reports it (not while a compilation may run)
            if code != INTERRUPTED:
                sys.exit(code)
        os._exit(code)
    sys.exit(code)


if __name__ == "__main__":  # pragma: no cover - python -m tofjax.cli
    # The commands reach this module's state (the interrupt note) as tofjax.cli, not as __main__.
    from tofjax.cli import entry_point as _entry_point

    _entry_point()
