"""A calibration against bounds (a datasheet's promises), at its solution: which bounds hold, which
are active, which keys they pin, and which fitted values break a physical limit the camera obeys.

**The bounds at the solution.** Every bound column of every file is judged against the hard model
at the estimate as ``tofjax compare`` judges it (:func:`fitting.check_bounds`). A bound is *active*
where the model meets it within :data:`~fitting._problem.BOUND_ACTIVE` of the bound (met with
equality: the fit holds it 0.1 % inside); one not met at the solution is listed by file and row
(the free parameters do not reach it, or the bounds contradict each other).

**Pinned or free.** For each free parameter, the interval over which every bound that holds at the
solution still holds, the others kept at the solution: a scan of the hard model outward from the
solution in the change residual's scale t (ln of a positive parameter, else the value;
:mod:`fitting._problem`), :data:`SCAN_POINTS` points a side out to :data:`SCAN_WIDTHS` widths (a
factor 2^10 for a positive parameter) or the parameter's own bound, then, twice, :data:`SCAN_POINTS`
points between the last that held and the first that did not (a bisection 17-fold a step): three
evaluations of one compiled batch (:func:`fitting._problem.batched_bound_margins`), the edge to
2e-3 widths (0.2 % of a positive parameter). A parameter is *pinned* on a side where a bound breaks
closer than :data:`PINNED_WIDTH` widths (a factor 2^0.1 = 1.07 of a positive parameter, a hundredth
of the allowed interval of another): where an active bound holds it, or where the interval is that
narrow; else it is *free* (within the interval).

**Physical limits** (:func:`physical_flags`): an illumination beyond laser class 1 by tofjax's
eye-safety estimate (``tj.Camera(params).eye_safety.ratio > 1``, IEC 60825-1:2014, a small source:
an estimate, not a classification) at each file's longest exposure; a fitted set the configuration's
own checks refuse (a quantum efficiency above 1: the responsivity beyond e lambda / (h c)); a
parameter at the edge of its physical range (a contrast that would exceed 1). Each is reported, not
raised.
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import tofjax as tj
from tofjax.schema import KEY_BY_DOTTED
from tofjax.sweepfile import bound_column

from ._compare import BoundCheck, _quantity_value, judge_bounds
from ._data import SweepRows
from ._least_squares import at_edge
from ._problem import (BOUND_ACTIVE, PERIOD_PARAMETERS, Problem, batched_bound_margins, bound_rows, reading_period,
                       wrapped_rows)


def problem_keeps_wrapped(problem: Problem) -> bool:
    """Whether the fit keeps the accuracy bounds where the reading wraps (a fitted frequency)."""
    return any(name in PERIOD_PARAMETERS for name in problem.names)

#: Scan points per side and stage (:func:`intervals`), how far the first stage reaches (in change
#: widths), and the stages.
SCAN_POINTS = 16
SCAN_WIDTHS = 10.0
SCAN_STAGES = 3
#: A side where a bound breaks closer to the solution than this many change widths pins the parameter.
PINNED_WIDTH = 0.1


@dataclasses.dataclass
class BoundsAtSolution:
    """The bounds of a calibration at its solution (module docstring).

    ``checks``: per file with bounds, ``(file index, its columns judged)``; ``active`` and ``unmet``:
    ``{"file", "line", "column", "statement", "bound", "model"}`` per row; ``intervals``: per free
    parameter ``{"name", "unit", "value", "lower", "upper", "lower_end", "upper_end", "lower_breaks",
    "upper_breaks", "status"}`` (an end is ``"bound"`` where a bound breaks beyond it, ``"range"``
    at the parameter's own bound, ``"scan"`` where the scan stopped); ``physical``: the flags of
    :func:`physical_flags`."""

    checks: list[tuple[int, list[BoundCheck]]]
    active: list[dict]
    unmet: list[dict]
    intervals: list[dict]
    physical: list[dict] = dataclasses.field(default_factory=list)

    @property
    def rows(self) -> int:
        return sum(int(np.sum(np.isfinite(b.bound))) for _, checks in self.checks for b in checks)

    @property
    def met(self) -> int:
        return sum(int(np.sum(b.met & np.isfinite(b.bound))) for _, checks in self.checks for b in checks)

    def as_dict(self, rows: list[SweepRows]) -> dict:
        def per_row(i, b, k):
            return {"line": rows[i].line(k), "bound": _num(b.bound[k]), "model": _num(b.model[k]),
                    "met": bool(b.met[k]), "margin": _num(b.margin[k])}

        files = [{"file": rows[i].path, "bounds": [
            {"column": b.column, "statement": b.statement, "rows": [per_row(i, b, k) for k in np.flatnonzero(np.isfinite(b.bound))]}
            for b in checks]} for i, checks in self.checks]
        return {"rows": self.rows, "met": self.met, "files": files, "active": self.active, "unmet": self.unmet,
                "parameters": self.intervals, "physical": self.physical}


def _num(x) -> float | str:
    x = float(x)
    return x if math.isfinite(x) else ("inf" if x > 0 else ("-inf" if x < 0 else "nan"))


def bounds_at(problem: Problem, theta, rows: list[SweepRows], hard: list[tuple]) -> BoundsAtSolution:
    """:class:`BoundsAtSolution` of ``problem`` at ``theta``; ``hard``: the hard model there
    (:func:`fitting._calibrate._hard_at`)."""
    checks, active, unmet = [], [], []
    for i, rows_of, obs in hard:
        r = rows[i]
        if not r.bounds:
            continue
        model = {name: np.asarray(getattr(obs, name))[rows_of] for name in ("depth_std_m", "amplitude_mean_lsb")}
        guess = (np.asarray(obs.caveats)[rows_of].astype(int) & tj.schema.CAVEAT_LOW_SNR) != 0
        judged = judge_bounds([(b.column, b.statement, b.values) for b in r.bounds], model,
                              np.asarray(r.sweep.distance_m), np.asarray(obs.depth_mean_m)[rows_of], guess)
        checks.append((i, judged))
        wrapped, period = wrapped_rows(r), reading_period(r.params, r.frequencies_hz)
        for b in judged:
            for k in np.flatnonzero(np.isfinite(b.bound)):
                entry = {"file": r.path, "line": r.line(k), "column": b.column, "statement": b.statement,
                         "bound": float(b.bound[k]), "model": _num(b.model[k])}
                if not b.met[k]:
                    if b.quantity == "depth_error_m" and wrapped[k]:
                        entry["reason"] = (f"the reading wraps: {float(r.sweep.distance_m[k]):.4g} m is beyond the "
                                           f"camera's unambiguity range of {period:.4g} m"
                                           + ("" if problem_keeps_wrapped(problem) else " (left out of the fit)"))
                    elif not np.isfinite(b.model[k]):
                        entry["reason"] = "the hard model has no value here (saturated, or its depth is a guess)"
                    unmet.append(entry)
                elif b.margin[k] <= BOUND_ACTIVE * b.bound[k]:
                    active.append(entry)
    return BoundsAtSolution(checks, active, unmet, intervals(problem, theta, rows))


def intervals(problem: Problem, theta, rows: list[SweepRows]) -> list[dict]:
    """Per free parameter, the interval over which every bound that holds at ``theta`` still holds,
    the others at ``theta`` (module docstring): :data:`SCAN_STAGES` evaluations of one compiled batch."""
    theta = np.asarray(theta, dtype=float)
    n, g = problem.n_params, SCAN_POINTS
    t_star = problem.anchor_transform(theta)
    width = np.asarray(problem.anchor_width, dtype=float)
    log = np.asarray(problem.anchor_log)
    lower, upper = np.asarray(problem.lower, dtype=float), np.asarray(problem.upper, dtype=float)
    has_lower = np.array([k in ("both", "lower") for k in problem.kinds])
    has_upper = np.array([k == "both" for k in problem.kinds])
    with np.errstate(divide="ignore"):
        lo_t = np.where(has_lower, np.where(log, np.log(np.maximum(lower, 0.0)), lower), -np.inf)
        hi_t = np.where(has_upper, np.where(log, np.log(np.where(has_upper, upper, 1.0)), upper), np.inf)
    inside = 1e-9 * width  # the parameter's own bound may be open (a power of 0 W)
    ends = np.stack([np.maximum(t_star - SCAN_WIDTHS * width, lo_t + inside),
                     np.minimum(t_star + SCAN_WIDTHS * width, hi_t - inside)], axis=1)  # (params, side)
    at_range = np.stack([t_star - SCAN_WIDTHS * width <= lo_t + inside, t_star + SCAN_WIDTHS * width >= hi_t - inside],
                        axis=1)
    good = np.stack([t_star, t_star], axis=1)
    bad = np.full((n, 2), np.nan)
    broken: list[list[int | None]] = [[None, None] for _ in range(n)]
    entries = bound_rows(problem, rows)
    met = None
    for stage in range(SCAN_STAGES):
        points = np.empty((n, 2, g))
        for k in range(n):
            for side in range(2):
                if stage == 0:
                    points[k, side] = t_star[k] + (ends[k, side] - t_star[k]) * np.arange(1, g + 1) / g
                elif np.isfinite(bad[k, side]):
                    points[k, side] = good[k, side] + (bad[k, side] - good[k, side]) * np.arange(1, g + 1) / (g + 1)
                else:
                    points[k, side] = t_star[k]  # nothing left to find on this side
        thetas = np.repeat(theta[None], n * 2 * g + 1, axis=0)
        for k in range(n):
            thetas[k * 2 * g:(k + 1) * 2 * g, k] = _inverse(log[k], points[k].ravel())
        margins = np.asarray(jax.device_get(batched_bound_margins(problem, jnp.asarray(thetas))))
        if met is None:
            met = margins[-1] >= 0.0  # what holds at the solution (its last row)
        if not np.any(met):
            break
        holds = np.all(margins[:-1][:, met] >= 0.0, axis=1).reshape(n, 2, g)
        for k in range(n):
            for side in range(2):
                if stage > 0 and not np.isfinite(bad[k, side]):
                    continue
                fails = np.flatnonzero(~holds[k, side])
                if fails.size == 0:
                    good[k, side] = points[k, side, -1] if stage > 0 else ends[k, side]
                    continue
                j = int(fails[0])
                if j > 0:
                    good[k, side] = points[k, side, j - 1]
                bad[k, side] = points[k, side, j]
                row = margins[(k * 2 + side) * g + j]
                worst = np.flatnonzero(met)[int(np.argmin(row[met]))]
                broken[k][side] = int(worst)
    out = []
    if met is None or not np.any(met):  # nothing holds at the solution: nothing to keep holding
        return [{"name": name, "unit": problem.units[k], "value": float(theta[k]), "lower": None, "upper": None,
                 "lower_end": None, "upper_end": None, "lower_breaks": None, "upper_breaks": None,
                 "status": "undetermined (no bound holds at the solution)"} for k, name in enumerate(problem.names)]
    for k, name in enumerate(problem.names):
        ends_kind, breaks, distance = [], [], []
        for side in range(2):
            if np.isfinite(bad[k, side]):
                ends_kind.append("bound")
                e = entries[broken[k][side]]
                r = rows[e["file"]]
                breaks.append({"file": r.path, "line": e["line"], "column": e["column"], "bound": e["bound"]})
                distance.append(abs(good[k, side] - t_star[k]) / width[k])
            else:
                ends_kind.append("range" if at_range[k, side] else "scan")
                breaks.append(None)
                distance.append(np.inf)
        pinned = [d < PINNED_WIDTH for d in distance]
        status = ("pinned" if all(pinned) else "pinned below" if pinned[0] else "pinned above" if pinned[1]
                  else "free")
        value_lo, value_hi = (float(_inverse(log[k], np.array([good[k, side]]))[0]) for side in range(2))
        out.append({"name": name, "unit": problem.units[k], "value": float(theta[k]), "lower": value_lo,
                    "upper": value_hi, "lower_end": ends_kind[0], "upper_end": ends_kind[1],
                    "lower_breaks": breaks[0], "upper_breaks": breaks[1], "status": status})
    return out


def _inverse(log: bool, t: np.ndarray) -> np.ndarray:
    return np.exp(t) if log else t


def physical_flags(config: tj.Config, rows: list[SweepRows], problem: Problem, theta) -> list[dict]:
    """The fitted values that break a physical limit the camera obeys (module docstring), each
    ``{"kind", "message"}`` (and ``"ratio"`` for the eye-safety estimate), never raised."""
    flags = []
    theta = jnp.asarray(np.asarray(theta, dtype=float))
    worst = None
    for r in rows:  # each file's camera (its own frequency, say) at its longest exposure
        exposure = float(np.max(np.asarray(r.sweep.integration_time_s)))
        cameras = []
        for values in (theta, problem.initial):
            params = problem.with_values(r.params, values)
            params = eqx.tree_at(lambda p: p.scene.integration_time_s, params, jnp.asarray(exposure))
            cameras.append(eqx.tree_at(lambda c: c.params, tj.Camera.from_config(r.config), params))
        safety, before = (jax.device_get(c.eye_safety) for c in cameras)
        if not bool(safety.in_band):
            continue
        ratio = float(safety.ratio)
        if worst is None or ratio > worst[0]:
            worst = (ratio, float(before.ratio), r, exposure, safety)
    if worst is not None and worst[0] > 1.0:
        ratio, before, r, exposure, safety = worst
        ratios = {k: float(v) for k, v in safety.ratios.items()}
        what = {"average": "the average power", "pulse": "one phase image", "burst": "a frame's phase images"}[
            max(ratios, key=ratios.get)]
        power = float(problem.with_values(r.params, theta).illumination.peak_power_w)
        flags.append({"kind": "laser class", "ratio": ratio, "file": r.path, "message": (
            f"the fitted illumination ({power:.4g} W peak) is beyond laser class 1: {ratio:.3g} times the limit for "
            f"{what} at {Path(r.path).name}'s longest exposure ({1e3 * exposure:.4g} ms per phase image; "
            f"{before:.3g} times with the initial values), by tofjax's eye-safety estimate (IEC 60825-1:2014 class 1, "
            "small source, 7 mm at 100 mm: an estimate, not a classification). A class 1 camera cannot emit this: "
            "the bounds ask for more light than its illumination may give, so another key the configuration takes "
            "from elsewhere (the lens, the pixel, the exposure) is not the camera's")})
    estimate = dict(zip(problem.names, np.asarray(theta, dtype=float), strict=True))
    try:
        for name, value in estimate.items():
            config = config.replace(name, float(value))
    except (tj.ConfigError, ValueError) as err:
        flags.append({"kind": "configuration", "message": f"the fitted values break the configuration's check: {err}"})
    for k, name in enumerate(problem.names):  # at the edge of its physical range (not of a narrower --bounds)
        key, value = KEY_BY_DOTTED[name], estimate[name]
        for side, edge, own in (("below", key.lo, problem.lower[k]), ("above", key.hi, problem.upper[k])):
            if edge is None or float(own) != float(edge) or problem.kinds[k] == "none":
                continue
            if side == "above" and problem.kinds[k] != "both":
                continue
            span = (float(problem.upper[k]) - float(problem.lower[k])) if problem.kinds[k] == "both" else \
                max(abs(value), abs(edge), 1e-300)
            if at_edge(value, edge, float(problem.initial[k]), span):
                flags.append({"kind": "out of range", "message": (
                    f"{name} = {value:.6g} is at the edge of its physical range ({key.range_text()}): the bounds or data "
                    f"ask for a value {side} {edge:g}, out of range (a {name.split('.')[1]} {side} {edge:g} is not "
                    "physical), so the model lacks what they show")})
    return flags


def _row(entry: dict) -> str:
    """``spec.csv line 16: depth_std_m_le (bound 5 mm, model 4.995 mm)``, and why where it says."""
    q = bound_column(entry["column"])[0]
    model = entry["model"] if isinstance(entry["model"], float) else float("nan")
    return (f"{Path(entry['file']).name} line {entry['line']}: {entry['column']} (bound "
            f"{_quantity_value(q, entry['bound'])}, model {_quantity_value(q, model)})"
            + (f": {entry['reason']}" if entry.get("reason") else ""))


def interval_line(p: dict) -> str:
    """One free parameter's interval and whether the bounds pin it (the console's and the report's words)."""
    def end(side: str) -> str:
        value, kind = p[side], p[f"{side}_end"]
        text = f"{value:.4g}"
        return text + (" (its bound)" if kind == "range" else (" or less" if side == "lower" else " or more")
                       if kind == "scan" else "")

    unit = f" {p['unit']}" if p["unit"] not in ("", "1", "-") else ""
    words = f"{p['name']} = {p['value']:.6g}{unit}: {p['status']}"
    if p["lower"] is None:
        return words
    why = []
    for side, verb in (("lower", "lowering"), ("upper", "raising")):
        b = p[f"{side}_breaks"]
        if b is not None:
            why.append(f"{verb} it past {p[side]:.4g} breaks {Path(b['file']).name} line {b['line']} ({b['column']})")
    return (f"{words}; every bound that holds at the solution holds over [{end('lower')}, {end('upper')}]{unit}"
            + (f": {'; '.join(why)}" if why else " (no bound breaks within the scan)"))


def headline(b: BoundsAtSolution) -> str:
    """How many bound rows hold at the solution, how many are active."""
    return (f"{b.met} of {b.rows} bound rows met by the hard model at the solution; {len(b.active)} active (met with "
            f"equality, within {100 * BOUND_ACTIVE:.2g} % of the bound), {len(b.unmet)} not met")


def row_lines(b: BoundsAtSolution, *, limit: int | None = None) -> list[str]:
    """The bound rows active and not met at the solution (``limit``: at most that many of each, the
    rest counted)."""
    lines = []
    for title, entries in (("active", b.active), ("not met", b.unmet)):
        shown = entries if limit is None else entries[:limit]
        lines += [f"{title}: {_row(e)}" for e in shown]
        if len(entries) > len(shown):
            lines.append(f"{title}: ... and {len(entries) - len(shown)} more rows (report.md lists them)")
    return lines
