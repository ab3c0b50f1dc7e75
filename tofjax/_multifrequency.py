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

from . import _depth
from ._model import simulate
from ._params import Params
from ._result import Result
from ._sweep import Sweep


def extended_range_m(frequencies_hz, speed_of_light_m_per_s: float = 299_792_458.0) -> float:
    """c / (2 gcd(f_i)) with the frequencies rounded to whole hertz (Eq 2.7 for two frequencies)."""
    ints = [int(round(float(f))) for f in np.atleast_1d(frequencies_hz)]
    if any(f <= 0 for f in ints):
        raise ValueError(f"modulation frequencies = {ints} must be > 0 Hz")
    return speed_of_light_m_per_s / (2.0 * reduce(math.gcd, ints))


class MultiFrequencyResult(eqx.Module):
    """A multi-frequency Monte Carlo sweep.

    - ``per_frequency``: one :class:`tofjax.Result` whose leaves have a leading frequency axis.
    - ``depth_m``: unwrapped distance per frame (samples, frames), in [0, extended range).
    - ``wrong_unwrap``: frames whose unwrapping picked the wrong candidate.
    - ``depth_mean_m``, ``depth_std_m``: circular statistics (period: the extended range) over the
      valid, correctly unwrapped frames; ``wrong_unwrap_fraction`` over the valid frames.
    """

    frequencies_hz: Float[Array, " frequencies"]
    extended_range_m: Float[Array, ""]
    distance_m: Float[Array, " samples"]
    per_frequency: Result
    depth_m: Float[Array, "samples frames"]
    valid: Bool[Array, "samples frames"]
    wrong_unwrap: Bool[Array, "samples frames"]
    depth_mean_m: Float[Array, " samples"]
    depth_std_m: Float[Array, " samples"]
    wrong_unwrap_fraction: Float[Array, " samples"]
    valid_fraction: Float[Array, " samples"]


def unwrap_frequencies(phases: Float[Array, "frequencies *b"], ranges_m: Float[Array, " frequencies"],
                       extended_m: float) -> Float[Array, "*b"]:
    """Distance from wrapped phases of several frequencies by their agreement (module docstring)."""
    expand = (slice(None),) + (None,) * (phases.ndim - 1)
    frac = phases / (2.0 * jnp.pi)
    first = (frac[0][None] + jnp.arange(int(math.ceil(extended_m / float(ranges_m[0]) - 1e-9)))[expand]) * ranges_m[0]
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


def simulate_multifrequency(params: Params, sweep: Sweep, key: PRNGKeyArray, iterations: int,
                            frequencies_hz) -> MultiFrequencyResult:
    """Monte Carlo at every frequency (one vmapped call) and the combined, unwrapped distance.

    **Arguments:** as :func:`tofjax.simulate`, plus ``frequencies_hz``: two or more modulation
    frequencies (concrete values; ``params``' own frequency is replaced by each in turn).
    """
    freqs = np.asarray(frequencies_hz, dtype=float).reshape(-1)
    if freqs.size < 2 or not np.all(freqs > 0) or len(set(freqs.tolist())) != freqs.size:
        raise ValueError(f"frequencies_hz = {freqs.tolist()} must be two or more distinct frequencies > 0 Hz")
    c = float(params.constants.speed_of_light_m_per_s)
    extended = extended_range_m(freqs, c)

    def one(f, k):
        p = eqx.tree_at(lambda q: q.illumination_waveform.modulation_frequency_hz, params, f)
        return simulate(p, sweep, k, iterations)

    per = jax.vmap(one)(jnp.asarray(freqs), jr.split(key, freqs.size))
    ranges = c / (2.0 * jnp.asarray(freqs))
    valid = jnp.all(per.valid, axis=0)
    depth = unwrap_frequencies(jnp.where(valid[None], per.phase_rad, 0.0), ranges, extended)
    truth = jnp.mod(per.distance_m[0], extended)[:, None]
    error = depth - truth
    error = error - extended * jnp.round(error / extended)
    wrong = valid & (jnp.abs(error) > 0.5 * float(jnp.min(ranges)))
    good = valid & ~wrong
    angle = 2.0 * jnp.pi * depth / extended
    mean_angle, std_angle, _ = _depth.circular_stats(angle, good)
    n_valid = jnp.sum(valid, axis=1)
    return MultiFrequencyResult(
        frequencies_hz=jnp.asarray(freqs), extended_range_m=jnp.asarray(extended), distance_m=per.distance_m[0],
        per_frequency=per, depth_m=depth, valid=valid, wrong_unwrap=wrong,
        depth_mean_m=mean_angle * extended / (2.0 * jnp.pi), depth_std_m=std_angle * extended / (2.0 * jnp.pi),
        wrong_unwrap_fraction=jnp.where(n_valid > 0, jnp.sum(wrong, axis=1) / jnp.maximum(n_valid, 1), jnp.nan),
        valid_fraction=jnp.mean(valid, axis=1),
    )
