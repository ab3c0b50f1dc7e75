"""One sweep run from a configuration, as ``tofjax simulate`` and the explorer do it.

Picks the path from the configuration and the method: several modulation frequencies -> Monte
Carlo per frequency and unwrapping by agreement (§2.2); otherwise Monte Carlo (:func:`simulate`)
or analytic (:func:`predict`). Results come back on the host, with the wall time of the run.
"""

from __future__ import annotations

import dataclasses
import time

import jax

from ._config import Config
from ._analytic import predict
from ._montecarlo import max_keep_frames, simulate
from ._multifrequency import MultiFrequencyResult, predict_multifrequency, simulate_multifrequency
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


def run_sweep(config: Config, sweep: Sweep, method: str = "mc", iterations: int | None = None, seed: int = 0,
              fixed_pattern: bool = False, keep_frames: int = 0, progress: bool = False) -> Run:
    """Run ``sweep`` with ``config``: ``method`` ``"mc"`` or ``"analytic"``; ``iterations`` frames per
    sample (default ``pixel.iterations``); ``seed`` of the Monte Carlo; ``keep_frames``: frames per
    sample to keep for plots (at most ``iterations``, and at most what fits 1 GiB for this many samples:
    :func:`tofjax._montecarlo.max_keep_frames`; the statistics use every frame regardless);
    ``progress``: the Monte Carlo reports its chunks to :mod:`tofjax.progress`.

    Several modulation frequencies (``extra_modulation_frequencies_hz``) are fused as
    ``illumination_waveform.frequency_fusion`` says: frame by frame (``"mc"``) or analytically
    (``"analytic"``: :func:`tofjax.predict_multifrequency`, noise for the correct unwrap, no
    wrong-unwrap fraction). Raises ``ValueError`` for an unknown method.
    """
    if method not in METHODS:
        raise ValueError(f"method = {method!r} is not allowed: expected one of {', '.join(map(repr, METHODS))}")
    iterations = config.iterations if iterations is None else iterations
    params, freqs = config.params, config.modulation_frequencies_hz
    fusion = config.values["illumination_waveform"]["frequency_fusion"]
    t0 = time.perf_counter()
    multi = None
    copies = len(freqs) + 1 if len(freqs) > 1 else 1
    keep = min(keep_frames, iterations, max_keep_frames(sweep.samples * copies, params.pixel.n_phases))
    if len(freqs) > 1:
        if method == "mc":
            multi = simulate_multifrequency(params, sweep, jax.random.key(seed), iterations, freqs, keep_frames=keep,
                                            progress=progress, fusion=fusion)
        else:
            multi = predict_multifrequency(params, sweep, freqs, fusion=fusion)
        multi = jax.device_get(multi)
        result = jax.tree_util.tree_map(lambda x: x[0], multi.per_frequency)
    elif method == "mc":
        result = simulate(params, sweep, jax.random.key(seed), iterations, fixed_pattern=fixed_pattern,
                          keep_frames=keep, progress=progress)
    else:
        result = predict(params, sweep)
    result = jax.device_get(result)
    return Run(config, sweep, method, iterations, seed, result, multi, time.perf_counter() - t0)
