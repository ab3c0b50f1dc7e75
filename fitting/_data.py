"""Measured sweeps as calibration data: rows, uncertainties and the camera each file was taken with.

Each file's operating points are its per-row ``distance_m``, ``illuminance_lx`` and
``integration_time_s`` columns. Its camera is the calibration configuration, with any metadata line
whose key is a dotted configuration key (``# scene.reflectivity: 0.9``, ``# scene.background:
halogen``) overriding that key for this file. The modulation frequency and number of phases in the
metadata must match the configuration.

Uncertainties, from ``n_frames`` and the model's own noise prediction at the current parameters
(so the weights do not follow the data's fluctuations; the posterior includes their
normalisation), or one relative error of every measured value when given:
- amplitude: standard error of a mean, ``sigma_amplitude / sqrt(n_frames)``;
- depth standard deviation: standard error of a standard deviation of Gaussian data,
  ``sigma_depth / sqrt(2 (n_frames - 1))``.

Rows that do not enter the fit, and why (counted in the diagnostics):
- ``valid_fraction < 1``: some frames saturated; the statistics of the remaining frames are
  biased, while the model's expected statistics assume no saturation;
- measured amplitude SNR ``amplitude_mean_lsb / amplitude_std_lsb < min_snr`` (default 5): the
  analytic model agrees with the Monte Carlo within ~1.5 % down to SNR 4 and degrades below
  (docs/model.md, "Analytic path");
- an empty cell: not measured; that residual is absent, the row's other one stays.
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import tofjax as tj
from tofjax import sweepfile as sf
from tofjax.schema import KEY_BY_DOTTED, coerce

from ._parameters import CalibrationInputError

OBSERVABLES = ("amplitude_mean_lsb", "depth_std_m")


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

    def used(self, name: str) -> np.ndarray:
        """Indices of the rows of observable ``name`` that enter the fit."""
        return np.flatnonzero(self.data[name][1])

    @property
    def params(self) -> tj.Params:
        return self.config.params


def _overrides(path: str, metadata: dict[str, str], config: tj.Config) -> tj.Config:
    for key, text in metadata.items():
        if key not in KEY_BY_DOTTED:
            continue
        spec = KEY_BY_DOTTED[key]
        if spec.dotted in ("scene.distance_m", "scene.illuminance_lx", "scene.integration_time_s"):
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
        elif spec.kind in ("pair", "angle", "float_list"):
            raise CalibrationInputError(f"{path}: metadata {key} cannot override a pair or list; set it in the "
                                        "configuration")
        try:
            coerce(spec, value, path)
            config = config.replace(key, value)
        except ValueError as err:
            raise CalibrationInputError(f"{path}: metadata {err}") from None
    return config


def load_rows(path: str | Path, config: tj.Config, *, relative_error: float | None = None,
              min_snr: float = 5.0) -> SweepRows:
    """Read one sweep file and prepare its residual rows (see the module docstring)."""
    data = sf.read_sweep(path)
    path = str(path)
    meta = data.metadata
    f_cfg = float(config.params.illumination_waveform.modulation_frequency_hz)
    if not math.isclose(data.modulation_frequency_hz, f_cfg, rel_tol=1e-9):
        raise CalibrationInputError(
            f"{path}: modulation_frequency_hz = {data.modulation_frequency_hz!r} in the file, but the configuration "
            f"has illumination_waveform.modulation_frequency_hz = {f_cfg!r}")
    if data.n_phases != config.params.pixel.n_phases:
        raise CalibrationInputError(f"{path}: n_phases = {data.n_phases} in the file, but the configuration has "
                                    f"pixel.n_phases = {config.params.pixel.n_phases}")
    file_config = _overrides(path, meta, config)
    cols = data.columns
    for name in ("distance_m", "illuminance_lx", "integration_time_s"):
        empty = np.isnan(cols[name])
        if np.any(empty):
            i = int(np.argmax(empty))
            raise CalibrationInputError(f"{path}:{data.lines[i]}: column {name} (field {data.fields[name]}) is empty: "
                                        "every row needs its operating point")
    frames = cols["n_frames"]
    if relative_error is None and np.any(frames < 2):
        i = int(np.argmax(frames < 2))
        raise CalibrationInputError(
            f"{path}:{data.lines[i]}: n_frames = {frames[i]:g}: uncertainties need at least 2 frames per row "
            "(an analytic prediction has 0); give a relative error (--relative-error)")
    if relative_error is not None and not (0 < relative_error < 10):
        raise CalibrationInputError(f"relative error = {relative_error!r} is out of range: allowed 0 < value < 10")
    if relative_error is None and not file_config.params.pixel.noise:
        raise CalibrationInputError(f"{path}: the configuration has pixel.noise = false, so the model predicts no "
                                    "noise and cannot weight the rows; enable noise or give --relative-error")

    valid = cols["valid_fraction"] >= 1.0
    amp, amp_std = cols["amplitude_mean_lsb"], cols["amplitude_std_lsb"]
    with np.errstate(divide="ignore", invalid="ignore"):
        snr = amp / amp_std
    low_snr = valid & (snr < min_snr)  # NaN (not measured) compares False: kept
    keep = valid & ~low_snr
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
    if sum(int(np.sum(v[1])) for v in out.values()) == 0:
        raise CalibrationInputError(f"{path}: no row enters the fit ({excluded['saturated']} saturated, "
                                    f"{excluded['low_snr']} below the amplitude SNR {min_snr:g}, the rest not measured)")
    sweep = tj.Sweep.points(data.sweep, cols["distance_m"], cols["illuminance_lx"], cols["integration_time_s"])
    return SweepRows(path, data.sweep, file_config, sweep, out, frames, excluded, data.n_rows)
