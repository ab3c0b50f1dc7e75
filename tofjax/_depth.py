"""Phase, amplitude, depth and their statistics (thesis §2.1.1.1, §3.3.3, §4.2.16, §5.4).

For N phase images D_j (differential codes, LSB) taken at reference steps theta_j,
Z = sum_j D_j exp(i theta_j): the phase is arg Z (Eq 2.2 generalised to N phases), the amplitude
|Z| 2 / N (Eq 2.4; |Z| for 2 phases, whose complements are implicit), the distance
d = d_u phase / 2 pi in [0, d_u) (Eqs 2.5-2.6).

Statistics over repeated frames use circular statistics: deviations are taken around the
circular mean and wrapped to (-pi, pi], so a noisy sample near the wrap (Fig 5.7a) does not
produce a d_u-sized outlier. Non-smooth functions get the double-``where`` guard so that no NaN
gradient leaks from a branch not taken.
"""

from __future__ import annotations

import jax.numpy as jnp
from jax import lax
from jaxtyping import Array, Bool, Complex, Float

from ._waveforms import phase_steps


def demodulate(values: Float[Array, "*b phases"]) -> Complex[Array, "*b"]:
    """Z = sum_j D_j exp(i theta_j) over the last (phase) axis."""
    theta = jnp.asarray(phase_steps(values.shape[-1])).reshape((1,) * (values.ndim - 1) + (-1,))
    return jnp.sum(values * jnp.exp(1j * theta), axis=-1)


def safe_sqrt(x: Array) -> Array:
    """sqrt(x) for x > 0, else 0, with a finite (zero) gradient at and below 0."""
    ok = x > 0.0
    return jnp.where(ok, jnp.sqrt(jnp.where(ok, x, 1.0)), 0.0)


def _safe_abs(z: Array) -> Array:
    ok = jnp.abs(z) > 0.0
    return jnp.where(ok, jnp.abs(jnp.where(ok, z, 1.0)), 0.0)


def phase_rad(z: Complex[Array, "*b"]) -> Float[Array, "*b"]:
    """arg Z in [0, 2 pi) (0 where Z = 0, with a zero gradient)."""
    ok = jnp.abs(z) > 0.0
    angle = jnp.angle(jnp.where(ok, z, 1.0))
    return jnp.where(ok, jnp.mod(angle, 2.0 * jnp.pi), 0.0)


def amplitude(z: Complex[Array, "*b"], n_phases: int) -> Float[Array, "*b"]:
    """Amplitude of the fundamental: |Z| 2 / N for 3-5 phases, |Z| for 2 (Eq 2.4)."""
    scale = 1.0 if n_phases == 2 else 2.0 / n_phases
    return scale * _safe_abs(z)


def wrap_angle(x: Array) -> Array:
    """Wrap to (-pi, pi]."""
    return jnp.pi - jnp.mod(jnp.pi - x, 2.0 * jnp.pi)


def circular_stats(
    phase: Float[Array, "*b frames"], valid: Bool[Array, "*b frames"]
) -> tuple[Float[Array, "*b"], Float[Array, "*b"], Float[Array, "*b"]]:
    """(mean phase in [0, 2 pi), phase standard deviation, number of valid frames) per row.

    The mean starts from the circular mean and adds the arithmetic mean of the wrapped
    deviations; the standard deviation is the sample standard deviation (ddof = 1) of those
    deviations. Rows with fewer than two valid frames give NaN (flagged by the frame count).
    """
    n = jnp.sum(valid, axis=-1)
    w = valid.astype(float)
    resultant = jnp.sum(w * jnp.exp(1j * phase), axis=-1)
    centre = phase_rad(resultant)
    dev = jnp.where(valid, wrap_angle(phase - centre[..., None]), 0.0)
    enough = n >= 2
    n_safe = jnp.where(enough, n, 2)
    mean_dev = jnp.sum(dev, axis=-1) / n_safe
    var = jnp.sum(jnp.where(valid, (dev - mean_dev[..., None]) ** 2, 0.0), axis=-1) / (n_safe - 1)
    std = safe_sqrt(var)
    mean = jnp.mod(centre + mean_dev, 2.0 * jnp.pi)
    return jnp.where(enough, mean, jnp.nan), jnp.where(enough, std, jnp.nan), n


def masked_mean_std(
    x: Float[Array, "*b frames"], valid: Bool[Array, "*b frames"]
) -> tuple[Float[Array, "*b"], Float[Array, "*b"]]:
    """Mean and sample standard deviation (ddof = 1) over the valid frames (NaN below two)."""
    n = jnp.sum(valid, axis=-1)
    enough = n >= 2
    n_safe = jnp.where(enough, n, 2)
    mean = jnp.sum(jnp.where(valid, x, 0.0), axis=-1) / n_safe
    var = jnp.sum(jnp.where(valid, (x - mean[..., None]) ** 2, 0.0), axis=-1) / (n_safe - 1)
    std = safe_sqrt(var)
    return jnp.where(enough, mean, jnp.nan), jnp.where(enough, std, jnp.nan)


def _fill_invalid(x: Float[Array, "samples *rest"], valid: Bool[Array, "samples *rest"]) -> Array:
    """Replace invalid entries along axis 0 by the last valid one before them (the first valid
    one for a leading invalid run), so unwrapping can step over them."""
    idx = jnp.arange(x.shape[0]).reshape((-1,) + (1,) * (x.ndim - 1))
    idx = jnp.broadcast_to(idx, x.shape)
    last = lax.cummax(jnp.where(valid, idx, -1), axis=0)
    first = jnp.min(jnp.where(valid, idx, x.shape[0] - 1), axis=0, keepdims=True)
    source = jnp.where(last >= 0, last, first)
    return jnp.take_along_axis(x, source, axis=0)


def unwrap_along_sweep(phase: Float[Array, "samples *rest"], valid: Bool[Array, "samples *rest"]) -> Array:
    """Unwrap phases along the sweep axis (§5.4: a jump larger than pi gets the 2 pi complement).

    Invalid entries are stepped over and come back as NaN. The first valid sample is taken to lie
    in the first unambiguity interval.
    """
    filled = _fill_invalid(jnp.where(valid, phase, 0.0), valid)
    return jnp.where(valid, jnp.unwrap(filled, axis=0), jnp.nan)
