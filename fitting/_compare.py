"""Measured sweeps beside the model, without fitting: the thesis' "analyze LTS data" (§4.4.2, Table
4.27) as ``tofjax compare``.

Per file and row: the measured depth mean against the real (stage) distance with the model's
expected depth (its wiggling and offset), the depth error of both, the amplitude (absolute), the
depth noise (absolute and relative to the distance), and the model / measured ratio of every
observable. The model is the hard analytic path (:func:`tofjax.predict`, or
:func:`tofjax.predict` of a multi-frequency camera with the file's fusion for several frequencies) of the camera
the file was taken with (the configuration plus the file's metadata overrides,
:func:`fitting.read_measurement`). A row the model cannot measure (pixel or ADC saturated: no
value) or where its closed form is a caveat (near a limit, low SNR, coarse quantisation), and a
row whose measured frames were not all valid, is flagged by name.

The model's expected depth of one frequency is its wrapped mean continued to the period nearest the
real distance (what an unwrapping camera would report; the figure draws it, as the measured readings,
as read: wrapped into [0, range)); a measured depth further than half the
unambiguity range from the real distance has its error taken modulo that range (a camera of one
frequency reports wrapped depths); with several frequencies, whose camera claims the extended
range, such a row is also flagged ``wrapped`` (a wrong unwrap).

A file's bounds (format 4: a datasheet's promise, "temporal noise < 1 mm up to 5.5 m", written per
row, :func:`tofjax.sweepfile.bound_column`) are checked against the same model, judged as the camera
would be: each row's bound is met or not, with its margin (bound minus model for an upper bound,
model minus bound for a lower one; positive where met). The depth error is the camera's reading
(wrapped into its unambiguity range, or unwrapped by its own frequencies over their extended range)
minus the true distance: a camera of one frequency beyond its range reads short by the range, and
meets no accuracy bound there. A row the model cannot measure (saturated), and a row whose phase
noise makes the reading a guess (the low-SNR caveat: a phase noise above 0.5 rad, where the depth
wraps in many frames), meets no bound on its depth: the specification promises a depth there.

Outputs (:func:`write_comparison`): ``comparison.csv`` (every row), ``comparison.md`` (per-file
summary and table), ``comparison.html`` (the same with the figures embedded), one PNG per file and,
where a file states bounds, ``bounds.csv`` (every bound at every row).
"""

from __future__ import annotations

import csv
import dataclasses
import io
import itertools
import math
import re
from pathlib import Path

import numpy as np
import tofjax as tj
from tofjax.outputs import atomic_path, write_bytes, write_text
from tofjax.report import Figure, Section, Summary, Table
from tofjax.schema import OPERATING_POINT_COLUMNS, SWEEP_AXES
from tofjax.sweepfile import BOUND_RELATIONS, bound_column

from ._data import Measurement, read_measurement
from ._problem import DENSE_POINTS, dense_sweep, hard_observables, nearest_period, reading_period, under_common_lamp

#: Ratios within this factor of 1 count as agreeing in the summaries (30 %).
AGREEMENT = 0.3
_QUANTITIES = ("depth_mean_m", "depth_std_m", "amplitude_mean_lsb", "amplitude_std_lsb")


@dataclasses.dataclass
class BoundCheck:
    """One bound column of a file against the model: per row the ``bound`` (NaN: none there), the
    ``model``'s value (NaN: it has none, saturated), whether it is ``met`` and the ``margin``
    (positive on the met side: bound - model for ``le``/``lt``, model - bound for ``ge``/``gt``)."""

    column: str
    quantity: str
    relation: str
    statement: str
    bound: np.ndarray
    model: np.ndarray
    met: np.ndarray
    margin: np.ndarray

    @property
    def text(self) -> str:
        """``depth_std_m < bound`` style."""
        return f"{self.quantity} {BOUND_RELATIONS[self.relation]}"

    def summary(self) -> dict:
        """Rows with a bound, those met, and the worst row (smallest margin; a row without a model
        value is worst) with its margin and the model's value over the bound there."""
        rows = np.flatnonzero(np.isfinite(self.bound))
        if not len(rows):
            return {"rows": 0, "met": 0}
        key = np.where(np.isfinite(self.margin[rows]), self.margin[rows], -np.inf)
        worst = int(rows[int(np.argmin(key))])
        with np.errstate(divide="ignore", invalid="ignore"):
            ratio = self.model[worst] / self.bound[worst]
        return {"rows": int(len(rows)), "met": int(np.sum(self.met[rows])), "worst": worst,
                "margin": float(self.margin[worst]), "model_over_bound": float(ratio)}


def check_bounds(data, model: dict[str, np.ndarray], distance_m: np.ndarray, reading_m: np.ndarray,
                 guess: np.ndarray) -> list[BoundCheck]:
    """Every bound column of a sweep file (``data``: :class:`tofjax.sweepfile.SweepData`) against the
    model's per-row values (``model``: :data:`_QUANTITIES`), judged as the camera would be (module
    docstring): the depth error is ``reading_m`` (the camera's expected reading) minus the true
    ``distance_m``, and a row where ``guess`` (its phase noise makes the reading a guess) meets no
    depth bound."""
    return judge_bounds([(column, data.metadata[f"bound.{column}"], data.columns[column]) for column in data.bounds],
                        model, distance_m, reading_m, guess)


def judge_bounds(bounds, model: dict[str, np.ndarray], distance_m: np.ndarray, reading_m: np.ndarray,
                 guess: np.ndarray) -> list[BoundCheck]:
    """:func:`check_bounds` of ``bounds``, ``(column, statement, values per row)`` each (a file's, or a
    calibration's :class:`fitting._data.Bound` columns)."""
    nan_if_guess = lambda x: np.where(guess, np.nan, x)  # noqa: E731
    values = {"depth_std_m": nan_if_guess(model["depth_std_m"]), "amplitude_mean_lsb": model["amplitude_mean_lsb"],
              "depth_error_m": nan_if_guess(np.abs(reading_m - distance_m))}
    out = []
    for column, statement, bound in bounds:
        quantity, relation = bound_column(column)
        bound, value = np.asarray(bound, dtype=float), np.asarray(values[quantity], dtype=float)
        upper = relation in ("le", "lt")
        margin = bound - value if upper else value - bound
        with np.errstate(invalid="ignore"):
            met = np.isfinite(margin) & ((margin >= 0) if relation in ("le", "ge") else (margin > 0))
        out.append(BoundCheck(column, quantity, relation, statement, bound, value, met, margin))
    return out


@dataclasses.dataclass
class FileComparison:
    """One file beside the model.

    ``measured`` and ``model`` map :data:`_QUANTITIES` to per-row arrays (NaN: not measured / no
    value); ``depth_error_m`` the measured and model depth minus the real distance; ``flags`` one
    list of words per row; ``dense_x`` and ``dense`` the model along the swept quantity.
    """

    path: str
    sweep_variable: str
    x: np.ndarray
    lines: np.ndarray
    distance_m: np.ndarray
    frequencies_hz: tuple[float, ...]
    fusion: str
    range_m: float
    measured: dict[str, np.ndarray]
    model: dict[str, np.ndarray]
    depth_error_m: dict[str, np.ndarray]
    flags: list[list[str]]
    dense_x: np.ndarray
    dense: dict[str, np.ndarray]
    #: The file's bounds against the model (format 4; empty for a file of measured values only).
    bounds: list[BoundCheck] = dataclasses.field(default_factory=list)

    def ratio(self, name: str) -> np.ndarray:
        """model / measured of ``name`` per row (NaN where either is missing or the measurement is 0)."""
        with np.errstate(divide="ignore", invalid="ignore"):
            r = self.model[name] / self.measured[name]
        return np.where(np.isfinite(r), r, np.nan)

    def summary(self, name: str) -> dict:
        """Rows with a ratio of ``name``, those within :data:`AGREEMENT`, the median ratio and the
        rms of log(ratio), over unflagged rows."""
        r = self.ratio(name)
        clean = np.array([not f for f in self.flags])
        use = np.isfinite(r) & clean
        if not np.any(use):
            return {"rows": 0}
        within = np.abs(r[use] - 1.0) <= AGREEMENT
        return {"rows": int(use.sum()), "within": int(within.sum()), "median_ratio": float(np.median(r[use])),
                "rms_log_ratio": float(np.sqrt(np.mean(np.log(r[use]) ** 2)))}


def _rows_and_dense(m: Measurement, dense: dict[str, np.ndarray], lux_scale: float = 1.0) -> tj.Sweep:
    """The file's rows, then the dense points: one call (which pads them to its bucket, so files of
    similar length share its program); the illuminance times ``lux_scale`` (:func:`under_common_lamp`)."""
    def column(name):
        values = np.concatenate([np.asarray(getattr(m.sweep, name)), dense[name]])
        return values * lux_scale if name == "illuminance_lx" else values

    return tj.Sweep.points("distance", **{name: column(name) for name in OPERATING_POINT_COLUMNS})


def compare_measurement(m: Measurement) -> FileComparison:
    """The model beside one checked file (module docstring); modelled under the common lamp
    (:func:`fitting._problem.under_common_lamp`: the same photons, one program for every lamp)."""
    dense = dense_sweep(m.sweep, DENSE_POINTS)
    params, lux_scale = under_common_lamp(m.config.params)
    sweep = _rows_and_dense(m, dense, lux_scale)
    obs = hard_observables(params, sweep, tuple(m.frequencies_hz), m.fusion, m.processing)  # host arrays
    n = m.data.n_rows

    def get(name: str, part: str) -> np.ndarray:  # the data rows, or the dense points after them
        value = np.asarray(getattr(obs, name))
        return value[:n] if part == "rows" else value[n:]

    period = reading_period(m.config.params, m.frequencies_hz)
    truth = np.asarray(m.sweep.distance_m)
    model = {name: get(name, "rows") for name in _QUANTITIES}
    model["depth_mean_m"] = np.asarray(nearest_period(model["depth_mean_m"], truth, period))
    measured = {name: np.asarray(m.columns[name], dtype=float) for name in _QUANTITIES}
    error_measured = measured["depth_mean_m"] - truth
    wrapped = np.abs(error_measured) > 0.5 * period
    error_measured = np.where(wrapped, error_measured - period * np.round(error_measured / period), error_measured)
    wrapped &= len(m.frequencies_hz) > 1  # one frequency: a wrapped depth is what the camera reports
    dense_depth = np.asarray(nearest_period(get("depth_mean_m", "dense"), dense["distance_m"], period))
    flags: list[list[str]] = []
    pixel, adc, caveats = get("pixel_saturated_fraction", "rows"), get("adc_saturated_fraction", "rows"), \
        get("caveats", "rows").astype(int)
    valid_measured = np.asarray(m.columns["valid_fraction"])
    for i in range(n):
        f = []
        if pixel[i] > 0:
            f.append("model: pixel saturated")
        if adc[i] > 0:
            f.append("model: ADC saturated")
        if not f and not np.isfinite(model["depth_std_m"][i]):
            f.append("model: no value")
        if caveats[i] & tj.schema.CAVEAT_NEAR_LIMIT:
            f.append("model: near a limit")
        if caveats[i] & tj.schema.CAVEAT_LOW_SNR:
            f.append("model: low SNR")
        if valid_measured[i] < 1.0:
            f.append(f"measured: {valid_measured[i]:.3g} of frames valid")
        if wrapped[i]:
            f.append("measured: wrapped")
        flags.append(f)
    scale = np.asarray(m.sweep.values)
    dense_x = dense[SWEEP_AXES[m.data.sweep].column]
    return FileComparison(
        path=m.path, sweep_variable=m.data.sweep, x=scale, lines=np.asarray(m.data.lines), distance_m=truth,
        frequencies_hz=tuple(m.frequencies_hz), fusion=m.fusion, range_m=period, measured=measured, model=model,
        depth_error_m={"measured": error_measured, "model": model["depth_mean_m"] - truth}, flags=flags,
        dense_x=dense_x, dense={"depth_mean_m": dense_depth, "depth_error_m": dense_depth - dense["distance_m"],
                                "depth_std_m": get("depth_std_m", "dense"),
                                "amplitude_mean_lsb": get("amplitude_mean_lsb", "dense"),
                                "amplitude_std_lsb": get("amplitude_std_lsb", "dense"),
                                "distance_m": dense["distance_m"]},
        bounds=check_bounds(m.data, model, truth, get("depth_mean_m", "rows"),
                            (caveats & tj.schema.CAVEAT_LOW_SNR) != 0))


def compare(paths, config: tj.Config | None = None) -> list[FileComparison]:
    """Every file beside the model of ``config`` (default: built-in defaults), without fitting.

    **Arguments:** ``paths``: tofjax-sweep files (one or several; depth-only, amplitude-only and
    multi-frequency files included); ``config``: the camera (:class:`tofjax.Config`).

    **Returns:** one :class:`FileComparison` per file; write them with :func:`write_comparison`.
    """
    config = config if config is not None else tj.Config()
    if isinstance(paths, (str, Path)):
        paths = [paths]
    if not paths:
        raise ValueError("no sweep file given")
    measurements = [read_measurement(p, config) for p in paths]  # every file checked before any work
    return compare_measurements(measurements)


def compare_measurements(measurements: list[Measurement]) -> list[FileComparison]:
    """:func:`compare_measurement` of every file. Files of different cameras (a static choice such
    as the background lamp differs) need their own compiled program: they are compiled in parallel
    threads (XLA compiles without the GIL), one per distinct structure."""
    from concurrent.futures import ThreadPoolExecutor

    if len(measurements) < 2:
        return [compare_measurement(m) for m in measurements]
    with ThreadPoolExecutor(max_workers=min(4, len(measurements))) as pool:
        return list(pool.map(compare_measurement, measurements))


# --- outputs ---------------------------------------------------------------------------------------

_CSV_COLUMNS = (
    "file", "line", "sweep_value", "distance_m", "measured_depth_mean_m", "model_depth_mean_m",
    "measured_depth_error_m", "model_depth_error_m", "measured_depth_std_m", "model_depth_std_m", "ratio_depth_std",
    "measured_amplitude_mean_lsb", "model_amplitude_mean_lsb", "ratio_amplitude_mean",
    "measured_amplitude_std_lsb", "model_amplitude_std_lsb", "ratio_amplitude_std", "flags",
)


def _cell(x) -> str:
    if isinstance(x, str):
        return x
    x = float(x)
    return "" if not math.isfinite(x) else f"{x:.6g}"


def table_rows(comparisons: list[FileComparison], label: str = "") -> list[dict[str, str]]:
    """Every row of every file as a flat record (the CSV and Markdown tables), file by file in order
    (two files of the same name stay apart: :func:`write_comparison` takes each file's own rows)."""
    out = []
    for c in comparisons:
        r_std, r_amp, r_amp_std = c.ratio("depth_std_m"), c.ratio("amplitude_mean_lsb"), c.ratio("amplitude_std_lsb")
        for i in range(len(c.x)):
            out.append({
                "file": Path(c.path).name, "line": str(int(c.lines[i])), "sweep_value": _cell(c.x[i]),
                "distance_m": _cell(c.distance_m[i]),
                "measured_depth_mean_m": _cell(c.measured["depth_mean_m"][i]),
                "model_depth_mean_m": _cell(c.model["depth_mean_m"][i]),
                "measured_depth_error_m": _cell(c.depth_error_m["measured"][i]),
                "model_depth_error_m": _cell(c.depth_error_m["model"][i]),
                "measured_depth_std_m": _cell(c.measured["depth_std_m"][i]),
                "model_depth_std_m": _cell(c.model["depth_std_m"][i]), "ratio_depth_std": _cell(r_std[i]),
                "measured_amplitude_mean_lsb": _cell(c.measured["amplitude_mean_lsb"][i]),
                "model_amplitude_mean_lsb": _cell(c.model["amplitude_mean_lsb"][i]),
                "ratio_amplitude_mean": _cell(r_amp[i]),
                "measured_amplitude_std_lsb": _cell(c.measured["amplitude_std_lsb"][i]),
                "model_amplitude_std_lsb": _cell(c.model["amplitude_std_lsb"][i]),
                "ratio_amplitude_std": _cell(r_amp_std[i]),
                "flags": "; ".join(c.flags[i]),
            })
    return out


def figure(c: FileComparison, title: str = ""):
    """The six panels of one file (module docstring) as a matplotlib Figure."""
    from matplotlib.figure import Figure

    axis = SWEEP_AXES[c.sweep_variable]
    label, xs = axis.axis_label, axis.display_scale
    x, dx = c.x * xs, c.dense_x * xs
    flagged = np.array([bool(f) for f in c.flags])
    fig = Figure(figsize=(13, 7.2))
    fig.subplots_adjust(left=0.06, right=0.985, top=0.9, bottom=0.08, hspace=0.4, wspace=0.27)  # constrained: 2x slower
    axes = fig.subplots(2, 3).ravel()

    def points(ax, y, name, scale=1.0, color="C0"):
        y = np.asarray(y) * scale
        ok = np.isfinite(y)
        if not np.any(ok):
            ax.text(0.5, 0.5, f"{name}: not in the file", transform=ax.transAxes, ha="center", color="grey")
            return
        ax.plot(x[ok & ~flagged], y[ok & ~flagged], "o", ms=3.5, color=color, label="measured")
        if np.any(ok & flagged):
            ax.plot(x[ok & flagged], y[ok & flagged], "x", ms=5, color="grey", label="measured (flagged)")

    with np.errstate(divide="ignore", invalid="ignore"):
        relative_measured = c.measured["depth_std_m"] / c.distance_m
        relative_model = c.dense["depth_std_m"] / c.dense["distance_m"]
    # The depth as the camera reads it, both the same way: wrapped into [0, range) (the model's expected
    # depth is kept continued to the real distance's period for the error, where it had been drawn so
    # beside the measured readings, which wrap); the model's line broken where it wraps.
    read_measured = np.mod(c.measured["depth_mean_m"], c.range_m)
    read_model = np.mod(c.dense["depth_mean_m"], c.range_m)
    read_model[1:][np.diff(read_model) < -0.5 * c.range_m] = np.nan
    # (measured, its name, model curve, scale, model label, y label, title) per panel
    panels = (
        (read_measured, "depth mean", read_model, 1.0, "model (expected depth)",
         "depth as read [m]", f"calculated vs real distance (read in [0, {c.range_m:.4g}) m)"),
        (c.depth_error_m["measured"], "depth mean", c.dense["depth_error_m"], 1e3, "model (wiggling)",
         "depth error [mm]", "depth error (depth - real distance)"),
        (c.measured["amplitude_mean_lsb"], "amplitude", c.dense["amplitude_mean_lsb"], 1.0, "model",
         "amplitude [LSB]", "amplitude"),
        (c.measured["depth_std_m"], "depth noise", c.dense["depth_std_m"], 1e3, "model", "depth noise [mm]",
         "depth noise (absolute)"),
        (relative_measured, "depth noise", relative_model, 100.0, "model", "depth noise / distance [%]",
         "depth noise (relative)"),
    )
    for ax, (measured, name, curve, scale, model_label, ylabel, heading) in zip(axes, panels, strict=False):
        points(ax, measured, name, scale)
        ax.plot(dx, scale * curve, "C1-", lw=1.2, label=model_label)
        ax.set_ylabel(ylabel)
        ax.set_title(heading, fontsize=10)
    for b in c.bounds:  # a datasheet's bound where it holds, in the panel of its quantity
        ok = np.isfinite(b.bound)
        panel, scale = {"depth_error_m": (1, 1e3), "amplitude_mean_lsb": (2, 1.0), "depth_std_m": (3, 1e3)}[b.quantity]
        axes[panel].plot(x[ok], scale * b.bound[ok], "C3--", lw=1.0, label=f"bound ({BOUND_RELATIONS[b.relation]})")
        if b.quantity == "depth_error_m":  # the bound is on the error's magnitude
            axes[panel].plot(x[ok], -scale * b.bound[ok], "C3--", lw=1.0)
    axes[0].plot(dx, c.dense["distance_m"], "k--", lw=0.8, label="real distance")
    axes[1].axhline(0, color="k", lw=0.6)
    ax = axes[5]
    for name, color, text in (("depth_std_m", "C0", "depth noise"), ("amplitude_mean_lsb", "C2", "amplitude"),
                              ("amplitude_std_lsb", "C4", "amplitude noise")):
        r = c.ratio(name)
        ok = np.isfinite(r)
        if np.any(ok):
            ax.plot(x[ok & ~flagged], r[ok & ~flagged], "o-", ms=3, lw=0.6, color=color, label=text)
            if np.any(ok & flagged):
                ax.plot(x[ok & flagged], r[ok & flagged], "x", ms=5, color="grey")
    ax.axhspan(1 - AGREEMENT, 1 + AGREEMENT, color="C2", alpha=0.1, label=f"within {100 * AGREEMENT:.0f} %")
    ax.axhline(1.0, color="k", lw=0.6)
    ax.set_ylabel("model / measured")
    ax.set_title("ratio per point", fontsize=10)
    for ax in axes:
        ax.set_xlabel(label)
        ax.grid(alpha=0.3)
        handles, _ = ax.get_legend_handles_labels()
        if handles:
            ax.legend(fontsize=7)
    freqs = ", ".join(f"{f / 1e6:g}" for f in c.frequencies_hz)
    fusion = f", {c.fusion} fusion" if len(c.frequencies_hz) > 1 else ""
    fig.suptitle(f"{title}{Path(c.path).name}: {c.sweep_variable} sweep at {freqs} MHz{fusion}", fontsize=11)
    return fig


def _summary_table(comparisons: list[FileComparison]) -> Table:
    rows = []
    for c in comparisons:
        flagged = sum(bool(f) for f in c.flags)
        for name in ("depth_std_m", "amplitude_mean_lsb", "amplitude_std_lsb"):
            s = c.summary(name)
            if s["rows"] == 0:
                continue
            rows.append((Path(c.path).name, name, str(s["rows"]), str(s["within"]), f"{s['median_ratio']:.3f}",
                         f"{s['rms_log_ratio']:.3f}", str(flagged)))
    return Table(("file", "observable", "rows", "within 30 %", "median model/measured", "rms log ratio",
                  "flagged rows"), tuple(rows))


def _quantity_value(quantity: str, x: float) -> str:
    """A bounded quantity's value in its display unit (lengths in mm)."""
    if not math.isfinite(x):
        return "no value"
    return f"{1e3 * x:.4g} mm" if quantity.endswith("_m") else f"{x:.4g} LSB"


def _signed(quantity: str, margin: float) -> str:
    """A margin with its sign, in its quantity's display unit."""
    return ("+" if margin >= 0 else "-") + _quantity_value(quantity, abs(margin))


def _where(c: FileComparison, i: int) -> str:
    """Row ``i`` of a file by its swept value (``distance [m] = 1.5``)."""
    axis = SWEEP_AXES[c.sweep_variable]
    return f"{axis.axis_label} = {c.x[i] * axis.display_scale:.4g}"


def bound_lines(c: FileComparison) -> list[str]:
    """One line per bound of a file: met rows, the worst margin (absolute and relative to the bound)
    and where (the console's and the report's words)."""
    out = []
    for b in c.bounds:
        s = b.summary()
        if not s["rows"]:
            continue
        where = _where(c, s["worst"])
        if not math.isfinite(s["margin"]):
            worst = f"the model has no value (saturated) at {where}"
        else:
            worst = (f"worst margin {_signed(b.quantity, s['margin'])} "
                     f"(model/bound {s['model_over_bound']:.3g}) at {where}")
        verdict = "met" if s["met"] == s["rows"] else "NOT met"
        out.append(f"{b.column} ({b.text} bound): {verdict}, {s['met']} of {s['rows']} rows meet it; {worst}")
    return out


def _bounds_table(comparisons: list[FileComparison]) -> Table:
    rows = []
    for c in comparisons:
        for b in c.bounds:
            s = b.summary()
            if not s["rows"]:
                continue
            i = s["worst"]
            rel = f"{s['model_over_bound']:.3g}" if math.isfinite(s["margin"]) else ""
            rows.append((Path(c.path).name, b.text, b.statement, str(s["rows"]), str(s["met"]),
                         _quantity_value(b.quantity, b.bound[i]), _quantity_value(b.quantity, b.model[i]),
                         _signed(b.quantity, s["margin"]) if math.isfinite(s["margin"]) else "no model value", rel,
                         _where(c, i)))
    return Table(("file", "bound", "stated", "rows", "met", "bound at worst row", "model there", "margin",
                  "model / bound", "worst row"), tuple(rows))


_BOUND_CSV_COLUMNS = ("file", "line", "sweep_value", "distance_m", "bound", "relation", "bound_value", "model_value",
                      "met", "margin")


def bound_rows(comparisons: list[FileComparison]) -> list[dict[str, str]]:
    """Every bound at every row that has one, as flat records (``bounds.csv``)."""
    out = []
    for c in comparisons:
        for b in c.bounds:
            for i in np.flatnonzero(np.isfinite(b.bound)):
                out.append({"file": Path(c.path).name, "line": str(int(c.lines[i])), "sweep_value": _cell(c.x[i]),
                            "distance_m": _cell(c.distance_m[i]), "bound": b.quantity, "relation": b.relation,
                            "bound_value": _cell(b.bound[i]), "model_value": _cell(b.model[i]),
                            "met": "yes" if b.met[i] else "no", "margin": _cell(b.margin[i])})
    return out


_MD_COLUMNS = (("line", "line"), ("sweep_value", "x"), ("measured_depth_error_m", "depth err meas [m]"),
               ("model_depth_error_m", "depth err model [m]"), ("measured_depth_std_m", "depth std meas [m]"),
               ("model_depth_std_m", "depth std model [m]"), ("ratio_depth_std", "ratio"),
               ("measured_amplitude_mean_lsb", "amp meas [LSB]"), ("model_amplitude_mean_lsb", "amp model [LSB]"),
               ("ratio_amplitude_mean", "ratio"), ("flags", "flags"))


def write_comparison(comparisons: list[FileComparison], out: str | Path, *, title: str = "Measured vs model",
                     preamble: list[str] | None = None, stem: str = "comparison", figures: bool = True) -> list[Path]:
    """Write ``{stem}.csv``, ``{stem}.md``, ``{stem}.html`` and, with ``figures``, one
    ``{stem}_<i>_<file>.png`` per file into ``out`` (created); returns the paths. Without figures the
    reports hold the tables (``tofjax calibrate``, whose own figures show the files)."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    written: list[Path] = []
    per_file = [table_rows([c]) for c in comparisons]  # each file's own rows, whatever its name
    records = [r for rows in per_file for r in rows]
    csv_path = out / f"{stem}.csv"
    with atomic_path(csv_path) as tmp, open(tmp, "w", newline="", encoding="utf-8") as f:
        writer = csv.DictWriter(f, fieldnames=list(_CSV_COLUMNS))
        writer.writeheader()
        writer.writerows({k: _spreadsheet_safe(v) if k in _TEXT_COLUMNS else v for k, v in r.items()} for r in records)
    written.append(csv_path)
    checks = bound_rows(comparisons)
    if checks:  # beside a calibration's two comparisons, each its own (compare_initial_bounds.csv)
        bounds_path = out / ("bounds.csv" if stem == "comparison" else f"{stem}_bounds.csv")
        with atomic_path(bounds_path) as tmp, open(tmp, "w", newline="", encoding="utf-8") as f:
            writer = csv.DictWriter(f, fieldnames=list(_BOUND_CSV_COLUMNS))
            writer.writeheader()
            writer.writerows({k: _spreadsheet_safe(v) if k == "file" else v for k, v in r.items()} for r in checks)
        written.append(bounds_path)
    pngs = []
    for i, c in enumerate(comparisons if figures else ()):
        fig = figure(c)
        buffer = io.BytesIO()
        fig.savefig(buffer, format="png", dpi=90)
        path = out / f"{stem}_{i}_{_file_name_part(Path(c.path).stem)}.png"
        write_bytes(path, buffer.getvalue())
        pngs.append((path, buffer.getvalue()))
        written.append(path)
    notes = [f"Ratios are model / measured; agreement means within {100 * AGREEMENT:.0f} %; flagged rows are left out "
             "of the summary. The model is tofjax's hard analytic path of the configured camera (with each file's "
             "metadata overrides)."]
    header = tuple(h for _, h in _MD_COLUMNS)
    report = Summary(title, [*(preamble or []), *notes], [Section("Summary", [_summary_table(comparisons)])])
    if checks:
        report.sections.append(Section("Published bounds", [
            "Each bound is checked at every row that states it, against the model of the file's camera and "
            "conditions. The margin is bound - model for an upper bound and model - bound for a lower one: "
            "positive where the bound is met. The worst row is the one with the smallest margin.",
            _bounds_table(comparisons)]))
    for c, rows, png in itertools.zip_longest(comparisons, per_file, pngs):
        name = Path(c.path).name
        report.sections.append(Section(name, [
            *([Figure(png[0].name, png[1], name)] if png else []),
            Table(header, tuple(tuple(r[k] for k, _ in _MD_COLUMNS) for r in rows), tuple(bool(r["flags"]) for r in rows)),
        ]))
    md_path = out / f"{stem}.md"
    write_text(md_path, report.markdown())
    written.append(md_path)
    html_path = out / f"{stem}.html"
    write_text(html_path, report.html())
    written.append(html_path)
    return written


#: The CSV's text columns (the rest are numbers): a spreadsheet must not run what they hold.
_TEXT_COLUMNS = ("file", "flags")


def _spreadsheet_safe(text: str) -> str:
    """A CSV text cell a spreadsheet shows as text: one that starts as a formula would (=, +, -, @,
    a tab or a carriage return; ``=HYPERLINK(...)`` in a file name) gets a leading apostrophe, as
    OWASP recommends against CSV injection."""
    return "'" + text if text[:1] in ("=", "+", "-", "@", "\t", "\r") else text


def _file_name_part(stem: str, limit: int = 48) -> str:
    """A part of an output file's name from an input's stem: letters, digits, ``.``, ``-`` and ``_``
    only, at most ``limit`` characters (a 240-character input name must not break the output's)."""
    return re.sub(r"[^A-Za-z0-9._-]+", "_", stem)[:limit] or "file"


