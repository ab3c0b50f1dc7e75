"""The calibration workflow: files + configuration -> least squares (-> posterior) -> outputs.

:func:`calibrate` mirrors ``tofjax calibrate``; :meth:`Calibration.write` writes the calibrated
configuration (TOML, usable by ``tofjax simulate``), a JSON of estimates, uncertainties,
correlations and diagnostics, PNG figures and a short Markdown report.
"""

from __future__ import annotations

import dataclasses
import importlib
import json
from pathlib import Path
from typing import TYPE_CHECKING

import jax
import jax.numpy as jnp
import numpy as np
import tofjax as tj
from tofjax.outputs import save_figure, write_text
from tofjax.report import Code, Figure, Section, Summary, Table
from tofjax.schema import SWEEP_AXES, get_leaf, render_toml
from tofjax.sweepfile import BOUND_RELATIONS, utc_now

from ._bounds import PINNED_WIDTH, BoundsAtSolution, bounds_at, headline, physical_flags, row_lines
from ._compare import FileComparison, compare_measurements, write_comparison
from ._data import OBSERVABLES, SweepRows, load_rows, read_measurement, reason_kind
from ._least_squares import ConvergenceError, LeastSquaresResult, fit_least_squares
from ._parameters import CalibrationInputError, make_parameters
from ._problem import (ANCHOR_LINEAR_WIDTH, BOUND_MARGIN, BOUND_SCALE, VALID_MARGIN, Problem, batched_curves,
                       build_problem, hard_observables, nearest_period)

if TYPE_CHECKING:  # emcee (and scipy through it) are imported only when a posterior is sampled
    from ._posterior import PosteriorResult

_LABEL = {"amplitude_mean_lsb": "amplitude [LSB]", "depth_std_m": "depth noise [mm]",
          "depth_mean_m": "depth error: mean reading - distance [mm]"}
_SCALE = {"amplitude_mean_lsb": 1.0, "depth_std_m": 1e3, "depth_mean_m": 1e3}


@dataclasses.dataclass
class Calibration:
    """Everything a calibration produced."""

    config: tj.Config
    rows: list[SweepRows]
    problem: Problem
    least_squares: LeastSquaresResult
    posterior: PosteriorResult | None
    #: With ``leave_out_invalid``: rows the fitted model could not measure (saturated or no value),
    #: left out and refitted: ``{"file", "line", "reason"}``.
    excluded_at_solution: list[dict] = dataclasses.field(default_factory=list)
    #: Rows the fitted model cannot measure although the camera did (the validity constraint could
    #: not hold them), kept in the fit: ``{"file", "line", "reason"}``; empty when it explains every row.
    unexplained: list[dict] = dataclasses.field(default_factory=list)
    #: Rows the validity constraint holds at the edge of a limit (headroom below twice the margin):
    #: ``{"file", "line", "headroom"}``; the data there ask for the dynamic range the model has.
    at_limit: list[dict] = dataclasses.field(default_factory=list)
    #: The command line that produced it (set by the CLI).
    command: str = ""
    #: Where files state bounds: which hold at the solution, which are active, the interval of every
    #: free parameter and whether the bounds pin it, and the physical limits the fitted values break
    #: (:class:`fitting._bounds.BoundsAtSolution`); ``None`` without bounds.
    bounds: BoundsAtSolution | None = None

    @property
    def estimates(self) -> dict[str, float]:
        return dict(zip(self.least_squares.names, map(float, self.least_squares.estimate), strict=True))

    def with_posterior(self, *, walkers: int = 32, steps: int = 2000, seed: int = 0, backend=None,
                       resume: bool = False, progress: bool = False) -> Calibration:
        """This calibration with its posterior sampled from the least-squares solution, without
        fitting again (:func:`fitting.sample_posterior`; arguments as :func:`calibrate`'s).
        ``calibrate(..., mcmc=True)`` is ``calibrate(...).with_posterior(...)``."""
        if not self.least_squares.converged:
            raise ConvergenceError("the least squares did not converge: no posterior to sample from its solution "
                                   f"({self.least_squares.solver_message})")
        from ._posterior import sample_posterior

        post = sample_posterior(self.problem, self.least_squares, walkers=walkers, steps=steps, seed=seed,
                                backend_path=backend, resume=resume, progress=progress)
        return dataclasses.replace(self, posterior=post)

    def calibrated_config(self) -> tj.Config:
        """The input configuration with the least-squares estimates; :class:`tofjax.ConfigError` where
        they break its checks (a quantum efficiency above 1: :attr:`refused`)."""
        config = self.config
        for name, value in self.estimates.items():
            config = config.replace(name, value)
        return config

    @property
    def refused(self) -> str | None:
        """Why the configuration's checks refuse the estimates (a quantum efficiency above 1), or
        ``None`` where they accept them: no ``calibrated.toml`` is written then."""
        try:
            self.calibrated_config()
        except (tj.ConfigError, ValueError) as err:
            return str(err)
        return None

    def as_dict(self) -> dict:
        return {
            "software": f"tofjax {tj.__version__}", "created_utc": utc_now(),
            "command": self.command, "configuration": self.config.values,
            "files": [{"path": r.path, "sweep": r.sweep_variable, "rows": r.n_rows,
                       "frequencies_hz": list(r.frequencies_hz), "fusion": r.fusion,
                       "residuals": {name: int(len(r.used(name))) for name in OBSERVABLES},
                       "excluded_rows": r.excluded,
                       "left_out": {str(int(r.lines[i])) if r.lines is not None else str(i): why
                                    for i, why in sorted(r.reasons.items())}} for r in self.rows],
            "excluded_at_solution": self.excluded_at_solution, "unexplained": self.unexplained,
            "at_limit": self.at_limit,
            "true_values": true_values(self),
            "bounds": self.bounds.as_dict(self.rows) if self.bounds is not None else None,
            "calibrated_config_refused": self.refused,
            "least_squares": self.least_squares.as_dict(),
            "posterior": self.posterior.as_dict() if self.posterior is not None else None,
        }

    def write(self, out: str | Path) -> list[Path]:
        """Write all outputs into directory ``out`` (created if needed); returns the paths."""
        out = Path(out)
        out.mkdir(parents=True, exist_ok=True)
        written = []
        header = "".join(f"# calibrated by tofjax calibrate from {r.path}\n" for r in self.rows)
        if self.refused is None:  # else the report says why (a quantum efficiency above 1)
            toml_path = out / "calibrated.toml"
            written.append(write_text(toml_path, header + render_toml(self.calibrated_config().values)))
        json_path = out / "calibration.json"
        write_text(json_path, json.dumps(self.as_dict(), indent=2))
        written.append(json_path)
        comparisons = self.comparisons()
        written += _figures(self, out, comparisons)
        for stem, which in (("compare_initial", 0), ("compare_calibrated", 1)):  # their tables; the figures above
            if all(c[which] is not None for c in comparisons):
                written += write_comparison([c[which] for c in comparisons], out, stem=stem, figures=False,
                                            title=f"Measured vs model, {stem.split('_')[1]} parameters")
        report = _report(self, [p for p in written if p.suffix == ".png"
                                and p.name.startswith(("fit_", "residuals", "corner"))], comparisons)
        for name, text in (("report.md", report.markdown()), ("report.html", report.html())):
            written.append(write_text(out / name, text))
        return written

    def comparisons(self) -> list[tuple[FileComparison, FileComparison | None]]:
        """Per file, the comparison (:func:`fitting.compare`) with the initial and with the
        calibrated parameters (``None`` where the configuration refuses those: :attr:`refused`)."""
        before = [read_measurement(r.path, self.config) for r in self.rows]
        if self.refused is not None:
            return [(c, None) for c in compare_measurements(before)]
        calibrated = self.calibrated_config()
        after = [read_measurement(r.path, calibrated) for r in self.rows]
        both = compare_measurements(before + after)
        return list(zip(both[: len(before)], both[len(before):], strict=True))


def calibrate(paths, config: tj.Config | None = None, *, fit, bounds=None, priors=None,
              relative_error: float | None = None, min_snr: float = 5.0, smooth: tj.Smooth | None = None,
              mcmc: bool = False, walkers: int = 32, steps: int = 2000, seed: int = 0, backend=None,
              resume: bool = False, progress: bool = False, max_steps: int = 1000,
              initial: dict[str, float] | None = None, leave_out_invalid: bool = False) -> Calibration:
    """Calibrate the parameters ``fit`` (dotted names) against sweep files.

    **Arguments:**
    - ``paths``: tofjax-sweep files (each with its operating points per row).
    - ``config``: the camera (:class:`tofjax.Config`; default: built-in defaults). Its values are the
      starting point; a file's metadata may override keys for that file.
    - ``fit``: names such as ``pixel.demodulation_contrast``; ``bounds``: ``{name: (lo, hi)}``
      (default: the configuration's validation range); ``priors``: ``{name: (mean, sigma)}``.
    - ``relative_error``: replace every row's uncertainty by this fraction of its value.
    - ``min_snr``: rows whose measured amplitude mean / std is below it are left out.
    - ``mcmc``, ``walkers``, ``steps``, ``seed``, ``backend``, ``resume``, ``progress``: posterior
      sampling (see :func:`fitting.sample_posterior`).
    - ``max_steps``: least-squares step limit; ``initial``: ``{name: value}`` starting values
      (default: the configuration's).

    **Every measured point constrains the fit:** a camera that delivered a row was neither saturated
    nor at an ADC rail there, so by default the fit holds every row it uses where the hard model
    measures it (the validity penalty, :mod:`fitting._problem`): the solution keeps each row's
    headroom (:attr:`tofjax.Result.headroom`) above :data:`~fitting._problem.VALID_MARGIN`. Rows it
    holds at that edge are listed in ``Calibration.at_limit`` (the data ask for the dynamic range the
    model has: free the full well, the saturation voltage or the ADC's range with ``fit`` where the
    data sheet leaves them open); rows the hard model still cannot measure at the solution stay in
    the fit and are named in ``Calibration.unexplained``. ``leave_out_invalid=True`` is the older,
    explicit alternative: no penalty; rows the fitted hard model saturates (pixel or ADC) or cannot
    measure are left out, named in ``Calibration.excluded_at_solution`` (file, line, reason), and the
    fit is repeated from the estimate, up to :data:`MAX_REFITS` times (if no row is left,
    :class:`CalibrationInputError` names them).

    **Published specifications** (format 4 files, ``source: specification``; bounds beside measured
    columns too): each bound row holds the model on its met side (a one-sided residual,
    :mod:`fitting._problem`), judged as ``tofjax compare`` judges it. With no measured row at all the
    fit is the smallest change from the starting configuration that meets every bound (a change
    residual per free parameter: ln(value / start) / ln 2 for a positive one). ``Calibration.bounds``
    (:class:`fitting.BoundsAtSolution`) says which bounds hold at the solution and which are active,
    each free parameter's interval over which they still hold and whether they pin it, and the
    physical limits the estimate breaks (laser class 1 by the eye-safety estimate, a quantum
    efficiency above 1, a parameter at the edge of its range: :func:`fitting.physical_flags`).

    An unconverged least squares still returns (``least_squares.converged`` is ``False``; no
    posterior is sampled), so its diagnostics can be written; the CLI then exits with status 1.
    """
    config = config if config is not None else tj.Config()
    rows, parameters = check_inputs(paths, config, fit=fit, bounds=bounds, priors=priors,
                                    relative_error=relative_error, min_snr=min_snr, initial=initial)
    problem = build_problem(parameters, rows, smooth, relative_error, validity=not leave_out_invalid)

    def meanwhile():  # what follows the fit: the hard model's program, and matplotlib for the figures
        _hard_at(problem, problem.initial)
        importlib.import_module("matplotlib.backends.backend_agg")

    ls = fit_least_squares(problem, rows, max_steps=max_steps, throw=False, meanwhile=meanwhile)
    excluded: list[dict] = []
    unexplained: list[dict] = []
    edge: list[dict] = []
    if leave_out_invalid:
        for _ in range(MAX_REFITS):
            bad = invalid_at(problem, ls.estimate, rows)
            if not bad:
                break
            for i, k, reason in bad:
                r = rows[i]
                for name in OBSERVABLES:
                    r.data[name][1][k] = False
                r.reasons[k] = reason
                r.excluded["at_solution"] = r.excluded.get("at_solution", 0) + 1
                excluded.append({"file": r.path, "line": r.line(k), "reason": reason})
            if sum(len(r.used(n)) for r in rows for n in OBSERVABLES) < len(parameters):
                raise CalibrationInputError("the fitted model cannot measure the rows the fit needs: "
                                            + "; ".join(f"{Path(e['file']).name}:{e['line']}: {e['reason']}" for e in excluded))
            parameters = tuple(dataclasses.replace(p, initial=_inside(p, float(v)))
                               for p, v in zip(parameters, ls.estimate, strict=True))
            problem = build_problem(parameters, rows, smooth, relative_error, validity=False)
            ls = fit_least_squares(problem, rows, max_steps=max_steps, throw=False)
        hard = _hard_at(problem, ls.estimate) if problem.bounded else None
    else:
        hard = _hard_at(problem, ls.estimate)  # the hard model at the estimate, once for both lists
        unexplained = [{"file": rows[i].path, "line": rows[i].line(k),
                        "reason": f"{reason}, where the camera measured it"}
                       for i, k, reason in invalid_at(problem, ls.estimate, rows, hard)]
        edge = at_limit(problem, ls.estimate, rows, hard)
    bounds = None
    if problem.bounded:  # which bounds hold, which keys they pin, which physical limits the estimate breaks
        bounds = bounds_at(problem, ls.estimate, rows, hard)
        bounds.physical = physical_flags(config, rows, problem, ls.estimate)
    cal = Calibration(config, rows, problem, ls, None, excluded, unexplained, edge, bounds=bounds)
    if mcmc and ls.converged:
        cal = cal.with_posterior(walkers=walkers, steps=steps, seed=seed, backend=backend, resume=resume,
                                 progress=progress)
    return cal


#: Refits after leaving out rows the fitted model cannot measure.
MAX_REFITS = 3


def _inside(p, value: float) -> float:
    """``value`` moved strictly inside ``p``'s bounds (a refit starts where the last fit ended)."""
    lo, hi = p.lower, p.upper
    if lo is not None and hi is not None:
        margin = 1e-6 * (hi - lo)
        return min(max(value, lo + margin), hi - margin)
    if lo is not None:
        return max(value, lo + 1e-6 * max(abs(lo), abs(value), 1e-300))
    return value




def _used(r: SweepRows) -> np.ndarray:
    """Which of ``r``'s rows enter the fit (any observable)."""
    used = np.zeros(r.n_rows, bool)
    for name in OBSERVABLES:
        used |= r.data[name][1]
    return used


def _hard_at(problem: Problem, theta) -> list[tuple]:
    """Per file used by the fit: (file index, its rows' slice of the group, the hard model's
    observables of its group at ``theta``), each group's model evaluated once."""
    out = []
    for group in problem.groups:
        obs = hard_observables(problem.with_values(group.params, jnp.asarray(theta)), group.model_sweep(dense=False),
                               group.frequencies_hz, group.fusion, group.processing)  # host arrays
        out += [(i, slice(*bounds), obs) for i, bounds in zip(group.files, group.bounds, strict=True)]
    return out


def at_limit(problem: Problem, theta, rows: list[SweepRows], hard: list[tuple] | None = None) -> list[dict]:
    """Rows used by the fit that the hard model at ``theta`` measures with a headroom below twice the
    validity margin (:data:`~fitting._problem.VALID_MARGIN`): where the constraint holds the solution.
    ``hard``: :func:`_hard_at` of ``theta``, if evaluated."""
    out = []
    for i, rows_of, obs in _hard_at(problem, theta) if hard is None else hard:
        headroom = np.asarray(obs.headroom)[rows_of]
        for k in np.flatnonzero(_used(rows[i]) & (headroom > 0.0) & (headroom < 2 * VALID_MARGIN)):
            out.append({"file": rows[i].path, "line": rows[i].line(k), "headroom": float(headroom[k])})
    return out


def invalid_at(problem: Problem, theta, rows: list[SweepRows], hard: list[tuple] | None = None
               ) -> list[tuple[int, int, str]]:
    """Rows used by the fit that the hard model at ``theta`` cannot measure: (file index, row,
    reason). ``hard``: :func:`_hard_at` of ``theta``, if evaluated."""
    out = []
    for i, rows_of, obs in _hard_at(problem, theta) if hard is None else hard:
        pixel, adc, depth_std, amplitude = (np.asarray(x)[rows_of] for x in (
            obs.pixel_saturated_fraction, obs.adc_saturated_fraction, obs.depth_std_m, obs.amplitude_mean_lsb))
        finite = np.isfinite(depth_std) & np.isfinite(amplitude)
        for k in np.flatnonzero(_used(rows[i]) & ((pixel > 0) | (adc > 0) | ~finite)):
            reason = ("the fitted model saturates the pixel here" if pixel[k] > 0 else
                      "the fitted model saturates the ADC here" if adc[k] > 0 else
                      "the fitted model has no value here")
            out.append((i, int(k), reason))
    return out


def true_values(cal: Calibration) -> list[dict]:
    """Fitted parameters whose true value a file states (``# true.<name>: value``, as simulated
    examples do): estimate, truth, and the deviation in sigmas."""
    ls = cal.least_squares
    out = []
    for k, name in enumerate(ls.names):
        stated = {r.metadata.get(f"true.{name}") for r in cal.rows} - {None}
        if len(stated) != 1:
            continue
        truth = float(stated.pop())
        z = (ls.estimate[k] - truth) / ls.sigma[k] if np.isfinite(ls.sigma[k]) and ls.sigma[k] > 0 else float("nan")
        verdict = ("consistent" if abs(z) < 2 else "in tension (2-3 sigma)" if abs(z) < 3 else "inconsistent (> 3 sigma)") \
            if np.isfinite(z) else "undetermined"
        out.append({"name": name, "estimate": float(ls.estimate[k]), "sigma": float(ls.sigma[k]), "true": truth,
                    "deviation_sigma": float(z), "verdict": verdict})
    return out


def posterior_notes(cal: Calibration) -> list[str]:
    """Where the posterior and the least squares disagree, why, and which to quote: one line per
    fitted parameter whose least-squares estimate lies outside the posterior's 68 % interval (empty
    without a posterior). The two answer different questions: the least squares minimises chi^2
    alone; the posterior weighs the whole likelihood, whose uncertainties are the model's own and so
    carry their normalisation -sum log sigma_i(theta) (docs/fitting.md "Uncertainties"), under the
    prior (uniform within the bounds, or --prior's Gaussian), and reports quantiles of a
    distribution that need not be Gaussian."""
    ls, post, problem = cal.least_squares, cal.posterior, cal.problem
    if post is None:
        return []
    out = []
    for k, name in enumerate(ls.names):
        j = post.names.index(name)
        lo, median, hi, estimate = post.p16[j], post.median[j], post.p84[j], ls.estimate[k]
        if lo <= estimate <= hi:
            continue
        unit = "" if ls.units[k] in ("1", "") else f" {ls.units[k]}"
        lower, upper = float(problem.lower[k]), float(problem.upper[k])
        bounds = {"both": f"uniform within its bounds {lower:g}-{upper:g}{unit}",
                  "lower": f"uniform above its bound {lower:g}{unit}"}.get(problem.kinds[k], "uniform")
        prior = (f"Gaussian {float(problem.prior_mean[k]):g} +- {float(problem.prior_sigma[k]):g}{unit}"
                 if float(problem.prior_sigma[k]) > 0 else bounds)
        skew = (hi - median) / (median - lo) if median > lo else float("inf")
        shape = (f"; its posterior is skewed ({median - lo:.3g} below the median, {hi - median:.3g} above)"
                 if not 0.67 < skew < 1.5 else "")
        out.append(f"{name}: the least-squares estimate {estimate:.6g} lies outside the posterior's 68 % interval "
                   f"[{lo:.6g}, {hi:.6g}]: the least squares minimises chi^2 alone, the posterior weighs the whole "
                   "likelihood, whose uncertainties are the model's and carry their normalisation -sum log sigma_i "
                   f"(a parameter that changes the predicted noise moves its peak), under a prior {prior}{shape}. "
                   f"Quote the posterior: median {median:.6g}{unit}, 68 % in [{lo:.6g}, {hi:.6g}]; calibrated.toml holds "
                   "the least-squares estimate (docs/fitting.md \"Posterior\")")
    return out


#: Rows of all files together that one calibration evaluates at once. Peak memory grows by about
#: 4 kB per row (measured with one fitted parameter: 2 000 rows 0.61 GB, 20 000 rows 0.68 GB), so
#: this bounds a calibration to about 1.5 GB.
MAX_ROWS = 200_000


def check_inputs(paths, config: tj.Config, *, fit, bounds=None, priors=None, relative_error: float | None = None,
                 min_snr: float = 5.0, initial: dict[str, float] | None = None):
    """Read and validate the files and the names, bounds and priors (what :func:`calibrate` does
    before any computation); returns ``(rows, parameters)``."""
    if isinstance(paths, (str, Path)):
        paths = [paths]
    if not paths:
        raise ValueError("no sweep file given")
    names = [fit] if isinstance(fit, str) else list(fit)
    starts = {name: float(get_leaf(config.params, name)) for name in names if _known(name)}
    for name, value in (initial or {}).items():
        if name not in names:
            raise CalibrationInputError(f"--initial: {name} is not fitted (--fit)")
        starts[name] = float(value)
    parameters = make_parameters(names, starts, bounds, priors)
    rows = [load_rows(p, config, relative_error=relative_error, min_snr=min_snr) for p in paths]
    total = sum(r.n_rows for r in rows)
    if total > MAX_ROWS:
        raise CalibrationInputError(f"{total:,} rows in {len(rows)} file(s): allowed at most {MAX_ROWS:,} rows in one "
                                    "calibration (the model is evaluated on all of them at once); average repeated "
                                    "points or thin the sweep")
    return rows, parameters


def _known(name: str) -> bool:
    from ._parameters import fittable_names

    return name in fittable_names()


def _bands(cal: Calibration):
    """Per file: (dense x in SI units, model curves (2, n) at the estimate, 68 % band lo and hi or None).

    The band comes from posterior draws, or from linear propagation of the least-squares covariance
    (None where a parameter is undetermined)."""
    problem, ls = cal.problem, cal.least_squares
    lin = ls.linearization
    if cal.posterior is not None:
        rng = np.random.default_rng(0)
        draws = cal.posterior.samples[rng.choice(len(cal.posterior.samples), size=min(200, len(cal.posterior.samples)),
                                                 replace=False)]
        per_draw = jax.device_get(batched_curves(problem, jnp.asarray(draws)))
        limits = [(np.percentile(c, 16, axis=0), np.percentile(c, 84, axis=0)) for c in per_draw]
    elif problem.bounds_only:  # a specification states no uncertainty: no band
        limits = [(None, None)] * len(problem.groups)
    elif np.all(np.isfinite(ls.unconstrained_covariance)):
        limits = []
        for centre, jac in zip(lin.curves, lin.curves_jacobian, strict=True):  # jac: (files, 2, n, params) in u
            sd = np.sqrt(np.einsum("foip,pq,foiq->foi", jac, ls.unconstrained_covariance, jac))
            limits.append((centre - sd, centre + sd))
    else:
        limits = [(None, None)] * len(problem.groups)
    out = {}
    for group, centre, (lo, hi) in zip(problem.groups, lin.curves, limits, strict=True):
        for k, i in enumerate(group.files):
            column = np.asarray(getattr(group.sweep, SWEEP_AXES[cal.rows[i].sweep_variable].column))[group.n_data:]
            out[i] = (column.reshape(len(group.files), -1)[k], np.asarray(centre)[k],
                      None if lo is None else lo[k], None if hi is None else hi[k])
    return out


#: The fit figure's panel of each bounded quantity (the depth error's bound: on the mean reading's panel).
_BOUND_PANEL = {"amplitude_mean_lsb": "amplitude_mean_lsb", "depth_std_m": "depth_std_m", "depth_error_m": "depth_mean_m"}

#: A comparison's dense curve per fitted observable (the depth mean's panel shows the depth error).
_COMPARE_CURVE = {"amplitude_mean_lsb": "amplitude_mean_lsb", "depth_std_m": "depth_std_m",
                  "depth_mean_m": "depth_error_m"}


def _figures(cal: Calibration, out: Path, comparisons=()) -> list[Path]:
    """One figure per file (its observables: the data with their sigmas, the fitted model and its 68 %
    band, the initial model from ``comparisons``' first of each pair, the rows left out by kind), the
    residuals, and the posterior's corner plot. Laid out by hand with one legend per figure:
    constrained layout and a legend per panel placed by "best" cost most of a figure's time."""
    from matplotlib.figure import Figure

    written = []
    bands = _bands(cal)
    for i, rows in enumerate(cal.rows):
        axis = SWEEP_AXES[rows.sweep_variable]
        label, xs = axis.axis_label, axis.display_scale
        dense_x, centre, lo, hi = bands[i]
        initial = comparisons[i][0] if comparisons else None
        x_all = np.asarray(rows.sweep.values) * xs
        fig = Figure(figsize=(15, 4.4))
        fig.subplots_adjust(left=0.05, right=0.99, top=0.84, bottom=0.12, wspace=0.25)
        axes = fig.subplots(1, len(OBSERVABLES))
        evaluated = cal.least_squares.evaluated[i]
        period = float(rows.config.params.unambiguity_range_m)
        kinds: dict[str, list[int]] = {}
        for k, why in rows.reasons.items():
            kinds.setdefault(reason_kind(why), []).append(k)
        for k, (ax, name) in enumerate(zip(axes, OBSERVABLES, strict=True)):
            data = rows.data[name][0]
            if name == "depth_mean_m":  # the systematic error: the reading against the true distance
                truth = np.asarray(rows.sweep.distance_m)
                data = np.asarray(nearest_period(data, truth, period)) - truth
            idx = rows.used(name)
            values, sigma = data[idx], np.asarray(evaluated[k][1])[idx]
            scale = _SCALE[name]
            xd = dense_x * xs
            if not np.any(np.isfinite(rows.data[name][0])):
                ax.text(0.5, 0.9, f"{name}: not measured in the file" + (" (its bounds: dashed)" if any(
                    _BOUND_PANEL[b.quantity] == name for b in rows.bounds) else " (model only)"),
                    transform=ax.transAxes, ha="center", color="grey")
            for n_kind, (kind, ks) in enumerate(sorted(kinds.items())):  # rows left out, greyed, by kind
                shown = [j for j in ks if np.isfinite(data[j])]
                if shown:
                    ax.plot(x_all[shown], data[shown] * scale, "x", ms=5, color=("0.55", "0.35", "0.7", "0.2")[n_kind % 4],
                            label=f"left out ({len(ks)} rows): {kind}")
            if lo is not None:
                ax.fill_between(xd, lo[k] * scale, hi[k] * scale, color="C1", alpha=0.3, label="model 68 % band")
            if initial is not None:
                ax.plot(initial.dense_x * xs, initial.dense[_COMPARE_CURVE[name]] * scale, color="0.5", ls="--", lw=0.9,
                        label="initial model")
            ax.plot(xd, centre[k] * scale, color="C1", label="fitted model")
            for b in rows.bounds:  # a datasheet's bound where it holds, in the panel of its quantity
                if _BOUND_PANEL[b.quantity] != name:
                    continue
                ok = np.isfinite(b.values)
                order = np.argsort(x_all[ok])
                for sign in (1.0, -1.0) if b.quantity == "depth_error_m" else (1.0,):  # the error's magnitude
                    ax.plot(x_all[ok][order], sign * b.values[ok][order] * scale, "C3--", lw=1.0, marker="_",
                            label=f"bound ({BOUND_RELATIONS[b.relation]})")
            ax.errorbar(x_all[idx], values * scale, yerr=sigma * scale, fmt="o", ms=3, color="C0", label="data")
            ax.set_xlabel(label)
            ax.set_ylabel(_LABEL[name])
            ax.grid(alpha=0.3)
        legend = {}
        for ax in axes:
            for handle, text in zip(*ax.get_legend_handles_labels(), strict=True):
                legend.setdefault(text, handle)
        fig.legend(list(legend.values()), list(legend), loc="upper right", ncols=3, fontsize=7, frameon=False)
        fig.suptitle(Path(rows.path).name, x=0.05, ha="left")
        path = out / f"fit_{i}_{Path(rows.path).stem}.png"
        save_figure(fig, path, dpi=110)
        written.append(path)

    evaluated = cal.least_squares.evaluated
    height = 2.6 * len(cal.rows) + 0.4
    fig = Figure(figsize=(8, height))
    fig.subplots_adjust(left=0.1, right=0.98, top=1 - 0.65 / height, bottom=0.5 / height, hspace=0.6)
    axes = fig.subplots(len(cal.rows), 1, squeeze=False)
    for i, rows in enumerate(cal.rows):
        ax = axes[i, 0]
        axis = SWEEP_AXES[rows.sweep_variable]
        label, xs = axis.axis_label, axis.display_scale
        for k, name in enumerate(OBSERVABLES):
            idx = rows.used(name)
            model, sigma = (np.asarray(a)[idx] for a in evaluated[i][k])
            r = (model - rows.data[name][0][idx]) / sigma
            ax.plot(np.asarray(rows.sweep.values)[idx] * xs, r, "o", ms=3, color=f"C{k}", label=name)
        for level in (-2, -1, 1, 2):
            ax.axhline(level, color="grey", lw=0.6, ls=":" if abs(level) == 2 else "--")
        ax.axhline(0, color="k", lw=0.6)
        ax.set_xlabel(label)
        ax.set_ylabel("(model - data) / sigma")
        ax.set_title(Path(rows.path).name, fontsize=9)
    fig.legend(*axes[0, 0].get_legend_handles_labels(), loc="upper center", ncols=len(OBSERVABLES), fontsize=8,
               frameon=False)
    path = out / "residuals.png"
    save_figure(fig, path, dpi=110)
    written.append(path)

    if cal.posterior is not None and len(cal.posterior.names) == 1:  # corner needs two or more
        post = cal.posterior
        fig = Figure(figsize=(4.5, 3.4), layout="constrained")
        ax = fig.subplots()
        ax.hist(np.asarray(post.samples)[:, 0], bins=40, color="C0", alpha=0.7)
        for q, style in ((post.p16[0], "--"), (post.median[0], "-"), (post.p84[0], "--")):
            ax.axvline(q, color="k", ls=style, lw=0.8)
        ax.axvline(cal.least_squares.estimate[0], color="C1", lw=1, label="least squares")
        ax.set_xlabel(f"{post.names[0]} [{cal.least_squares.units[0]}]")
        ax.set_ylabel("samples")
        ax.legend(fontsize=8)
        path = out / "corner.png"
        save_figure(fig, path, dpi=100)
        written.append(path)
    elif cal.posterior is not None and len(cal.posterior.samples) > len(cal.posterior.names):
        import corner

        size = 3.2 * len(cal.posterior.names)
        fig = corner.corner(cal.posterior.samples, labels=[n.split(".")[1] for n in cal.posterior.names],
                            truths=cal.least_squares.estimate, quantiles=[0.16, 0.5, 0.84], show_titles=True,
                            title_fmt=".4g", title_kwargs={"fontsize": 8}, label_kwargs={"fontsize": 8},
                            fig=Figure(figsize=(size, size)))
        path = out / "corner.png"
        save_figure(fig, path, dpi=100)
        written.append(path)
    return written


def bounds_section(cal: Calibration) -> list:
    """The report's "Published bounds" section: how the bounds entered, which hold at the solution,
    which are active, each free parameter's interval and whether the bounds pin it, and the physical
    limits the estimate breaks."""
    b, problem, ls = cal.bounds, cal.problem, cal.least_squares
    how = ("Each bound row is a one-sided constraint: a residual (ln(model / bound) + "
           f"{BOUND_MARGIN:g}) / {BOUND_SCALE:g} for an upper bound (ln(bound / model) + {BOUND_MARGIN:g} for a lower "
           "one) where positive, 0 elsewhere: near the bound (model - bound) / (1e-4 bound), holding the model 0.1 % "
           "inside it. The quantities are judged as tofjax compare judges them (the depth error is the camera's reading "
           "minus the true distance); a bound row is also held where the hard model measures it.")
    if problem.bounds_only:
        how += (" No file holds a measured value, so the fit is the smallest change from the configuration that "
                "meets every bound: a residual per free parameter, ln(value / initial) / ln 2 for a positive parameter "
                "(a factor 2 either way costs as much as one standard deviation), (value - initial) / "
                f"{ANCHOR_LINEAR_WIDTH:g} of its allowed interval otherwise, and any --prior's (value - mean) / sigma. "
                "A specification states no uncertainty: the sigmas below are the prior's width and the bounds' "
                "stiffness, not a measurement; the intervals say what the bounds allow.")
    else:
        how += " The measured rows are fitted as usual; the bounds constrain the fit."
    out: list = [how, headline(b)]
    rows = []
    for p, initial in zip(b.intervals, ls.initial, strict=True):
        why = {side: (f"{Path(p[f'{side}_breaks']['file']).name} line {p[f'{side}_breaks']['line']} "
                      f"({p[f'{side}_breaks']['column']})") if p[f"{side}_breaks"] else
               {"range": "its own bound", "scan": "none within the scan", None: ""}[p[f"{side}_end"]]
               for side in ("lower", "upper")}
        span = ("", "") if p["lower"] is None else (f"{p['lower']:.4g}", f"{p['upper']:.4g}")
        rows.append((p["name"], p["unit"], f"{initial:.6g}", f"{p['value']:.6g}", p["status"], *span, why["lower"],
                     why["upper"]))
    out += [f"Per free parameter, the interval over which every bound that holds at the solution still holds, the "
            "others at the solution (a scan of the hard model); pinned where a bound breaks within "
            f"{PINNED_WIDTH:g} change widths of the solution on that side (a factor {2 ** PINNED_WIDTH:.3g} of a "
            "positive parameter): an active bound holds it there, or the interval is that narrow.",
            Table(("parameter", "unit", "initial", "estimate", "held by the bounds", "from", "to", "broken below by",
                   "broken above by"), tuple(rows))]
    lines = row_lines(b)
    if lines:
        out += ["Bound rows active or not met at the solution (file, line, column):", lines]
    if b.physical:
        out += ["Physical limits the estimate breaks:", [f["message"] for f in b.physical]]
    if cal.refused:
        out += ["calibrated.toml is not written: the configuration refuses the estimates: " + cal.refused]
    return out


def _report(cal: Calibration, figures: list[Path], comparisons=()) -> Summary:
    """The calibration report (:class:`tofjax.report.Summary`: ``report.md`` and ``report.html``)."""
    ls, post = cal.least_squares, cal.posterior
    report = Summary("Calibration report", [f"tofjax {tj.__version__}, {utc_now()}"])
    if cal.command:
        report.sections.append(Section("Command", [Code(cal.command)]))
    data = []
    for r in cal.rows:
        used = ", ".join(f"{len(r.used(n))} {n}" for n in OBSERVABLES)
        freqs = ", ".join(f"{f / 1e6:g}" for f in r.frequencies_hz)
        fused = f" ({r.fusion} fusion)" if len(r.frequencies_hz) > 1 else ""
        data.append(f"{r.path}: {r.sweep_variable} sweep at {freqs} MHz{fused}, {r.n_rows} rows; residuals: "
                    f"{used}; left out: {r.excluded['saturated']} with saturated frames, {r.excluded['low_snr']} "
                    f"below the SNR limit, {r.excluded.get('at_solution', 0)} the fitted model cannot measure")
        for k, why in sorted(r.reasons.items()):
            data.append(f"{Path(r.path).name} line {r.line(k)}: {why}")
    report.sections.append(Section("Data", [data]))
    if cal.problem.validity:  # every measured row constrains the fit (calibrate's docstring)
        limits = ["Every row the fit uses is held where the model measures it (a camera that delivered a row was "
                  "not saturated there): its headroom to the nearest limit (the full well, or SBI's, or an ADC "
                  f"rail) stays above {VALID_MARGIN:g} of that limit's range."]
        limits += [f"{Path(e['file']).name} line {e['line']}: {e['reason']}: the model cannot explain it (kept in the "
                   "fit)" for e in cal.unexplained]
        limits += [f"{Path(e['file']).name} line {e['line']}: held at the edge (headroom {e['headroom']:.2g})"
                   for e in cal.at_limit]
        if cal.at_limit:
            limits.append("The data ask for the dynamic range the model has at these rows: if the data sheet leaves "
                          "the full well, the saturation voltage or the ADC's range open, fit them too (--fit "
                          "pixel.v_saturated_v, adc.v_ref_pos_v, or pixel.full_well_e with --initial); the "
                          "estimates' sigmas there hold the edge, not only the data.")
        elif not cal.unexplained:
            limits.append("No row is at its edge: the constraint does not act at the solution.")
        report.sections.append(Section("Validity of the measured rows", [limits]))
    if cal.bounds is not None:
        report.sections.append(Section("Published bounds", bounds_section(cal)))
    objective = (f"the sum of squares (the change residuals' and any broken bound's; no measured row) = {ls.chi2:.4g}"
                 if cal.problem.bounds_only else f"chi^2 = {ls.chi2:.2f} for {ls.dof} degrees of freedom (chi^2/dof = "
                 f"{ls.chi2_per_dof:.3f})")
    fit = [f"{'converged' if ls.converged else 'NOT CONVERGED (the estimate below is the last iterate)'} after "
           f"{ls.steps} steps; {objective}; condition number {ls.condition_number:.3g}",
           Table(("parameter", "unit", "initial", "estimate", "sigma"), tuple(
               (n, u, f"{i:.6g}", f"{e:.6g}", f"{sg:.3g}")
               for n, u, i, e, sg in zip(ls.names, ls.units, ls.initial, ls.estimate, ls.sigma, strict=True)))]
    if ls.bound_flags:
        fit += ["At or near a bound:", [b["message"] for b in ls.bound_flags]]
    truths = true_values(cal)
    if truths:
        fit += ["Against the true values the files state (simulated data):",
                Table(("parameter", "estimate", "sigma", "true", "(estimate - true) / sigma", "verdict"), tuple(
                    (t["name"], f"{t['estimate']:.6g}", f"{t['sigma']:.3g}", f"{t['true']:.6g}",
                     f"{t['deviation_sigma']:+.2f}", t["verdict"]) for t in truths))]
    if ls.degeneracies:
        fit += ["What the data cannot separate:", list(ls.degeneracies)]
    short = [n.split(".")[1] for n in ls.names]
    fit += ["Correlation matrix:", Table(("", *short), tuple(
        (name, *(f"{x:+.3f}" for x in row)) for name, row in zip(short, ls.correlation, strict=True)))]
    if ls.residual_summary:  # none of bounds only
        fit += ["Residuals (whitened):",
                [f"{Path(r['file']).name} {r['observable']}: {r['rows']} rows, rms {r['rms']:.2f}, mean {r['mean']:+.2f}, "
                 f"max |r| {r['max_abs']:.2f}" for r in ls.residual_summary]]
    report.sections.append(Section("Least squares (Levenberg-Marquardt)", fit))
    if post is not None:
        notes = posterior_notes(cal)
        report.sections.append(Section("Posterior (emcee)", [
            f"{post.walkers} walkers x {post.steps} steps, burn-in {post.burn_in}, thin {post.thin}, "
            f"{len(post.samples)} samples; acceptance {post.acceptance_fraction:.2f}",
            Table(("parameter", "median", "16 %", "84 %", "autocorrelation time [steps]"), tuple(
                (n, f"{m:.6g}", f"{lo:.6g}", f"{hi:.6g}", f"{t:.1f}")
                for n, m, lo, hi, t in zip(post.names, post.median, post.p16, post.p84, post.autocorr_time, strict=True))),
            *([[f"warning: {w}" for w in post.warnings]] if post.warnings else []),
            *([[f"note: {n}" for n in notes]] if notes else [])]))
    rows = []
    if comparisons:
        for before, after in comparisons:
            for name in ("depth_std_m", "amplitude_mean_lsb"):
                a, b = before.summary(name), after.summary(name) if after is not None else {"rows": 0}
                if a["rows"] or b["rows"]:
                    cell = lambda x: f"{x['median_ratio']:.3f} ({x['within']}/{x['rows']})" if x["rows"] else "-"  # noqa: E731
                    rows.append((Path(before.path).name, name, cell(a), cell(b)))
    if rows:  # none of bounds only (the bounds' own section above)
        report.sections.append(Section("Measured vs model, before and after", [
            "Median model/measured ratio and rows within 30 % (unflagged rows; the tables per row in "
            "compare_initial.* and compare_calibrated.*; the figures show the initial model dashed):",
            Table(("file", "observable", "initial", "calibrated"), tuple(rows))]))
    report.sections.append(Section("Figures", [Figure(f.name, f.read_bytes()) for f in figures]))
    report.sections.append(Section("Use", [
        "calibrated.toml is the input configuration with the least-squares estimates; use it with "
        "tofjax simulate --config calibrated.toml. The input configuration is in calibration.json "
        "(configuration)."]))
    return report


