"""Range extension with two or more modulation frequencies (thesis §2.2, Eq 2.7, Fig 2.3, Fig 5.9).

Each frequency f_i is a complete N-phase measurement (same exposure) with its own wrapped phase
phi_i and unambiguity range d_i = c / (2 f_i). The extended range is c / (2 g), g the greatest
common divisor of the frequencies (in Hz): for two frequencies that are multiples of |f1 - f2| it is
Eq 2.7, 7.465 m for 80.32 and 60.24 MHz. The distance is the candidate where the frequencies
agree: for each wrap count n of the first frequency, d = (phi_1 / 2 pi + n) d_1, every other
frequency takes its nearest consistent wrap, and the candidate with the smallest disagreement
(in units of each d_i) wins; the result is the 1/d_i^2-weighted mean of the agreeing distances.

Under noise the wrong candidate can win: a *wrong unwrap*, an error of a sizeable fraction of the
extended range (the effect behind Fig 5.9). A simulated frame counts as wrongly unwrapped when its
distance is further than half the smallest unambiguity range from the true distance (modulo the
extended range); statistics of the depth use the correctly unwrapped valid frames, and the wrong
fraction is reported beside them.

The frames of every frequency are drawn together, chunk by chunk, by the Monte Carlo engine
(:mod:`tofjax._frames`), so memory stays bounded; each frequency has its own random stream.
"""

from __future__ import annotations

import math
from functools import reduce

import equinox as eqx
import jax
import jax.numpy as jnp
import jax.random as jr
import numpy as np
from jaxtyping import Array, Bool, Float, PRNGKeyArray

from ._chain import build_chain
from ._frames import draw_frames, reduce_frames, run_blocks, wrap
from ._montecarlo import assemble, check_counts, prepare
from ._params import Params
from ._random import key_words
from ._result import Result
from ._sweep import Sweep, check_inputs


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
      valid, correctly unwrapped frames; ``wrong_unwrap_fraction`` over the valid frames.
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


def unwrap_frequencies(phases: Float[Array, "frequencies *b"], ranges_m: Float[Array, " frequencies"],
                       extended_m: float) -> Float[Array, "*b"]:
    """Distance from wrapped phases of several frequencies by their agreement (module docstring)."""
    expand = (slice(None),) + (None,) * (phases.ndim - 1)
    frac = phases / (2.0 * jnp.pi)
    first = (frac[0][None] + jnp.arange(int(math.ceil(extended_m / float(ranges_m[0]) - 1e-9)), dtype=float)[expand]) * ranges_m[0]
    total_w = 1.0 / ranges_m[0] ** 2
    weighted = first * total_w
    cost = jnp.zeros_like(first)
    for i in range(1, phases.shape[0]):
        n = jnp.round(first / ranges_m[i] - frac[i][None])
        d_i = (frac[i][None] + n) * ranges_m[i]
        cost = cost + ((d_i - first) / ranges_m[i]) ** 2
        weighted = weighted + d_i / ranges_m[i] ** 2
        total_w = total_w + 1.0 / ranges_m[i] ** 2
    best = jnp.argmin(cost, axis=0)
    combined = jnp.take_along_axis(weighted / total_w, best[None], axis=0)[0]
    return jnp.mod(combined, extended_m)


class _Combined(eqx.Module):
    good: Array
    wrong: Array
    valid: Array
    dev: Array
    dev2: Array


def simulate_multifrequency(params: Params, sweep: Sweep, key: PRNGKeyArray, iterations: int,
                            frequencies_hz, *, keep_frames: int = 0, progress: bool = False) -> MultiFrequencyResult:
    """Monte Carlo at every frequency (frames drawn together, chunk by chunk) and the combined,
    unwrapped distance.

    **Arguments:** as :func:`tofjax.simulate`, plus ``frequencies_hz``: two or more modulation
    frequencies (concrete values; ``params``' own frequency is replaced by each in turn), and
    ``keep_frames``: unwrapped frames to return per point (the plots use them); ``progress``: as
    :func:`tofjax.simulate`.
    """
    check_inputs(params, sweep)
    freqs = np.asarray(frequencies_hz, dtype=float).reshape(-1)
    if freqs.size < 2 or not np.all(freqs > 0) or len(set(freqs.tolist())) != freqs.size:
        raise ValueError(f"frequencies_hz = {freqs.tolist()} must be two or more distinct frequencies > 0 Hz")
    # Frames are kept per frequency and once more unwrapped.
    check_counts(iterations, keep_frames, sweep.samples * (freqs.size + 1), params.pixel.n_phases)
    c = float(params.constants.speed_of_light_m_per_s)
    ranges = tuple(float(x) for x in c / (2.0 * freqs))
    return _simulate(params, sweep, key, iterations, jnp.asarray(freqs), keep_frames, float(extended_range_m(freqs, c)),
                     ranges, progress)


@eqx.filter_jit
def _simulate(params, sweep, key, iterations, freqs, keep, extended, ranges, progress=False) -> MultiFrequencyResult:
    ranges = np.asarray(ranges)  # concrete: the number of unwrapping candidates depends on them
    n_freq = len(ranges)

    def chain_at(f):
        return build_chain(eqx.tree_at(lambda q: q.illumination_waveform.modulation_frequency_hz, params, f),
                           points=sweep.samples)

    chains = jax.vmap(chain_at)(freqs)
    prepared = jax.vmap(lambda ch: prepare(ch, sweep))(chains)
    words = key_words(jr.split(key)[1])
    d = sweep.operating_points(params.scene)[0]
    truth = jnp.mod(d.reshape(-1), extended)
    # Centre of the combined statistics: the noise-free frames' unwrapped distance.
    reference = unwrap_frequencies(jnp.mod(prepared.consts.ref_phase, 2.0 * jnp.pi), ranges, extended)
    streams = jnp.arange(n_freq, dtype=jnp.uint32)
    min_range = float(np.min(ranges))

    def step(cb, first, n, counted, record):
        consts, ref, true = cb
        linear = jnp.all(consts.linear, axis=0)  # a point's path, the same at every frequency (outside the vmap)
        frames = jax.vmap(lambda ch, c, st: draw_frames(ch, c, words, first, n, st, linear))(chains, consts, streams)
        per, valid_f = jax.vmap(lambda c, f: reduce_frames(c, f, counted[None, :]))(consts, frames)
        valid = jnp.all(valid_f, axis=0)
        depth = unwrap_frequencies(jnp.where(valid[None], jnp.mod(frames.phase, 2.0 * jnp.pi), 0.0), ranges, extended)
        error = depth - true[:, None]
        error = error - extended * jnp.round(error / extended)
        use = valid & counted[None, :]
        wrong = use & (jnp.abs(error) > 0.5 * min_range)
        good = use & ~wrong
        dev = jnp.where(good, wrap(2.0 * jnp.pi * (depth - ref[:, None]) / extended), 0.0)
        count = lambda x: jnp.sum(x, axis=-1).astype(float)  # noqa: E731
        combined = _Combined(count(good), count(wrong), count(use), jnp.sum(dev, -1), jnp.sum(dev * dev, -1))
        out = None
        if record:
            kept_f = (jnp.moveaxis(frames.codes, 1, -1), jnp.mod(frames.phase, 2.0 * jnp.pi), frames.amplitude, valid_f)
            kept_f = jax.tree_util.tree_map(lambda x: jnp.moveaxis(x, 0, 1), kept_f)  # points first
            out = (kept_f, depth, valid, wrong)
        return (per, combined), out

    (per_sums, combined), kept = run_blocks(step, (prepared.consts, reference, truth), sweep.samples, iterations,
                                            keep, chains.n_phases, progress=progress)
    kept_f = None if kept is None else jax.tree_util.tree_map(lambda x: jnp.moveaxis(x, 1, 0), kept[0])
    per = jax.vmap(lambda ch, p, s, k: assemble(ch, sweep, p, s, k, iterations))(chains, prepared, per_sums, kept_f)
    shape = d.shape
    points = lambda x: x.reshape(shape + x.shape[1:])  # noqa: E731
    n = combined.good
    enough = n >= 2
    n_safe = jnp.where(enough, n, 2.0)
    mean_dev = combined.dev / n_safe
    var = jnp.maximum(combined.dev2 - n_safe * mean_dev**2, 0.0) / (n_safe - 1.0)
    to_m = extended / (2.0 * jnp.pi)
    mean = jnp.mod(reference + to_m * mean_dev, extended)
    frames = (None, None, None) if kept is None else tuple(points(x) for x in kept[1:])
    return MultiFrequencyResult(
        frequencies_hz=freqs, extended_range_m=jnp.asarray(extended), distance_m=d, per_frequency=per,
        depth_m=frames[0], valid=frames[1], wrong_unwrap=frames[2],
        depth_mean_m=points(jnp.where(enough, mean, jnp.nan)),
        depth_std_m=points(jnp.where(enough, to_m * jnp.sqrt(var), jnp.nan)),
        wrong_unwrap_fraction=points(jnp.where(combined.valid > 0, combined.wrong / jnp.maximum(combined.valid, 1.0),
                                               jnp.nan)),
        valid_fraction=points(combined.valid / float(iterations)),
    )
