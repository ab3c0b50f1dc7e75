"""The analogue-to-digital converter (thesis §3.3.1-3.3.2, §4.2.15, Figs 3.14-3.16, 4.7): the
chain's readout stage.

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

import math

import equinox as eqx
import jax
import jax.numpy as jnp
from jax.scipy.special import ndtr
from jaxtyping import Array, Bool, Float

from ._params import ADC
from ._stages import AbstractStage, Moments, Samples, replace

_GOLDEN = 0.5 * (math.sqrt(5.0) - 1.0)
_SMOOTH_WINDOW = 6
# sin(pi s) for abs(s) <= 1/2: Taylor series to s^13 (error < 7e-10, far below any edge spacing).
_SIN_PI = tuple(((-1) ** n) * math.pi ** (2 * n + 1) / math.factorial(2 * n + 1) for n in range(7))


def mid_code(adc: ADC) -> float:
    """Code of a zero differential voltage, 2^(N-1)."""
    return 2.0 ** (adc.resolution_bits - 1)


def max_code(adc: ADC) -> float:
    """Largest code, 2^N - 1."""
    return 2.0**adc.resolution_bits - 1.0


@eqx.filter_jit
def code_position(adc: ADC, v: Float[Array, "*b"], per_volt: Float[Array, ""] | float = 1.0) -> Float[Array, "*b"]:
    """Continuous code position u (LSB) of a differential voltage ``v``, with offset, gain and INL;
    with ``per_volt`` (units of ``v`` per volt, e.g. C_int / e) of a differential charge. The per-call
    scalars are folded so that each frame costs multiplications only."""
    mid = mid_code(adc)
    per_lsb = 1.0 / (per_volt * adc.lsb_v)
    if not adc.enabled:
        return mid + v * per_lsb
    x = v * (per_lsb * (1.0 + adc.gain_error_percent_fsr / 100.0)) + adc.offset_error_lsb
    return mid + x + adc.integral_nonlinearity_lsb * (1.0 - (x * (1.0 / mid)) ** 2)


def code_position_slope(adc: ADC, v: Float[Array, "*b"], per_volt: Float[Array, ""] | float = 1.0) -> Float[Array, "*b"]:
    """du/dv, LSB per unit of ``v`` (the derivative of :func:`code_position`)."""
    per_lsb = 1.0 / (per_volt * adc.lsb_v)
    if not adc.enabled:
        return jnp.broadcast_to(per_lsb, jnp.shape(v))
    mid = mid_code(adc)
    slope = per_lsb * (1.0 + adc.gain_error_percent_fsr / 100.0)
    x = v * slope + adc.offset_error_lsb
    return slope * (1.0 - 2.0 * adc.integral_nonlinearity_lsb * x / mid**2)


def _sin_two_pi(x: Array) -> Array:
    """sin(2 pi x) by a polynomial after exact reduction (XLA's sin costs ~14 ns on a CPU)."""
    s = 2.0 * (x - jnp.round(x))  # sin(2 pi x) = sin(pi s), s in [-1, 1]
    s = jnp.where(s > 0.5, 1.0 - s, jnp.where(s < -0.5, -1.0 - s, s))
    z = s * s
    p = _SIN_PI[-1]
    for c in _SIN_PI[-2::-1]:
        p = p * z + c
    return s * p


def _edge(adc: ADC, c: Array) -> Array:
    return c - 0.5 + 0.5 * adc.differential_nonlinearity_lsb * _sin_two_pi(_GOLDEN * c)


@eqx.filter_jit
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
    j = jnp.arange(-_SMOOTH_WINDOW + 1, _SMOOTH_WINDOW + 1, dtype=float).reshape(
        (1,) * base.ndim + (2 * _SMOOTH_WINDOW,))
    c = base[..., None] + j
    valid = (c >= 1.0) & (c <= top)
    steps = jnp.where(valid, ndtr((u[..., None] - _edge(adc, c)) / temperature_lsb), 0.0)
    return jnp.clip(base - _SMOOTH_WINDOW, 0.0, top) + jnp.sum(steps, axis=-1)


def saturated(adc: ADC, u: Float[Array, "*b"]) -> Bool[Array, "*b"]:
    """Whether the code of ``u`` is at either end of the range (§3.3.2)."""
    if not adc.enabled:
        return jnp.zeros(jnp.shape(u), dtype=bool)
    return (u < _edge(adc, jnp.asarray(1.0))) | (u >= _edge(adc, jnp.asarray(max_code(adc))))


def saturated_code(adc: ADC, codes: Float[Array, "*b"]) -> Bool[Array, "*b"]:
    """:func:`saturated` read from the hard quantiser's codes (:func:`quantize` without a temperature):
    a code is 0 exactly where u lies below the first edge, and the top code exactly where u reaches
    the last, because every edge E_c lies within 1/2 LSB of c - 1/2 (the DNL, below 1 LSB, moves it by
    at most half of it): u below E_1 < 1 floors to 0 or below, and u at or above E_top > top - 1 to
    top - 1 or above. Not for the smooth mode's blurred codes."""
    if not adc.enabled:
        return jnp.zeros(jnp.shape(codes), dtype=bool)
    return (codes <= 0.0) | (codes >= max_code(adc))


def headroom(adc: ADC, u: Float[Array, "*b"]) -> Float[Array, "*b"]:
    """The distance, in LSB, from code position ``u`` to the nearer end of the range (:func:`saturated`
    below 0), ``inf`` without an ADC."""
    if not adc.enabled:
        return jnp.full(jnp.shape(u), jnp.inf)
    return jnp.minimum(u - _edge(adc, jnp.asarray(1.0)), _edge(adc, jnp.asarray(max_code(adc))) - u)


def quantization_variance_lsb2(adc: ADC) -> Float[Array, ""]:
    """Variance of the quantisation error under noise spanning many codes, LSB^2.

    Code c spans [E_c, E_c+1) of width w_c, whose centre lies m_c away from c; it is hit with
    probability proportional to w_c and its error is uniform there, so the variance is
    sum w (w^2 / 12 + m^2) / sum w: 1/12 for an ideal ADC, about 0.16 with the default DNL of
    0.8 LSB (averaged over all codes of the fixed DNL pattern).
    """
    if not adc.enabled:
        return jnp.asarray(0.0)
    c = jnp.arange(1.0, 2.0**adc.resolution_bits - 1.0, dtype=jnp.result_type(adc.v_ref_pos_v))
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


def expected_code_slope(adc: ADC, u: Float[Array, "*b"], temperature_lsb: Float[Array, ""] | None = None):
    """d(expected code)/du: 1 inside the range, 0 beyond the rails (soft rails: a difference of
    logistic functions)."""
    if not adc.enabled:
        return jnp.ones(jnp.shape(u), jnp.result_type(u))
    top = max_code(adc)
    if temperature_lsb is None:
        return jnp.where((u > 0.0) & (u < top), 1.0, 0.0)
    s = temperature_lsb
    return jax.nn.sigmoid(u / s) - jax.nn.sigmoid((u - top) / s)


class Readout(AbstractStage):
    """The readout stage: the held differential charge A - B (electrons) to codes. Its moments: the
    expected code and its slope at the mean (:meth:`linearize`), the input's variance through the
    slope, plus the quantisation variance where temporal noise dithers the staircase; its samples:
    each frame's codes.

    **Fields:** ``adc`` (:class:`tofjax.ADC`), ``electrons_per_volt`` (C_int / e), ``temperature_lsb``
    (``None``: hard quantiser and rails; else the smooth mode's width), ``dithered`` (static: the
    quantisation error counts as noise, as it does when temporal noise is on, ``pixel.noise``).
    """

    adc: ADC
    electrons_per_volt: Float[Array, ""]
    temperature_lsb: Float[Array, ""] | None = None
    dithered: bool = eqx.field(static=True, default=True)

    def moments(self, m: Moments) -> Moments:
        code, slope_code, u, slope_u = self.linearize(m.diff)
        var_code = slope_code**2 * m.var_diff
        if self.dithered:
            var_code = var_code + self.quantization_variance_lsb2
        return replace(m, code=code, u=u, slope_u=slope_u, var_code=var_code)

    def sample(self, s: Samples) -> Samples:
        u = self.position(s.diff)
        return replace(s, u=u, codes=self.quantize(u), adc_saturated=jnp.any(self.saturated(u), axis=0))

    @property
    def codes_show_saturation(self) -> bool:
        """Whether frames' codes alone say where the ADC saturated (the hard quantiser:
        :func:`saturated_code`), so that a draw can hand on its codes instead of its differential."""
        return self.temperature_lsb is None

    def saturated_codes(self, codes: Array) -> Array:
        """Per frame, whether any phase image's code (phase axis first) is at a rail: what
        :meth:`sample` finds from the code positions, read from the hard quantiser's codes
        (:attr:`codes_show_saturation`)."""
        return jnp.any(saturated_code(self.adc, codes), axis=0)

    @property
    def mid_code(self) -> float:
        return mid_code(self.adc)

    def position(self, differential_e: Array) -> Array:
        """Continuous code position u of a differential charge (:func:`code_position`)."""
        return code_position(self.adc, differential_e, self.electrons_per_volt)

    def linearize(self, differential_e: Array) -> tuple[Array, Array, Array, Array]:
        """(expected code, d code / d charge, code position u, d u / d charge) at a differential charge."""
        u = self.position(differential_e)
        du = code_position_slope(self.adc, differential_e, self.electrons_per_volt)
        return expected_code(self.adc, u, self.temperature_lsb), expected_code_slope(self.adc, u, self.temperature_lsb) * du, u, du

    def quantize(self, u: Array) -> Array:
        """Codes of code positions (one frame each)."""
        return quantize(self.adc, u, self.temperature_lsb)

    def saturated(self, u: Array) -> Array:
        return saturated(self.adc, u)

    def headroom(self, u: Array) -> Array:
        """How far, in LSB, the code position ``u`` lies from the nearer end of the range (hard
        criterion: >= 0 exactly where :meth:`saturated` is false, but for ``u`` on the top edge;
        ``inf`` without an ADC)."""
        return headroom(self.adc, u)

    @property
    def quantization_variance_lsb2(self) -> Array:
        return quantization_variance_lsb2(self.adc)

    @property
    def lsb_e(self) -> Array:
        """One LSB (q) in electrons at the integration node (ignoring the gain error)."""
        return self.adc.lsb_v * self.electrons_per_volt
