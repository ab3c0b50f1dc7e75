"""Sweep files simulated by Monte Carlo from known parameters: the example data set, the tests'
parameter-recovery checks and the recovery benchmark. Each file says so in its metadata
(``source: simulation``, ``true.<parameter>: value`` lines)."""

from __future__ import annotations

from pathlib import Path

import jax
import tofjax as tj
from tofjax import sweepfile as sf


def write_simulated_sweep(path: str | Path, params: tj.Params, sweep: tj.Sweep, frames: int, key,
                          *, true_values: dict[str, float] | None = None,
                          overrides: dict[str, object] | None = None, note: str = "") -> sf.SweepData:
    """Simulate ``frames`` frames per row and write a tofjax-sweep file.

    **Arguments:**
    - ``params``: the camera that "measures" (with its true parameter values).
    - ``sweep``: the operating points; ``frames``: frames per row; ``key``: a jax.random key.
    - ``true_values``: written as ``# true.<name>: value`` (information only).
    - ``overrides``: written as ``# <dotted key>: value``; a calibration applies them to this file.
    """
    result = jax.device_get(tj.simulate(params, sweep, key, frames))
    meta = {
        "sweep": sweep.variable, "source": "simulation",
        "modulation_frequency_hz": repr(float(params.illumination_waveform.modulation_frequency_hz)),
        "n_phases": params.pixel.n_phases, "software": f"tofjax {tj.__version__}", "frames": frames,
    }
    if note:
        meta["note"] = note
    for name, value in (overrides or {}).items():
        meta[name] = value
    for name, value in (true_values or {}).items():
        meta[f"true.{name}"] = repr(float(value))
    cols = sf.columns_from_result(result)
    sf.write_sweep(path, meta, {name: cols[name] for name in sf.REQUIRED_COLUMNS})
    return sf.read_sweep(path)
