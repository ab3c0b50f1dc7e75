"""Measured sweeps as calibration data: rows, uncertainties and the camera each file was taken with.

Each file's operating points are its per-row ``distance_m``, ``illuminance_lx`` and
``integration_time_s`` columns, and ``temperature_c`` (the sensor's, format 3) where it has one;
without it every row is at the configuration's ``pixel.temperature_c`` (or the file's own
``# pixel.temperature_c:`` line). Its camera is the calibration configuration, with any metadata line
whose key is a dotted configuration key (``# scene.reflectivity: 0.9``, ``# scene.background:
halogen``) overriding that key for this file. The modulation frequencies and number of phases in the
metadata must match the configuration: a file of one frequency against a configuration of several
(or the reverse) is refused, never fitted as if the other frequencies did not exist. A
multi-frequency file (format 2, ``modulation_frequencies_hz``) is modelled as its camera fused the
frequencies (``frequency_fusion`` in the file, else the configuration's): the depth noise is the
fused distance's, the amplitude the first frequency's. The file's ``integration_time_per`` converts
its integration times to the model's phase images (:func:`tofjax.optics.phase_image_time_s`).

Uncertainties, from ``n_frames`` and the model's own noise prediction at the current parameters
(so the weights do not follow the data's fluctuations; the posterior includes their
normalisation), or one relative error of every measured value when given:
- amplitude: standard error of a mean, ``sigma_amplitude / sqrt(n_frames)``;
- depth standard deviation: standard error of a standard deviation of Gaussian data,
  ``sigma_depth / sqrt(2 (n_frames - 1))``;
- mean depth reading: standard error of a mean, ``sigma_depth / sqrt(n_frames)``.

Rows that do not enter the fit, and why (counted in the diagnostics, and each row's reason kept in
``SweepRows.reasons`` for the report and the figures):
- ``valid_fraction < 1``: some frames saturated; the statistics of the remaining frames are
  biased, while the model's expected statistics assume no saturation (an absent or empty
  ``valid_fraction`` is unknown: the row enters, and the fitted model's own validity decides,
  :func:`fitting.calibrate`);
- measured amplitude SNR ``amplitude_mean_lsb / amplitude_std_lsb < min_snr`` (default 5): the
  analytic model agrees with the Monte Carlo within ~1.5 % down to SNR 4 and degrades below
  (docs/model.md, "Analytic path");
- an empty cell: not measured; that residual is absent, the row's other one stays.

Bounds (format 4, a datasheet's promise: ``depth_std_m_lt``, ...) are kept per file as
:class:`Bound` columns (:attr:`SweepRows.bounds`): the calibration holds the model on their met side
(:mod:`fitting._problem`). A file may hold bounds only (a ``source: specification`` file): its rows
need no ``n_frames`` and no noise model for weights, as nothing of theirs is weighted. A bound on a
quantity the model cannot predict for the file's camera is refused in one line (a ``depth_std_m``
bound with ``pixel.noise = false``: the model has no depth noise to judge).
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import tofjax as tj
from tofjax import sweepfile as sf
from tofjax.schema import KEY_BY_DOTTED, OPERATING_POINT_COLUMNS, SWEEP_AXES, coerce

from ._parameters import CalibrationInputError

#: What a file's rows say and the fit explains: the amplitude, the depth noise and the mean distance
#: reading (the camera's systematic error: offset and wiggling, against the row's true distance).
OBSERVABLES = ("amplitude_mean_lsb", "depth_std_m", "depth_mean_m")


#: The quantities a bound may state that the fit models (:data:`tofjax.sweepfile.BOUND_QUANTITIES`):
#: the depth noise, the depth error's magnitude (the camera's reading minus the true distance) and the
#: amplitude, as ``tofjax compare`` judges them (:func:`fitting.check_bounds`).
BOUND_MODELS = ("depth_std_m", "depth_error_m", "amplitude_mean_lsb")


@dataclasses.dataclass
class Bound:
    """One bound column of a file: ``column`` (``depth_std_m_lt``), its ``quantity`` and ``relation``
    (``le``, ``lt``, ``ge``, ``gt``), the ``statement`` its ``# bound.`` line quotes, and ``values``
    per row (NaN: no bound at that row)."""

    column: str
    quantity: str
    relation: str
    statement: str
    values: np.ndarray

    @property
    def upper(self) -> bool:
        """Whether it bounds the quantity from above (``le``, ``lt``)."""
        return self.relation in ("le", "lt")


@dataclasses.dataclass
class SweepRows:
    """One sweep file prepared for the fit."""

    path: str
    sweep_variable: str
    config: tj.Config
    sweep: tj.Sweep
    #: observable -> (values with NaN where not measured, mask of rows that enter the fit)
    data: dict[str, tuple[np.ndarray, np.ndarray]]
    frames: np.ndarray
    excluded: dict[str, int]
    n_rows: int
    #: Every modulation frequency of the measurement, and how the camera fused them.
    frequencies_hz: tuple[float, ...] = ()
    fusion: str = "inverse_variance"
    #: The camera's own processing stages (``[processing]``, :mod:`tofjax.processing`).
    processing: tuple = ()
    #: Row index -> why the row does not enter the fit.
    reasons: dict[int, str] = dataclasses.field(default_factory=dict)
    #: 1-based line of each row in the file.
    lines: np.ndarray | None = None
    #: The file's metadata (``true.<key>`` values among them).
    metadata: dict[str, str] = dataclasses.field(default_factory=dict)
    #: The file's bound columns (format 4; empty for a file of measured values only).
    bounds: list[Bound] = dataclasses.field(default_factory=list)

    @property
    def bounded(self) -> np.ndarray:
        """Which rows state a bound (any column)."""
        out = np.zeros(self.n_rows, bool)
        for b in self.bounds:
            out |= np.isfinite(b.values)
        return out

    def line(self, k: int) -> int:
        """The file line of row ``k``."""
        return int(self.lines[k]) if self.lines is not None else k + 1

    def used(self, name: str) -> np.ndarray:
        """Indices of the rows of observable ``name`` that enter the fit."""
        return np.flatnonzero(self.data[name][1])

    @property
    def params(self) -> tj.Params:
        return self.config.params


def _overrides(path: str, metadata: dict[str, str], config: tj.Config, columns) -> tj.Config:
    """``config`` with the file's metadata lines that name configuration keys applied, except the
    operating point's where the file has its column (``columns``): its rows set those."""
    rows_set = {axis.key for axis in SWEEP_AXES.values() if axis.column in columns}
    for key, text in metadata.items():
        if key not in KEY_BY_DOTTED:
            continue
        spec = KEY_BY_DOTTED[key]
        if spec.dotted in rows_set:
            continue
        value: object = text
        if spec.kind in ("float", "int"):
            try:
                value = int(text) if spec.kind == "int" else float(text)
            except ValueError:
                raise CalibrationInputError(f"{path}: metadata {key} = {text!r} is not a number") from None
        elif spec.kind == "bool":
            if text.lower() not in ("true", "false"):
                raise CalibrationInputError(f"{path}: metadata {key} = {text!r} is not true or false")
            value = text.lower() == "true"
        elif spec.kind in ("pair", "angle", "float_list", "choice_list"):
            raise CalibrationInputError(f"{path}: metadata {key} cannot override a pair or list; set it in the "
                                        "configuration")
        try:
            coerce(spec, value, path)
            config = config.replace(key, value)
        except ValueError as err:
            raise CalibrationInputError(f"{path}: metadata {err}") from None
    return config


@dataclasses.dataclass
class Measurement:
    """A sweep file checked against the configuration: its data, its columns with the integration
    times per phase image, the camera it was taken with, its operating points, its frequencies and
    their fusion, and its own processing (``[processing]``)."""

    path: str
    data: sf.SweepData
    columns: dict[str, np.ndarray]
    config: tj.Config
    sweep: tj.Sweep
    frequencies_hz: tuple[float, ...]
    fusion: str

    @property
    def processing(self) -> tuple:
        """The camera's processing stages (:attr:`tofjax.Config.processing`)."""
        return self.config.processing


def read_measurement(path: str | Path, config: tj.Config) -> Measurement:
    """Read one sweep file and check it against ``config`` (module docstring): frequencies, phases,
    metadata overrides, exposure definition, operating points."""
    data = sf.read_sweep(path)
    path = str(path)
    meta = data.metadata
    # The file's own overrides first: the checks below hold for the camera the file is modelled
    # with (a "# pixel.n_phases: 3" beside "# n_phases: 4" is refused, not applied after the check).
    file_config = _overrides(path, meta, config, data.fields)
    f_cfg = file_config.modulation_frequencies_hz
    f_file = data.modulation_frequencies_hz
    if len(f_file) != len(f_cfg):
        raise CalibrationInputError(
            f"{path}: the file was measured at {len(f_file)} modulation frequenc{'y' if len(f_file) == 1 else 'ies'} "
            f"({', '.join(f'{f:g}' for f in f_file)} Hz), the configuration has {len(f_cfg)} "
            f"({', '.join(f'{f:g}' for f in f_cfg)} Hz): "
            + ("state every frequency in the file (format tofjax-sweep/2: \"# modulation_frequencies_hz: f1, f2\") or "
               "remove illumination_waveform.extra_modulation_frequencies_hz" if len(f_file) < len(f_cfg) else
               "set illumination_waveform.extra_modulation_frequencies_hz to the file's further frequencies"))
    for k, (a, b) in enumerate(zip(f_file, f_cfg, strict=True)):
        if not math.isclose(a, b, rel_tol=1e-9):
            key = "modulation_frequency_hz" if k == 0 else f"extra_modulation_frequencies_hz[{k - 1}]"
            raise CalibrationInputError(f"{path}: modulation frequency {k + 1} = {a!r} Hz in the file, but the "
                                        f"configuration has illumination_waveform.{key} = {b!r}")
    if data.n_phases != file_config.params.pixel.n_phases:
        raise CalibrationInputError(f"{path}: n_phases = {data.n_phases} in the file, but the configuration has "
                                    f"pixel.n_phases = {file_config.params.pixel.n_phases}")
    cols = dict(data.columns)
    per = data.integration_time_per
    if per != "phase_image":  # the model's unit is one phase image
        cols["integration_time_s"] = tj.optics.phase_image_time_s(cols["integration_time_s"], per, data.n_phases, len(f_file))
    if "temperature_c" not in data.fields:  # a file without it: every row at the configured temperature
        cols["temperature_c"] = np.full(data.n_rows, float(file_config.params.pixel.temperature_c))
    for name in OPERATING_POINT_COLUMNS:
        empty = np.isnan(cols[name])
        if np.any(empty):
            i = int(np.argmax(empty))
            raise CalibrationInputError(f"{path}:{data.lines[i]}: column {name} (field {data.fields[name]}) is empty: "
                                        "every row needs its operating point")
    sweep = tj.Sweep.points(data.sweep, **{name: cols[name] for name in OPERATING_POINT_COLUMNS})
    fusion = meta.get("frequency_fusion", config.values["illumination_waveform"]["frequency_fusion"])
    return Measurement(path, data, cols, file_config, sweep, tuple(f_file), fusion)


def reason_kind(reason: str) -> str:
    """A row's reason for being left out (:attr:`SweepRows.reasons`, written in :func:`load_rows`)
    without its row's numbers: one legend entry per kind in the figures."""
    if "frames valid" in reason:
        return "saturated frames"
    if "--min-snr" in reason:
        return "amplitude SNR below --min-snr"
    return reason


def load_rows(path: str | Path, config: tj.Config, *, relative_error: float | None = None,
              min_snr: float = 5.0) -> SweepRows:
    """Read one sweep file and prepare its residual rows (see the module docstring)."""
    m = read_measurement(path, config)
    path, data, cols, file_config = m.path, m.data, m.columns, m.config
    bounds = _bounds(path, data, file_config)
    measured_rows = np.zeros(data.n_rows, bool)
    for name in OBSERVABLES:
        measured_rows |= ~np.isnan(cols[name])
    frames = cols["n_frames"]
    few = ~(frames >= 2) & (measured_rows | (not bounds))  # an empty cell (NaN): not stated; a bound needs none
    if relative_error is None and np.any(few):
        i = int(np.argmax(few))
        stated = "not stated (empty)" if np.isnan(frames[i]) else f"{frames[i]:g}"
        raise CalibrationInputError(
            f"{path}:{data.lines[i]}: n_frames = {stated}: uncertainties need at least 2 frames per row "
            "(an analytic prediction has 0); give a relative error (--relative-error)")
    if relative_error is not None and not (0 < relative_error < 10):
        raise CalibrationInputError(f"relative error = {relative_error!r} is out of range: allowed 0 < value < 10")
    if relative_error is None and not file_config.params.pixel.noise and (np.any(measured_rows) or not bounds):
        raise CalibrationInputError(f"{path}: the configuration has pixel.noise = false, so the model predicts no "
                                    "noise and cannot weight the rows; enable noise or give --relative-error")

    valid = ~(cols["valid_fraction"] < 1.0)  # empty: unknown, kept (the fitted model decides)
    amp, amp_std = cols["amplitude_mean_lsb"], cols["amplitude_std_lsb"]
    with np.errstate(divide="ignore", invalid="ignore"):
        snr = amp / amp_std
    low_snr = valid & (snr < min_snr)  # NaN (not measured) compares False: kept
    keep = valid & ~low_snr
    reasons = {int(i): f"{cols['valid_fraction'][i]:.3g} of its frames valid (the rest saturated)"
               for i in np.flatnonzero(~valid)}
    reasons.update({int(i): f"measured amplitude SNR {snr[i]:.3g} below the limit {min_snr:g} (--min-snr)"
                    for i in np.flatnonzero(low_snr)})
    out, excluded = {}, {"saturated": int(np.sum(~valid)), "low_snr": int(np.sum(low_snr))}
    for name in OBSERVABLES:
        values = cols[name]
        measured = keep & ~np.isnan(values)
        bad = measured & ~(np.abs(values) > 0) if relative_error is not None else np.zeros_like(measured)
        if np.any(bad):
            i = int(np.argmax(bad))
            raise CalibrationInputError(f"{path}:{data.lines[i]}: column {name} (field {data.fields[name]}) = 0 has a "
                                        "zero relative uncertainty; such a row cannot be weighted")
        zero_std = measured & (values == 0) & (frames >= 2) if name == "depth_std_m" else np.zeros_like(measured)
        if np.any(zero_std):  # the model predicts noise; a zero is a recording or export error
            i = int(np.argmax(zero_std))
            raise CalibrationInputError(
                f"{path}:{data.lines[i]}: column depth_std_m (field {data.fields[name]}) = 0 over {frames[i]:g} frames: "
                "a measured depth noise cannot be exactly zero (a camera quantising depth coarser than its noise, or "
                "an export error); leave the cell empty if it was not measured")
        out[name] = (values, measured)
    if sum(int(np.sum(v[1])) for v in out.values()) == 0 and not bounds:
        raise CalibrationInputError(f"{path}: no row enters the fit ({excluded['saturated']} saturated, "
                                    f"{excluded['low_snr']} below the amplitude SNR {min_snr:g}, the rest not measured)")
    return SweepRows(path, data.sweep, file_config, m.sweep, out, frames, excluded, data.n_rows, m.frequencies_hz,
                     m.fusion, m.processing, reasons, data.lines, dict(data.metadata), bounds)


def _bounds(path: str, data: sf.SweepData, config: tj.Config) -> list[Bound]:
    """The file's bound columns as :class:`Bound` (module docstring), each on a quantity the model
    predicts for the file's camera; anything else is refused in one line."""
    out = []
    for column in data.bounds:
        quantity, relation = sf.bound_column(column)
        if quantity not in BOUND_MODELS:
            raise CalibrationInputError(f"{path}: column {column} (field {data.fields[column]}) bounds {quantity}, which "
                                        f"the calibration does not model (it models {', '.join(BOUND_MODELS)}); "
                                        "tofjax compare checks it")
        if quantity == "depth_std_m" and not config.params.pixel.noise:
            raise CalibrationInputError(f"{path}: column {column} (field {data.fields[column]}) bounds the depth noise, "
                                        "but the configuration has pixel.noise = false: the model predicts no noise, "
                                        "so the bound cannot be judged; enable noise")
        values = np.asarray(data.columns[column], dtype=float)
        zero = np.flatnonzero((values == 0) & (relation in ("le", "lt")))
        if zero.size:
            raise CalibrationInputError(f"{path}:{data.lines[zero[0]]}: column {column} (field {data.fields[column]}) "
                                        f"= 0: an upper bound of 0 leaves no room to hold the model inside (the "
                                        "calibration holds it 0.1 % of the bound inside); leave the cell empty for no "
                                        "bound at that row")
        out.append(Bound(column, quantity, relation, data.metadata.get(f"bound.{column}", ""),
                         np.where(values > 0, values, np.nan)))  # a lower bound of 0 always holds: none
    return out
