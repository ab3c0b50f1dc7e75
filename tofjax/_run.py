"""One sweep run from a configuration, as ``tofjax simulate`` and the explorer do it.

The configuration's camera (:class:`tofjax.Camera`) and one of the two verbs: Monte Carlo
(:func:`tofjax.simulate`) or analytic (:func:`tofjax.predict`); the verbs decide the path (several
modulation frequencies: per frequency and fused, §2.2). Results come back on the host, with the wall
time of the run.
"""

from __future__ import annotations

import dataclasses
import json
import time

import jax
import numpy as np

from ._camera import Camera, predict, simulate
from ._config import Config
from ._montecarlo import max_keep_frames
from ._multifrequency import MultiFrequencyResult
from ._result import Result
from ._sweep import Sweep

METHODS = ("mc", "analytic")


@dataclasses.dataclass(frozen=True)
class Run:
    """A finished sweep: ``result`` (the first modulation frequency's when there are several),
    ``multifrequency`` (``None`` for one frequency), and ``elapsed_s`` (wall time, compilation
    included)."""

    config: Config
    sweep: Sweep
    method: str
    iterations: int
    seed: int
    result: Result
    multifrequency: MultiFrequencyResult | None
    elapsed_s: float
    fixed_pattern: bool = False


def run_sweep(config: Config, sweep: Sweep, method: str = "mc", iterations: int | None = None, seed: int = 0,
              fixed_pattern: bool = False, keep_frames: int = 0, progress: bool = False) -> Run:
    """Run ``sweep`` with ``config``: ``method`` ``"mc"`` or ``"analytic"``; ``iterations`` frames per
    sample (default ``pixel.iterations``); ``seed`` of the Monte Carlo; ``keep_frames``: frames per
    sample to keep for plots (at most ``iterations``, and at most what fits a quarter of the device's
    memory for this many samples: :func:`tofjax._montecarlo.max_keep_frames`; the statistics use
    every frame regardless);
    ``progress``: the Monte Carlo reports its chunks to :mod:`tofjax.progress`.

    Several modulation frequencies (``extra_modulation_frequencies_hz``) are fused as
    ``illumination_waveform.frequency_fusion`` says: frame by frame (``"mc"``) or analytically
    (``"analytic"``: :func:`tofjax.predict` of a multi-frequency camera, noise for the correct unwrap, no
    wrong-unwrap fraction). Raises ``ValueError`` for an unknown method, and for ``fixed_pattern``
    where it cannot act (:func:`fixed_pattern_problem`).
    """
    if method not in METHODS:
        raise ValueError(f"method = {method!r} is not allowed: expected one of {', '.join(map(repr, METHODS))}")
    problem = fixed_pattern_problem(config, method) if fixed_pattern else None
    if problem:
        raise ValueError(f"fixed_pattern = True {problem}")
    iterations = config.iterations if iterations is None else iterations
    camera = Camera.from_config(config)
    t0 = time.perf_counter()
    copies = len(camera.frequencies_hz) + 1 if camera.multifrequency else 1
    keep = min(keep_frames, iterations, max_keep_frames(sweep.samples * copies, camera.params.pixel.n_phases))
    key = jax.random.key(seed)
    if fixed_pattern:  # the population's dark slopes, drawn from the key (simulate(params, ...)'s own door)
        out = simulate(camera.params, sweep, key, iterations, fixed_pattern=True, keep_frames=keep, progress=progress,
                       processing=camera.processing)
    elif method == "mc":
        out = simulate(camera, sweep, key, iterations, keep_frames=keep, progress=progress)
    else:
        out = predict(camera, sweep)
    out = jax.device_get(out)
    multi = out if isinstance(out, MultiFrequencyResult) else None
    result = out if multi is None else jax.tree_util.tree_map(lambda x: x[0], multi.per_frequency)
    return Run(config, sweep, method, iterations, seed, result, multi, time.perf_counter() - t0, fixed_pattern)


def fixed_pattern_problem(config: Config, method: str) -> str | None:
    """Why a sweep's fixed pattern (dark slopes drawn from the population) cannot act on ``method``
    with ``config``, or ``None``: the draw is made per Monte Carlo run of one modulation frequency, so
    the analytic and the multi-frequency runs would drop it while the file said it was on."""
    if method != "mc":
        return "needs the Monte Carlo (method 'mc'): the analytic sweep is the mean pixel's"
    if len(config.modulation_frequencies_hz) > 1:
        return ("needs one modulation frequency: the multi-frequency run draws no pattern "
                f"({len(config.modulation_frequencies_hz)} configured)")
    return None


def multifrequency_columns(mf: MultiFrequencyResult) -> dict:
    """Sweep-file columns of a multi-frequency run: combined depth statistics, the first frequency's
    amplitude, the wrong-unwrap fraction and each frequency's own depth noise."""
    from .sweepfile import operating_point_columns

    primary = mf.per_frequency
    cols = {
        **operating_point_columns(primary, 0), "n_frames": np.full(primary.distance_m.shape[1], float(primary.n_frames)),
        "depth_mean_m": mf.depth_mean_m, "depth_std_m": mf.depth_std_m,
        "amplitude_mean_lsb": primary.amplitude_mean_lsb[0], "amplitude_std_lsb": primary.amplitude_std_lsb[0],
        "valid_fraction": mf.valid_fraction, "wrong_unwrap_fraction": mf.wrong_unwrap_fraction,
    }
    for i in range(primary.depth_std_m.shape[0]):
        cols[f"depth_std_m_f{i + 1}"] = primary.depth_std_m[i]
    return {k: np.asarray(v, dtype=float) for k, v in cols.items()}


def sweep_file_contents(run: Run, config_file: str = "(built-in defaults)") -> tuple[dict, dict]:
    """The tofjax-sweep file of a run (:func:`tofjax.sweepfile.write_sweep`'s metadata and columns):
    what ``tofjax simulate --out`` and the explorer's report write."""
    from . import __version__
    from .sweepfile import columns_from_result, utc_now

    config, params, multi = run.config, run.config.params, run.multifrequency
    mc = run.method == "mc"
    metadata = {
        "sweep": run.sweep.variable, "source": "simulation", "method": run.method,
        "modulation_frequency_hz": repr(float(params.illumination_waveform.modulation_frequency_hz)),
        "n_phases": params.pixel.n_phases, "created_utc": utc_now(), "software": f"tofjax {__version__}",
        "seed": run.seed if mc else "", "iterations": run.iterations if mc else 0,
        "fixed_pattern": str(bool(run.fixed_pattern)).lower(), "config_file": config_file,
        "config_json": json.dumps(config.values, separators=(",", ":")),
        "unambiguity_range_m": repr(float(run.result.unambiguity_range_m)),  # the first frequency's
        "depth_columns": "depth_mean_m is wrapped into [0, unambiguity_range_m) (the circular mean, what a camera "
                         "reports); depth_unwrapped_mean_m is unwrapped along the sweep (the summary's 'unwrapped')"
                         if multi is None else "depth_mean_m is the frequencies' fused, unwrapped distance",
    }
    if config.phase_images_per_integration_time != 1:  # the file's times are the model's, per phase image
        metadata["integration_time_note"] = (f"integration_time_s is per phase image: the configuration's times "
                                             f"({config.values['scene']['integration_time_per']}) / "
                                             f"{config.phase_images_per_integration_time}")
    if multi is not None:
        metadata["modulation_frequencies_hz"] = ",".join(repr(float(f)) for f in config.modulation_frequencies_hz)
        metadata["extended_range_m"] = repr(float(multi.extended_range_m))
        metadata["frequency_fusion"] = multi.fusion
    return metadata, multifrequency_columns(multi) if multi is not None else columns_from_result(run.result)
