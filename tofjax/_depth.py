"""Demodulation: phase, amplitude, depth and their statistics (thesis §2.1.1.1, §3.3.3, §4.2.16, §5.4).

For N phase images D_j (differential codes, LSB) taken at reference steps theta_j,
Z = sum_j D_j exp(i theta_j): the phase is arg Z (Eq 2.2 generalised to N phases), the amplitude
|Z| 2 / N (Eq 2.4; |Z| for 2 phases, whose complements are implicit), the distance
d = d_u phase / 2 pi in [0, d_u) (Eqs 2.5-2.6).

Two evaluations of the same estimators:
- per frame (Monte Carlo): Z in real arithmetic with the constant weights cos/sin theta_j, and a
  rational-polynomial arctan2 (:func:`atan2`, exact to float64 rounding; XLA's own costs ~20 ns on a
  CPU, four times the whole rest of a frame);
- in closed form (analytic path, :func:`delta_method`): the delta method through Z, with the
  second-order terms of a phasor in Gaussian noise (:mod:`tofjax._rician`).

Statistics over repeated frames use circular statistics: deviations are taken around a centre and
wrapped to (-pi, pi], so a noisy sample near the wrap (Fig 5.7a) does not produce a d_u-sized
outlier. Non-smooth functions get the double-``where`` guard so that no NaN gradient leaks from a
branch not taken.
"""

from __future__ import annotations

import math

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jax import lax
from jaxtyping import Array, Bool, Complex, Float

from . import _rician
from ._stages import AbstractStage, Moments, Samples, replace
from ._waveforms import phase_steps

# Cephes' atan: P/Q rational approximation on [0, tan(pi/8)], with the pi/4 reduction above it.
_ATAN_P = (-8.750608600031904122785e-1, -1.615753718733365076637e1, -7.500855792314704667340e1,
           -1.228866684490136173410e2, -6.485021904942025371773e1)
_ATAN_Q = (2.485846490142306297962e1, 1.650270098316988542046e2, 4.328810604912902668951e2,
           4.853903996359136964868e2, 1.945506571482613964425e2)
_TAN_PI_8 = math.sqrt(2.0) - 1.0


def amplitude_scale(n_phases: int) -> float:
    """|Z| to amplitude: 2 / N for 3-5 phases, 1 for 2 (Eq 2.4)."""
    return 1.0 if n_phases == 2 else 2.0 / n_phases


def phase_weights(n_phases: int) -> tuple[np.ndarray, np.ndarray]:
    """(cos theta_j, sin theta_j), rounded so that the 90-degree steps are exact."""
    theta = phase_steps(n_phases)
    return np.round(np.cos(theta), 15) + 0.0, np.round(np.sin(theta), 15) + 0.0


@eqx.filter_jit
def demodulate(values: Float[Array, "*b phases"]) -> Complex[Array, "*b"]:
    """Z = sum_j D_j exp(i theta_j) over the last (phase) axis."""
    cos, sin = (w.reshape((1,) * (values.ndim - 1) + (-1,)) for w in phase_weights(values.shape[-1]))
    return lax.complex(jnp.sum(values * cos, axis=-1), jnp.sum(values * sin, axis=-1))


def phasor(values: Float[Array, "phases *b"]) -> tuple[Float[Array, "*b"], Float[Array, "*b"]]:
    """(Re Z, Im Z) of phase images stacked on the *leading* axis, in real arithmetic (per frame)."""
    cos, sin = phase_weights(values.shape[0])
    re = sum(float(c) * values[j] for j, c in enumerate(cos) if c != 0.0)
    im = sum(float(s) * values[j] for j, s in enumerate(sin) if s != 0.0)
    return re, im


@eqx.filter_jit
def atan2(y: Array, x: Array) -> Array:
    """arctan2(y, x) in (-pi, pi] (0 at the origin), elementwise, by Cephes' rational approximation."""
    ax, ay = jnp.abs(x), jnp.abs(y)
    swap = ay > ax
    num, den = jnp.where(swap, ax, ay), jnp.where(swap, ay, ax)
    # r = num / den in [0, 1], reduced by pi/4 above tan(pi/8) to (r - 1) / (r + 1) = (num - den) / (num +
    # den) (both halved near the top of the range, against overflow). Each quotient has one user (the
    # select), so XLA fuses the whole function into its consumer; a quotient with several users is
    # materialised, and its inputs recomputed in every fusion that reads it (docs/model.md,
    # "Performance", measurement 5).
    big = num > _TAN_PI_8 * den
    s = jnp.where(den > 2.0 ** (jnp.finfo(jnp.result_type(den)).maxexp - 24), 0.5, 1.0)  # 2^1000 in float64
    r = jnp.where(big, (s * num - s * den) / jnp.where(big, s * num + s * den, 1.0),
                  num / jnp.where(den == 0.0, 1.0, den))
    z = r * r
    p = _ATAN_P[0]
    for c in _ATAN_P[1:]:
        p = p * z + c
    q = z + _ATAN_Q[0]
    for c in _ATAN_Q[1:]:
        q = q * z + c
    a = r + r * z * p / q
    a = jnp.where(big, a + 0.25 * math.pi, a)
    a = jnp.where(swap, 0.5 * math.pi - a, a)
    a = jnp.where(x < 0.0, math.pi - a, a)
    return jnp.where(y < 0.0, -a, a)


def safe_sqrt(x: Array) -> Array:
    """sqrt(x) for x > 0, else 0, with a finite (zero) gradient at and below 0."""
    ok = x > 0.0
    return jnp.where(ok, jnp.sqrt(jnp.where(ok, x, 1.0)), 0.0)


def _safe_abs(z: Array) -> Array:
    ok = jnp.abs(z) > 0.0
    return jnp.where(ok, jnp.abs(jnp.where(ok, z, 1.0)), 0.0)


@eqx.filter_jit
def phase_rad(z: Complex[Array, "*b"]) -> Float[Array, "*b"]:
    """arg Z in [0, 2 pi) (0 where Z = 0, with a zero gradient)."""
    ok = jnp.abs(z) > 0.0
    angle = jnp.angle(jnp.where(ok, z, 1.0))
    return jnp.where(ok, jnp.mod(angle, 2.0 * jnp.pi), 0.0)


def amplitude(z: Complex[Array, "*b"], n_phases: int) -> Float[Array, "*b"]:
    """Amplitude of the fundamental: |Z| 2 / N for 3-5 phases, |Z| for 2 (Eq 2.4)."""
    return amplitude_scale(n_phases) * _safe_abs(z)


def wrap_angle(x: Array) -> Array:
    """Wrap to (-pi, pi]."""
    return jnp.pi - jnp.mod(jnp.pi - x, 2.0 * jnp.pi)


def _dot(weights: tuple[float, ...], columns: list[Array]) -> Array:
    """sum_j w_j x_j, skipping zero weights."""
    terms = [w * x for w, x in zip(weights, columns, strict=True) if w != 0.0]
    return sum(terms[1:], terms[0])


def delta_method(values: Float[Array, "*b phases"], variances: Float[Array, "*b phases"], n_phases: int):
    """Phase and amplitude statistics of N phase images with independent Gaussian noise, in closed form.

    With u_j = exp(i theta_j) conj(Z) / |Z|, the first-order variances of the phase and of |Z| are
    sum_j var_j Im(u_j)^2 / |Z|^2 and sum_j var_j Re(u_j)^2: the noise across (s_perp^2) and along
    (s_par^2) the phasor. The phase variance's higher orders and the amplitude's noise bias follow
    from a phasor in circular Gaussian noise of s_perp^2 per quadrature (:mod:`tofjax._rician`):
    E[theta^2] = G(v), v = s_perp^2 / |Z|^2 (v (1 + v) to second order, bounded by pi^2 / 3), and
    E|Z| the Rician mean (|Z| + s_perp^2 / 2|Z| to second order); Var|Z| = |Z|^2 + s_par^2 + s_perp^2
    - E|Z|^2 (exact second moment).

    **Returns:** (phase in [0, 2 pi), phase variance, first-order phase variance v, amplitude mean,
    amplitude variance), the amplitudes scaled by :func:`amplitude_scale`.
    """
    # Per-phase columns with the weights as Python numbers: every step below is elementwise over
    # the points and fuses into one loop (a reduction over a trailing axis of 3-5 is slow on CPU).
    cos, sin = (tuple(float(x) for x in w) for w in phase_weights(n_phases))
    d = [values[..., j] for j in range(n_phases)]
    var = [variances[..., j] for j in range(n_phases)]
    re = _dot(cos, d)
    im = _dot(sin, d)
    r2 = re * re + im * im
    ok = r2 > 0.0
    r2_safe = jnp.where(ok, r2, 1.0)
    # The projections unnormalised (|Z| u_j), divided by |Z|^2 once: no square root or quotient with
    # several users, which XLA would materialise and then recompute the charges' whole chain in every
    # fusion that reads it (the noise image needs no square root of |Z| at all).
    along = [cj * re + sj * im for cj, sj in zip(cos, sin, strict=True)]  # Re(exp(i theta_j) conj(Z))
    across = [sj * re - cj * im for cj, sj in zip(cos, sin, strict=True)]  # Im(exp(i theta_j) conj(Z))
    # (At Z = 0 the old normalised projections took u = 1: Re u_j = cos theta_j, Im u_j = sin theta_j.)
    s_par2 = jnp.where(ok, sum(vj * aj * aj for vj, aj in zip(var, along, strict=True)) / r2_safe,
                       sum(vj * cj * cj for vj, cj in zip(var, cos, strict=True)))
    s_perp2 = jnp.where(ok, sum(vj * aj * aj for vj, aj in zip(var, across, strict=True)) / r2_safe,
                        sum(vj * sj * sj for vj, sj in zip(var, sin, strict=True)))
    v = jnp.where(ok, s_perp2 / r2_safe, jnp.inf)
    r = jnp.sqrt(r2_safe)
    phase = jnp.where(ok, jnp.mod(atan2(im, re), 2.0 * jnp.pi), 0.0)
    var_phase, mean_ratio = _rician.moments(v)
    modulus = jnp.where(ok, r, 0.0)
    mean = jnp.where(ok, modulus * jnp.where(ok, mean_ratio, 1.0), jnp.sqrt(0.5 * jnp.pi * s_perp2))
    var_amp = jnp.maximum(modulus**2 + s_par2 + s_perp2 - mean**2, 0.0)
    scale = amplitude_scale(n_phases)
    return phase, var_phase, v, scale * mean, scale**2 * var_amp


@eqx.filter_jit
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
    resultant = lax.complex(jnp.sum(w * jnp.cos(phase), axis=-1), jnp.sum(w * jnp.sin(phase), axis=-1))
    centre = phase_rad(resultant)
    dev = jnp.where(valid, wrap_angle(phase - centre[..., None]), 0.0)
    enough = n >= 2
    n_safe = jnp.where(enough, n, 2).astype(float)
    mean_dev = jnp.sum(dev, axis=-1) / n_safe
    var = jnp.sum(jnp.where(valid, (dev - mean_dev[..., None]) ** 2, 0.0), axis=-1) / (n_safe - 1.0)
    std = safe_sqrt(var)
    mean = jnp.mod(centre + mean_dev, 2.0 * jnp.pi)
    return jnp.where(enough, mean, jnp.nan), jnp.where(enough, std, jnp.nan), n


@eqx.filter_jit
def masked_mean_std(
    x: Float[Array, "*b frames"], valid: Bool[Array, "*b frames"]
) -> tuple[Float[Array, "*b"], Float[Array, "*b"]]:
    """Mean and sample standard deviation (ddof = 1) over the valid frames (NaN below two)."""
    n = jnp.sum(valid, axis=-1)
    enough = n >= 2
    n_safe = jnp.where(enough, n, 2).astype(float)
    mean = jnp.sum(jnp.where(valid, x, 0.0), axis=-1) / n_safe
    var = jnp.sum(jnp.where(valid, (x - mean[..., None]) ** 2, 0.0), axis=-1) / (n_safe - 1.0)
    std = safe_sqrt(var)
    return jnp.where(enough, mean, jnp.nan), jnp.where(enough, std, jnp.nan)


def _fill_invalid(x: Float[Array, "samples *rest"], valid: Bool[Array, "samples *rest"]) -> Array:
    """Replace invalid entries along axis 0 by the last valid one before them (the first valid
    one for a leading invalid run), so unwrapping can step over them."""
    idx = jnp.arange(x.shape[0]).reshape((-1,) + (1,) * (x.ndim - 1))
    idx = jnp.broadcast_to(idx, x.shape)
    # The running maximum as an associative scan: lax.cummax's reduce windows took 3x longer on a CPU.
    last = lax.associative_scan(jnp.maximum, jnp.where(valid, idx, -1), axis=0)
    first = jnp.min(jnp.where(valid, idx, x.shape[0] - 1), axis=0, keepdims=True)
    source = jnp.where(last >= 0, last, first)
    return jnp.take_along_axis(x, source, axis=0)


def unwrap_along_sweep(phase: Float[Array, "samples *rest"], valid: Bool[Array, "samples *rest"]) -> Array:
    """Unwrap phases along the sweep axis (§5.4: a jump larger than pi gets the 2 pi complement).

    Invalid entries are stepped over and come back as NaN. The first valid sample is taken to lie
    in the first unambiguity interval.
    """
    phase = jnp.where(valid, phase, 0.0)
    # Filling is skipped where every sample is valid (it would change nothing): at 1e5 points the fill
    # is half the unwrapping's time (docs/model.md, "Performance", measurement 24).
    filled = lax.cond(jnp.all(valid), lambda x, v: x, _fill_invalid, phase, valid)
    return jnp.where(valid, jnp.unwrap(filled, axis=0), jnp.nan)


class Demodulation(AbstractStage):
    """The last stage: the phase images' signed codes D_j = code_j - mid code to the phasor
    Z = sum_j D_j exp(i theta_j), its phase and amplitude (§3.3.3). Moments: the delta method with
    the higher orders of a phasor in Gaussian noise (:func:`delta_method`); samples: each frame's.

    **Fields** (static): ``n_phases``, ``mid_code`` (the code of a zero differential)."""

    n_phases: int = eqx.field(static=True)
    mid_code: float = eqx.field(static=True)

    def moments(self, m: Moments) -> Moments:
        phase, var_phase, v_first, amp, var_amp = delta_method(m.code - self.mid_code, m.var_code, self.n_phases)
        return replace(m, phase=phase, var_phase=var_phase, v_first=v_first, amp=amp, var_amp=var_amp)

    def sample(self, s: Samples) -> Samples:
        re, im = phasor(s.codes - self.mid_code)
        return replace(s, phase=atan2(im, re), amplitude=amplitude_scale(self.n_phases) * jnp.sqrt(re * re + im * im))
