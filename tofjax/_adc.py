"""The analogue-to-digital converter (thesis §3.3.1-3.3.2, §4.2.15, Figs 3.14-3.16, 4.7).

The differential tap voltage v = V_B - V_A enters an ADC with input range [-V_ref, V_ref],
V_ref = VrefPos - VrefNeg, FSR = 2 V_ref and q = FSR / 2^N (Eqs 3.32-3.34). Its continuous code
position, in LSB, is

    x = (v / q) (1 + gain% / 100) + offset
    u = 2^(N-1) + x + INL (1 - (x / 2^(N-1))^2)

(mid-scale is code 2^(N-1); the INL is a bow through both ends of the range, peaking at
mid-scale). Code c covers [E_c, E_c+1) with E_c = c - 1/2 + delta_c (a mid-tread quantiser, zero
offset -1/2 LSB as Fig 3.14b), and the DNL perturbs the edges by the fixed, evenly spread pattern
delta_c = (DNL / 2) sin(2 pi c g), g the golden ratio, so every step width lies within
1 +- DNL LSB. Codes are clipped to 0 .. 2^N - 1; a phase sample at either end is ADC-saturated.

The hard quantiser counts the edges below u exactly. The smooth one replaces each edge's step by
a Gaussian CDF of width ``temperature`` LSB: the expected code under Gaussian input noise of that
width, which tends to the hard one as the temperature goes to 0.
"""

from __future__ import annotations

import jax.numpy as jnp
from jax.scipy.special import ndtr
from jaxtyping import Array, Bool, Float

from ._params import ADC

_GOLDEN = 0.5 * (jnp.sqrt(5.0) - 1.0)
_SMOOTH_WINDOW = 6


def mid_code(adc: ADC) -> float:
    """Code of a zero differential voltage, 2^(N-1)."""
    return 2.0 ** (adc.resolution_bits - 1)


def max_code(adc: ADC) -> float:
    """Largest code, 2^N - 1."""
    return 2.0**adc.resolution_bits - 1.0


def code_position(adc: ADC, v: Float[Array, "*b"]) -> Float[Array, "*b"]:
    """Continuous code position u (LSB) of a differential voltage, with offset, gain and INL."""
    mid = mid_code(adc)
    x = v / adc.lsb_v
    if not adc.enabled:
        return mid + x
    x = x * (1.0 + adc.gain_error_percent_fsr / 100.0) + adc.offset_error_lsb
    return mid + x + adc.integral_nonlinearity_lsb * (1.0 - (x / mid) ** 2)


def _edge(adc: ADC, c: Array) -> Array:
    return c - 0.5 + 0.5 * adc.differential_nonlinearity_lsb * jnp.sin(2.0 * jnp.pi * _GOLDEN * c)


def quantize(adc: ADC, u: Float[Array, "*b"], temperature_lsb: Float[Array, ""] | None = None) -> Float[Array, "*b"]:
    """Code of a code position ``u`` (hard: exact integer; smooth: Gaussian-blurred staircase)."""
    if not adc.enabled:
        return u
    top = max_code(adc)
    base = jnp.floor(u)
    if temperature_lsb is None:
        # Edges c <= base lie below u, edges c >= base + 2 above it (|delta_c| < 1/2).
        c = base + 1.0
        valid = (c >= 1.0) & (c <= top)
        return jnp.clip(base, 0.0, top) + jnp.where(valid & (u >= _edge(adc, c)), 1.0, 0.0)
    j = jnp.arange(-_SMOOTH_WINDOW + 1, _SMOOTH_WINDOW + 1).reshape((1,) * base.ndim + (2 * _SMOOTH_WINDOW,))
    c = base[..., None] + j
    valid = (c >= 1.0) & (c <= top)
    steps = jnp.where(valid, ndtr((u[..., None] - _edge(adc, c)) / temperature_lsb), 0.0)
    return jnp.clip(base - _SMOOTH_WINDOW, 0.0, top) + jnp.sum(steps, axis=-1)


def saturated(adc: ADC, u: Float[Array, "*b"]) -> Bool[Array, "*b"]:
    """Whether the code of ``u`` is at either end of the range (§3.3.2)."""
    if not adc.enabled:
        return jnp.zeros(jnp.shape(u), dtype=bool)
    return (u < _edge(adc, jnp.asarray(1.0))) | (u >= _edge(adc, jnp.asarray(max_code(adc))))


def quantization_variance_lsb2(adc: ADC) -> Float[Array, ""]:
    """Variance of the quantisation error under noise spanning many codes, LSB^2.

    Code c spans [E_c, E_c+1) of width w_c, whose centre lies m_c away from c; it is hit with
    probability proportional to w_c and its error is uniform there, so the variance is
    sum w (w^2 / 12 + m^2) / sum w: 1/12 for an ideal ADC, about 0.16 with the default DNL of
    0.8 LSB (averaged over all codes of the fixed DNL pattern).
    """
    if not adc.enabled:
        return jnp.asarray(0.0)
    c = jnp.arange(1.0, 2.0**adc.resolution_bits - 1.0)
    lo, hi = _edge(adc, c), _edge(adc, c + 1.0)
    width, offset = hi - lo, 0.5 * (lo + hi) - c
    return jnp.sum(width * (width**2 / 12.0 + offset**2)) / jnp.sum(width)


def expected_code(adc: ADC, u: Float[Array, "*b"], temperature_lsb: Float[Array, ""] | None = None) -> Float[Array, "*b"]:
    """Mean code for a code position ``u`` under noise much wider than one LSB (the analytic path).

    Dithered by the noise, the mid-tread staircase averages to u itself; only the ends of the
    range remain (hard clip, or a soft clip of width ``temperature_lsb``).
    """
    if not adc.enabled:
        return u
    top = max_code(adc)
    if temperature_lsb is None:
        return jnp.clip(u, 0.0, top)
    s = temperature_lsb
    return s * jnp.logaddexp(0.0, u / s) - s * jnp.logaddexp(0.0, (u - top) / s)
