"""Range extension with two or more modulation frequencies (thesis §2.2, Eq 2.7, Fig 2.3, Fig 5.9).

Each frequency f_i is a complete N-phase measurement (same exposure) with its own wrapped phase
phi_i and unambiguity range d_i = c / (2 f_i). The extended range is c / (2 g), g the greatest
common divisor of the frequencies (in Hz): for two frequencies that are multiples of |f1 - f2| it is
Eq 2.7, 7.465 m for 80.32 and 60.24 MHz. The distance is the candidate where the frequencies
agree: for each wrap count n of the first frequency, d = (phi_1 / 2 pi + n) d_1, every other
frequency takes its nearest consistent wrap, and the candidate with the smallest disagreement
(in units of each d_i) wins; the result is the weighted mean of the agreeing distances, with the
weights of the camera's *fusion* (``illumination_waveform.frequency_fusion``, docs/model.md,
"Frequency fusion"):

- ``inverse_variance`` (default): w_i = 1 / sigma_i^2, sigma_i the depth noise of frequency i alone
  (from the analytic path at the operating point): the minimum-variance combination;
- ``unambiguity_range``: w_i = 1 / d_i^2, what inverse variance becomes when every frequency has the
  same phase noise;
- ``equal``: w_i = 1;
- ``highest_frequency``: only the highest frequency's distance; the others only choose its wrap;
- ``phase_average``: w_i = 1/d_i (proportional to f_i): the mean of the frequencies' unwrapped phases
  (each a distance over its own d_i), as libfreenect2's depth engine of the Kinect v2 fuses them.

The fused distance's noise, for the correct unwrap, is sigma^2 = sum w_i^2 sigma_i^2 / (sum w_i)^2
(:func:`fused_std`); :func:`tofjax.predict` of a multi-frequency camera gives it analytically.

Under noise the wrong candidate can win: a *wrong unwrap*, an error of a sizeable fraction of the
extended range (the effect behind Fig 5.9). A simulated frame counts as wrongly unwrapped when its
distance is further than half the smallest unambiguity range from the true distance (modulo the
extended range); statistics of the depth use the correctly unwrapped valid frames, and the wrong
fraction is reported beside them. The analytic path gives its rate in closed form
(:func:`wrong_unwrap_probability`): with phase noises eps_i (in periods), the correct candidate's
disagreements are v_i = eps_1 d_1 / d_i - eps_i, the candidate k wraps of the first frequency away has
v_i + delta_ki (delta_ki = k d_1 / d_i wrapped to (-1/2, 1/2]), and it wins where sum (v_i + delta_ki)^2 <
sum v_i^2, i.e. where the Gaussian v . delta_k < -|delta_k|^2 / 2: P_k = Phi(-|delta_k|^2 / (2 sd(v . delta_k))),
summed over the candidates (the union bound, tight where the rate is small; capped at 1).

The frames of every frequency are drawn together, chunk by chunk, by the Monte Carlo engine
(:mod:`tofjax._frames`), so memory stays bounded; each frequency has its own random stream.
"""

from __future__ import annotations

import dataclasses
import math
from functools import reduce

import equinox as eqx
import jax
import jax.numpy as jnp
import jax.random as jr
import numpy as np
from jaxtyping import Array, Bool, Float, PRNGKeyArray

from . import _executor, _jit
from ._analytic import analytic, moments
from ._chain import Chain, build_chain
from ._executor import execute
from ._frames import draw_delivered, reduce_frames, sample_mean_std, wrap
from ._montecarlo import assemble, check_counts, drawn_phases, prepare
from ._constants import SPEED_OF_LIGHT_M_PER_S
from ._params import Params
from ._random import key_words
from ._result import Result
from ._schema import FUSIONS
from ._smooth import Smooth
from ._sweep import Sweep, check_inputs, unpad


def extended_range_m(frequencies_hz, speed_of_light_m_per_s: float = 299_792_458.0) -> float:
    """c / (2 gcd(f_i)) with the frequencies rounded to whole hertz (Eq 2.7 for two frequencies)."""
    ints = [int(round(float(f))) for f in np.atleast_1d(frequencies_hz)]
    if any(f <= 0 for f in ints):
        raise ValueError(f"modulation frequencies = {ints} must be > 0 Hz")
    return speed_of_light_m_per_s / (2.0 * reduce(math.gcd, ints))


class MultiFrequencyResult(eqx.Module):
    """A multi-frequency Monte Carlo sweep.

    - ``per_frequency``: one :class:`tofjax.Result` whose leaves have a leading frequency axis.
    - ``depth_m``: unwrapped distance per kept frame ``(*b, frames)``, in [0, extended range);
      ``valid``, ``wrong_unwrap``: per kept frame (``None`` without ``keep_frames``).
    - ``depth_mean_m``, ``depth_std_m``: circular statistics (period: the extended range) over the
      valid, correctly unwrapped frames; ``wrong_unwrap_fraction`` over the valid frames. From
      :func:`tofjax.predict`: the fused expected distance and its noise (analytic), and the
      wrong-unwrap rate in closed form (:func:`wrong_unwrap_probability`).
    - ``fusion``: the weighting of the frequencies' distances (module docstring).
    """

    frequencies_hz: Float[Array, " frequencies"]
    extended_range_m: Float[Array, ""]
    distance_m: Float[Array, "*b"]
    per_frequency: Result
    depth_m: Float[Array, "*b frames"] | None
    valid: Bool[Array, "*b frames"] | None
    wrong_unwrap: Bool[Array, "*b frames"] | None
    depth_mean_m: Float[Array, "*b"]
    depth_std_m: Float[Array, "*b"]
    wrong_unwrap_fraction: Float[Array, "*b"]
    valid_fraction: Float[Array, "*b"]
    fusion: str = eqx.field(static=True, default="inverse_variance")


def fusion_weights(depth_var_m2: Float[Array, "frequencies *b"], ranges_m, fusion: str) -> Float[Array, "frequencies *b"]:
    """The fusion's weights per frequency (module docstring), shape of ``depth_var_m2``: the
    variance of each frequency's distance alone (used by ``inverse_variance`` only)."""
    ranges = jnp.asarray(ranges_m, dtype=float).reshape((-1,) + (1,) * (jnp.ndim(depth_var_m2) - 1))
    shape = jnp.shape(depth_var_m2)
    if fusion == "inverse_variance":  # scaled by the smallest variance; noise-free frequencies share equally
        smallest = jnp.min(depth_var_m2, axis=0, keepdims=True)
        positive = depth_var_m2 > 0
        return jnp.where(positive, smallest / jnp.where(positive, depth_var_m2, 1.0), 1.0)
    if fusion == "unambiguity_range":
        return jnp.broadcast_to(1.0 / ranges**2, shape)
    if fusion == "equal":
        return jnp.ones(shape)
    if fusion == "phase_average":
        return jnp.broadcast_to(1.0 / ranges, shape)
    if fusion == "highest_frequency":
        return jnp.broadcast_to((ranges == jnp.min(ranges)).astype(float), shape)
    raise ValueError(f"frequency_fusion = {fusion!r} is not allowed: expected one of "
                     + ", ".join(f'"{f}"' for f in FUSIONS))


def fused_std(depth_std_m: Float[Array, "frequencies *b"], weights: Float[Array, "frequencies *b"]) -> Float[Array, "*b"]:
    """Noise of the weighted mean of independent distances: sqrt(sum w_i^2 sigma_i^2) / sum w_i."""
    return jnp.sqrt(jnp.sum(weights**2 * depth_std_m**2, axis=0)) / jnp.sum(weights, axis=0)


def wrong_unwrap_probability(std_cycles: Float[Array, "frequencies *b"], ranges_m, extended_m: float
                             ) -> Float[Array, "*b"]:
    """The probability that the unwrapping picks a wrong candidate (module docstring), from each
    frequency's phase noise in periods ``std_cycles`` (its depth noise over its unambiguity range);
    ``ranges_m``, ``extended_m``: concrete."""
    from ._processing import normal_cdf

    ranges = np.asarray(ranges_m, dtype=float)
    ratios = ranges[0] / ranges[1:]  # d_1 / d_i of the other frequencies
    var = std_cycles**2
    total = jnp.zeros(std_cycles.shape[1:], std_cycles.dtype)
    for k in range(1, int(math.ceil(extended_m / ranges[0] - 1e-9))):
        delta = k * ratios - np.round(k * ratios)  # the other frequencies' disagreement, periods
        gap = float(np.sum(delta * delta))
        if gap == 0.0:  # a candidate every frequency agrees on: the extended range is shorter
            continue
        # Var(v . delta): v_i = eps_1 d_1 / d_i - eps_i, the eps independent.
        spread = (float(np.dot(delta, ratios)) ** 2) * var[0] + sum(float(d * d) * var[i + 1]
                                                                    for i, d in enumerate(delta))
        safe = jnp.where(spread > 0, spread, 1.0)
        total = total + jnp.where(spread > 0, normal_cdf(-gap / (2.0 * jnp.sqrt(safe))), 0.0)
    return jnp.minimum(total, 1.0)


def unwrap_frequencies(phases: Float[Array, "frequencies *b"], ranges_m: Float[Array, " frequencies"],
                       extended_m: float, weights: Float[Array, "frequencies *b"] | None = None) -> Float[Array, "*b"]:
    """Distance from wrapped phases of several frequencies by their agreement (module docstring);
    ``weights`` of the agreeing distances, broadcastable to ``phases`` (default 1/d_i^2)."""
    expand = (slice(None),) + (None,) * (phases.ndim - 1)
    if weights is None:
        weights = jnp.asarray([1.0 / float(r) ** 2 for r in ranges_m]).reshape((-1,) + (1,) * (phases.ndim - 1))
    weights = jnp.broadcast_to(weights, phases.shape)
    frac = phases / (2.0 * jnp.pi)
    first = (frac[0][None] + jnp.arange(int(math.ceil(extended_m / float(ranges_m[0]) - 1e-9)), dtype=float)[expand]) * ranges_m[0]
    total_w = weights[0][None]
    weighted = first * total_w
    cost = jnp.zeros_like(first)
    for i in range(1, phases.shape[0]):
        n = jnp.round(first / ranges_m[i] - frac[i][None])
        d_i = (frac[i][None] + n) * ranges_m[i]
        cost = cost + ((d_i - first) / ranges_m[i]) ** 2
        weighted = weighted + d_i * weights[i][None]
        total_w = total_w + weights[i][None]
    best = jnp.argmin(cost, axis=0)
    combined = jnp.take_along_axis(weighted / total_w, best[None], axis=0)[0]
    return jnp.mod(combined, extended_m)


class _Combined(eqx.Module):
    good: Array
    wrong: Array
    valid: Array
    dev: Array
    dev2: Array


def _check_frequencies(frequencies_hz, fusion: str) -> np.ndarray:
    freqs = np.asarray(frequencies_hz, dtype=float).reshape(-1)
    if freqs.size < 2 or not np.all(freqs > 0) or len(set(freqs.tolist())) != freqs.size:
        raise ValueError(f"frequencies_hz = {freqs.tolist()} must be two or more distinct frequencies > 0 Hz")
    fusion_weights(jnp.ones(1), [1.0], fusion)  # the fusion's name
    return freqs


def _with_frequency(params: Params, f) -> Params:
    return eqx.tree_at(lambda q: q.illumination_waveform.modulation_frequency_hz, params, f)


def predict_multifrequency(params: Params, sweep: Sweep, frequencies_hz, *, fusion: str = "inverse_variance",
                           smooth: Smooth | None = None, processing: tuple = ()) -> MultiFrequencyResult:
    """Analytic prediction of a multi-frequency camera: :func:`tofjax.predict` at every frequency
    (same exposure per frequency) and the fused distance (module docstring).

    ``depth_mean_m`` is the fused distance of the expected phases (with wiggling), unwrapped over the
    extended range; ``depth_std_m`` the fused noise sqrt(sum w_i^2 sigma_i^2) / sum w_i for the correct
    unwrap; ``valid_fraction`` the probability that every frequency is delivered. ``frequencies_hz``:
    concrete values; ``fusion``: ``inverse_variance`` (default), ``unambiguity_range``, ``equal`` or
    ``highest_frequency``; ``smooth``: as :func:`tofjax.predict`; ``processing``: the camera's
    processing stages, run on each frequency's phase before the fusion (docs/model.md, "The camera's
    processing").
    """
    check_inputs(params, sweep)
    freqs = _check_frequencies(frequencies_hz, fusion)
    c = SPEED_OF_LIGHT_M_PER_S  # exact (SI); concrete even when params are traced (calibration)
    ranges = tuple(float(x) for x in c / (2.0 * freqs))
    return _predict(params, sweep, jnp.asarray(freqs), float(extended_range_m(freqs, c)), ranges, fusion, smooth,
                    processing)


@_jit.jit
def _predict(params, sweep, freqs, extended, ranges, fusion, smooth, processing=()) -> MultiFrequencyResult:
    ranges_np = np.asarray(ranges)
    per = jax.vmap(lambda f: analytic(build_chain(_with_frequency(params, f), smooth, sweep.samples,
                                                  processing=processing), sweep))(freqs)
    weights = fusion_weights(per.depth_std_m**2, ranges_np, fusion)
    phases = 2.0 * jnp.pi * per.depth_mean_m / jnp.asarray(ranges_np).reshape((-1,) + (1,) * sweep.values.ndim)
    ok = jnp.all(jnp.isfinite(phases), axis=0)
    mean = unwrap_frequencies(jnp.where(ok, phases, 0.0), ranges_np, extended, jnp.where(ok, weights, 1.0))
    valid = jnp.prod(per.valid_fraction, axis=0)
    d = sweep.operating_points(params)[0]
    return MultiFrequencyResult(
        frequencies_hz=freqs, extended_range_m=jnp.asarray(extended), distance_m=d, per_frequency=per,
        depth_m=None, valid=None, wrong_unwrap=None, depth_mean_m=jnp.where(ok, mean, jnp.nan),
        depth_std_m=fused_std(per.depth_std_m, weights),
        wrong_unwrap_fraction=wrong_unwrap_probability(per.depth_std_m / jnp.asarray(ranges_np).reshape(
            (-1,) + (1,) * sweep.values.ndim), ranges_np, extended),
        valid_fraction=valid, fusion=fusion)


def simulate_multifrequency(params: Params, sweep: Sweep, key: PRNGKeyArray, iterations: int,
                            frequencies_hz, *, keep_frames: int = 0, progress: bool = False,
                            fusion: str = "inverse_variance", raw: bool = False, processing: tuple = ()
                            ) -> MultiFrequencyResult:
    """Monte Carlo at every frequency (frames drawn together, chunk by chunk) and the combined,
    unwrapped distance.

    **Arguments:** as :func:`tofjax.simulate`, plus ``frequencies_hz``: two or more modulation
    frequencies (concrete values; ``params``' own frequency is replaced by each in turn), and
    ``keep_frames``: unwrapped frames to return per point (the plots use them); ``progress``: as
    :func:`tofjax.simulate`; ``raw`` (static): every frequency's kept frames carry their raw phase
    images' taps too (``per_frequency.frames_tap_a_e`` / ``frames_tap_b_e`` beside
    ``per_frequency.codes``, a leading frequency axis); ``processing``: as :func:`predict_multifrequency`.
    """
    check_inputs(params, sweep)
    freqs = np.asarray(frequencies_hz, dtype=float).reshape(-1)
    if freqs.size < 2 or not np.all(freqs > 0) or len(set(freqs.tolist())) != freqs.size:
        raise ValueError(f"frequencies_hz = {freqs.tolist()} must be two or more distinct frequencies > 0 Hz")
    # Frames are kept per frequency and once more unwrapped.
    check_counts(iterations, keep_frames, sweep.samples * (freqs.size + 1), params.pixel.n_phases, raw=raw)
    c = float(params.constants.speed_of_light_m_per_s)
    ranges = tuple(float(x) for x in c / (2.0 * freqs))
    freqs, extended = jnp.asarray(freqs), float(extended_range_m(freqs, c))
    phases = drawn_phases(params.pixel.n_phases, processing)
    padded = _executor.padded(sweep, (params, sweep, key, processing), iterations * phases * len(ranges))
    return _unpadded(execute(_run_setup, _run_consts, _run_finish,
                             (params, padded, key, freqs, extended, ranges, fusion, iterations, raw, processing),
                             points=padded.samples, frames=iterations, keep=keep_frames, phases=phases,
                             progress=progress), sweep, padded)


def _unpadded(result: MultiFrequencyResult, sweep: Sweep, padded: Sweep) -> MultiFrequencyResult:
    """``result`` of the ``padded`` sweep (:func:`tofjax._executor.padded`) with the padding cut: the
    per-frequency leaves' points axis follows the frequencies' axis; the frequencies themselves and
    the extended range are per call."""
    if padded is sweep:
        return result
    per = unpad(result.per_frequency, sweep, padded, axis=1)
    points = unpad(dataclasses.replace(result, per_frequency=None, frequencies_hz=None, extended_range_m=None),
                   sweep, padded)
    return dataclasses.replace(points, per_frequency=per, frequencies_hz=result.frequencies_hz,
                               extended_range_m=result.extended_range_m)


class _Step(eqx.Module):
    """The chunk step of all frequencies' chains at once (:func:`tofjax._executor.run_blocks`): the
    frames of every frequency, their statistics, and those of the combined, unwrapped distance. A
    pytree, so that the chunk programs of :func:`tofjax._executor.drive_blocks` take it as an argument."""

    chains: Chain  # one per frequency (a leading axis)
    words: tuple[Array, Array]
    streams: Array
    ranges: tuple[float, ...] = eqx.field(static=True)
    extended: float = eqx.field(static=True)
    raw: bool = eqx.field(static=True, default=False)
    image: tuple[int, int] | None = eqx.field(static=True, default=None)  # a frame's pixels (whole frames)

    def __call__(self, cb, first, n, counted, record):
        ranges, extended, words = np.asarray(self.ranges), self.extended, self.words
        consts, ref, true, w = cb
        linear = jnp.all(consts.linear, axis=0)  # a point's path, the same at every frequency (outside the vmap)
        taps = record and self.raw
        # A frame's pixels are drawn frames first, as the single frequency's chunks are: its processing's
        # neighbourhoods then read the draw's own layout (points first, a 3 x 3 median of two frequencies'
        # frames ran 15 times slower), and the batch is turned points first for the fusion below.
        ff = self.image is not None and not record
        frames = jax.vmap(lambda ch, c, st: draw_delivered(ch, c, words, first, n, st, linear, frames_first=ff,
                                                           taps=taps, image=self.image))(self.chains, consts, self.streams)
        if ff:
            frames = eqx.tree_at(lambda f: (f.codes, f.phase, f.amplitude, f.pixel_saturated, f.adc_saturated,
                                            f.sbi_engaged, f.valid), frames,
                                 (jnp.swapaxes(frames.codes, -1, -2),
                                  *(jnp.swapaxes(x, -1, -2) for x in (frames.phase, frames.amplitude,
                                                                      frames.pixel_saturated, frames.adc_saturated,
                                                                      frames.sbi_engaged, frames.valid))))
        per, valid_f = jax.vmap(lambda c, f: reduce_frames(c, f, counted[None, :]))(consts, frames)
        valid = jnp.all(valid_f, axis=0)
        depth = unwrap_frequencies(jnp.where(valid[None], jnp.mod(frames.phase, 2.0 * jnp.pi), 0.0), ranges, extended,
                                   w[..., None])
        error = depth - true[:, None]
        error = error - extended * jnp.round(error / extended)
        use = valid & counted[None, :]
        wrong = use & (jnp.abs(error) > 0.5 * float(np.min(ranges)))
        good = use & ~wrong
        dev = jnp.where(good, wrap(2.0 * jnp.pi * (depth - ref[:, None]) / extended), 0.0)
        count = lambda x: jnp.sum(x, axis=-1).astype(float)  # noqa: E731
        combined = _Combined(count(good), count(wrong), count(use), jnp.sum(dev, -1), jnp.sum(dev * dev, -1))
        out = None
        if record:
            kept_f = (jnp.moveaxis(frames.codes, 1, -1), jnp.mod(frames.phase, 2.0 * jnp.pi), frames.amplitude, valid_f,
                      *((jnp.moveaxis(frames.tap_a_e, 1, -1), jnp.moveaxis(frames.tap_b_e, 1, -1)) if taps else ()))
            kept_f = jax.tree_util.tree_map(lambda x: jnp.moveaxis(x, 0, 1), kept_f)  # points first
            out = (kept_f, depth, valid, wrong)
        return (per, combined), out


def _setup(params, sweep, key, freqs, extended, ranges, fusion, raw=False, processing=()):
    """Every frequency's chain and frames' constants, the chunk step, and the blocks' inputs (the
    constants, the noise-free unwrapped distance, the true distance, the fusion weights)."""
    ranges = np.asarray(ranges)  # concrete: the number of unwrapping candidates depends on them
    n_freq = len(ranges)

    def chain_at(f):
        return build_chain(_with_frequency(params, f), points=sweep.samples, processing=processing)

    chains = jax.vmap(chain_at)(freqs)
    prepared = jax.vmap(lambda ch: prepare(ch, sweep))(chains)
    if fusion == "inverse_variance":  # each frequency's depth variance alone, from the analytic path
        var_phase = jax.vmap(lambda ch: moments(ch, sweep).var_phase)(chains).reshape(n_freq, -1)
        weights = fusion_weights(var_phase * (ranges[:, None] / (2.0 * jnp.pi)) ** 2, ranges, fusion)
    else:
        weights = fusion_weights(jnp.ones((n_freq, sweep.samples)), ranges, fusion)
    words = key_words(jr.split(key)[1])
    d = sweep.operating_points(params)[0]
    truth = jnp.mod(d.reshape(-1), extended)
    # Centre of the combined statistics: the noise-free frames' unwrapped distance.
    reference = unwrap_frequencies(jnp.mod(prepared.consts.ref_phase, 2.0 * jnp.pi), ranges, extended, weights)
    step = _Step(chains, words, jnp.arange(n_freq, dtype=jnp.uint32), tuple(float(r) for r in ranges), extended, raw)
    return chains, prepared, step, (prepared.consts, reference, truth, weights)


def _finish(params, sweep, iterations, freqs, extended, fusion, chains, prepared, reference, sums,
            kept) -> MultiFrequencyResult:
    """The result from the blocks' sums and kept frames."""
    per_sums, combined = sums
    kept_f = None if kept is None else jax.tree_util.tree_map(lambda x: jnp.moveaxis(x, 1, 0), kept[0])
    per = jax.vmap(lambda ch, p, s, k: assemble(ch, sweep, p, s, k, iterations))(chains, prepared, per_sums, kept_f)
    d = sweep.operating_points(params)[0]
    shape = d.shape
    points = lambda x: x.reshape(shape + x.shape[1:])  # noqa: E731
    mean_dev, sd_dev, enough = sample_mean_std(combined.good, combined.dev, combined.dev2)
    to_m = extended / (2.0 * jnp.pi)
    mean = jnp.mod(reference + to_m * mean_dev, extended)
    frames = (None, None, None) if kept is None else tuple(points(x) for x in kept[1:])
    return MultiFrequencyResult(
        frequencies_hz=freqs, extended_range_m=jnp.asarray(extended), distance_m=d, per_frequency=per,
        depth_m=frames[0], valid=frames[1], wrong_unwrap=frames[2],
        depth_mean_m=points(jnp.where(enough, mean, jnp.nan)),
        depth_std_m=points(jnp.where(enough, to_m * sd_dev, jnp.nan)),
        wrong_unwrap_fraction=points(jnp.where(combined.valid > 0, combined.wrong / jnp.maximum(combined.valid, 1.0),
                                               jnp.nan)),
        valid_fraction=points(combined.valid / float(iterations)), fusion=fusion,
    )


@_jit.jit
def _run_setup(params, sweep, key, freqs, extended, ranges, fusion, iterations, raw, processing):
    """:func:`simulate_multifrequency`'s run (:func:`tofjax._executor.execute`)."""
    chains, prepared, step, consts = _setup(params, sweep, key, freqs, extended, ranges, fusion, raw, processing)
    return (chains, prepared, consts), step


def _run_consts(params, sweep, key, freqs, extended, ranges, fusion, iterations, raw, processing, carry):
    return carry[2]


@_jit.jit
def _run_finish(params, sweep, key, freqs, extended, ranges, fusion, iterations, raw, processing, carry, sums, kept
                ) -> MultiFrequencyResult:
    chains, prepared, consts = carry
    return _finish(params, sweep, iterations, freqs, extended, fusion, chains, prepared, consts[1], sums, kept)
