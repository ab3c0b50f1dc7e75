"""Pixel saturation and suppression of background illumination (thesis §3.2.4-3.2.5,
§4.2.10-4.2.11, Figs 3.12-3.13, 5.2, 5.15): the chain's limit stage.

Quantities are electrons collected by a tap, n = (V_reset - V) C / e; the full well is
N_sat = (V_reset - V_saturated) C / e.

- Without SBI (:class:`Saturation`) a tap stops at N_sat (V = V_saturated); the pixel is saturated
  when either tap is.
- With SBI (:class:`SBI`), from the moment the first tap reaches the threshold the common mode is
  removed: the full tap stays at N_sat and the same compensating charge is taken from the other, so
  the difference n_A - n_B keeps integrating. The other tap rises towards V_reset, and the pixel
  saturates only when it gets there, i.e. when |n_A - n_B| reaches N_sat. In closed form both taps
  lose max(0, max(n_A, n_B) - N_sat), then are floored at 0 (V_reset).

The hard mode is exact. The smooth mode replaces max(0, x) by a C^2 switch of half-width s (the
temperature, in electrons): 0 below -s, x above +s, and s (2u^3 - u^4) with u = (x/s + 1)/2 in
between (its derivative is the smoothstep 3u^2 - 2u^3); max(a, b) = b + relu(a - b). It tends to the
hard mode as s -> 0, has finite first and second derivatives everywhere, and - unlike softplus,
whose exponential tails would shift a tap holding a few hundred electrons - it is exact wherever
every tap holds more than s electrons and lies more than s below the full well.

Each limit states what the chain needs of it: its value, the slopes of the held differential with
respect to each tap's charge (the analytic path), the hard saturation/SBI flags, and where it is
linear (the Monte Carlo draws one normal per phase image there, docs/model.md).
"""

from __future__ import annotations

import abc

import equinox as eqx
import jax.numpy as jnp
from jaxtyping import Array, Bool, Float

from ._stages import AbstractStage, Moments, replace


def _relu(x: Array, temperature: Array | None) -> Array:
    if temperature is None:
        return jnp.maximum(x, 0.0)
    u = jnp.clip(0.5 * (x / temperature + 1.0), 0.0, 1.0)
    inner = temperature * (2.0 * u**3 - u**4)
    return jnp.where(x >= temperature, x, jnp.where(x <= -temperature, 0.0, inner))


def _relu_slope(x: Array, temperature: Array | None) -> Array:
    """d relu / dx: the step (hard; 0 at the kink) or the smoothstep of the C^2 switch."""
    if temperature is None:
        return jnp.where(x > 0.0, 1.0, 0.0)
    u = jnp.clip(0.5 * (x / temperature + 1.0), 0.0, 1.0)
    return u * u * (3.0 - 2.0 * u)


def _max(a: Array, b: Array, temperature: Array | None) -> Array:
    """max(a, b) = b + relu(a - b); exactly a where a leads by the switch's width."""
    if temperature is None:
        return jnp.maximum(a, b)
    return jnp.where(a - b >= temperature, a, b + _relu(a - b, temperature))


def _min_with(x: Array, top: Array, temperature: Array | None) -> Array:
    """min(x, top) = x - relu(x - top); exactly ``top`` beyond the switch's width (so pinned taps
    hold exactly the full well, not the full well plus rounding)."""
    if temperature is None:
        return jnp.minimum(x, top)
    return jnp.where(x - top >= temperature, top, x - _relu(x - top, temperature))


class AbstractLimit(AbstractStage):
    """The limit stage: the taps' charge after SBI/saturation. Its moments: the held charges at the
    taps' means, and the differential's variance through the closed-form slopes (the delta method);
    the Monte Carlo applies it to each frame's taps in its draw (:mod:`tofjax._frames`).

    **Fields:** ``full_well_e`` (N_sat), ``temperature_e`` (``None``: hard mode; else the smooth
    switch's half-width in electrons).
    """

    full_well_e: eqx.AbstractVar[Float[Array, ""]]
    temperature_e: eqx.AbstractVar[Float[Array, ""] | None]

    @abc.abstractmethod
    def __call__(self, n_a: Array, n_b: Array) -> tuple[Array, Array]:
        """Electrons the taps hold at the end of the exposure."""

    @abc.abstractmethod
    def slopes(self, n_a: Array, n_b: Array) -> tuple[Array, Array]:
        """d(held_A - held_B)/dn_A and d(held_A - held_B)/dn_B, in closed form."""

    @abc.abstractmethod
    def flags(self, n_a: Array, n_b: Array) -> tuple[Bool[Array, "*b"], Bool[Array, "*b"]]:
        """(pixel saturated, SBI engaged) for tap charges ``n_a``, ``n_b`` (hard criteria)."""

    @abc.abstractmethod
    def headroom(self, n_a: Array, n_b: Array) -> Array:
        """The charge, in electrons, the taps ``n_a``, ``n_b`` could still gain before the pixel
        saturates (hard criterion: > 0 exactly where :meth:`flags` says unsaturated; negative beyond)."""

    @abc.abstractmethod
    def passes(self, n_a: Array, n_b: Array, reach_a: Array, reach_b: Array) -> Array:
        """Whether every charge within ``reach`` electrons of ``n`` keeps its differential and leaves
        the pixel unsaturated (the analytic path's linearisation holds there)."""

    @abc.abstractmethod
    def linear(self, n_a: Array, n_b: Array, reach_a: Array, reach_b: Array) -> tuple[Array, Array]:
        """Whether every charge within ``reach`` electrons of ``n`` passes (:meth:`passes`) with
        constant flags, and the (constant) SBI flag there: ``(linear, sbi_engaged)``."""

    def moments(self, m: Moments) -> Moments:
        held_a, held_b = self(m.a, m.b)
        slope_a, slope_b = self.slopes(m.a, m.b)
        zero = jnp.zeros((), held_a.dtype)
        return replace(m, a=held_a, b=held_b, diff=held_a - held_b,
                       var_diff=slope_a**2 * m.var_a + slope_b**2 * m.var_b, post_a=zero, post_b=zero)

    @property
    def _margin(self) -> Array | float:
        return 0.0 if self.temperature_e is None else 2.0 * self.temperature_e


class Saturation(AbstractLimit):
    """Without SBI: each tap stops at the full well."""

    full_well_e: Float[Array, ""]
    temperature_e: Float[Array, ""] | None = None

    def __call__(self, n_a, n_b):
        s, n = self.temperature_e, self.full_well_e
        return _min_with(n_a, n, s), _min_with(n_b, n, s)

    def slopes(self, n_a, n_b):
        s, n = self.temperature_e, self.full_well_e
        return 1.0 - _relu_slope(n_a - n, s), -(1.0 - _relu_slope(n_b - n, s))

    def flags(self, n_a, n_b):
        high = jnp.maximum(n_a, n_b)
        return high >= self.full_well_e, jnp.zeros(jnp.shape(high), dtype=bool)

    def headroom(self, n_a, n_b):
        return self.full_well_e - jnp.maximum(n_a, n_b)  # the fuller tap to the full well

    def passes(self, n_a, n_b, reach_a, reach_b):
        top = self.full_well_e - self._margin
        return (n_a + reach_a < top) & (n_b + reach_b < top)

    def linear(self, n_a, n_b, reach_a, reach_b):
        ok = self.passes(n_a, n_b, reach_a, reach_b)
        return ok, jnp.zeros(jnp.shape(ok), dtype=bool)


class SBI(AbstractLimit):
    """With the SBI circuit: the common mode above the full well is removed (module docstring)."""

    full_well_e: Float[Array, ""]
    temperature_e: Float[Array, ""] | None = None

    def _removed(self, n_a, n_b):
        s = self.temperature_e
        return _relu(_max(n_a, n_b, s) - self.full_well_e, s)

    def __call__(self, n_a, n_b):
        s = self.temperature_e
        removed = self._removed(n_a, n_b)
        a, b = n_a - removed, n_b - removed
        return a + _relu(-a, s), b + _relu(-b, s)

    def slopes(self, n_a, n_b):
        s, n = self.temperature_e, self.full_well_e
        high_a = _relu_slope(n_a - n_b, s)  # d max(a, b) / da
        engaged = _relu_slope(_max(n_a, n_b, s) - n, s)
        r_a, r_b = engaged * high_a, engaged * (1.0 - high_a)  # d removed / da, / db
        removed = self._removed(n_a, n_b)
        keep_a = 1.0 - _relu_slope(removed - n_a, s)  # the floor of tap A is inactive
        keep_b = 1.0 - _relu_slope(removed - n_b, s)
        return keep_a * (1.0 - r_a) + keep_b * r_a, -keep_a * r_b - keep_b * (1.0 - r_b)

    def flags(self, n_a, n_b):
        return jnp.abs(n_a - n_b) >= self.full_well_e, jnp.maximum(n_a, n_b) > self.full_well_e

    def headroom(self, n_a, n_b):
        return self.full_well_e - jnp.abs(n_a - n_b)  # SBI removes the common mode: the difference to the full well

    def passes(self, n_a, n_b, reach_a, reach_b):
        # The floors stay inactive: both taps above 0 and, once SBI removes the common mode,
        # their difference below the full well.
        margin, n = self._margin, self.full_well_e
        return (n_a - reach_a > margin) & (n_b - reach_b > margin) \
            & (jnp.abs(n_a - n_b) + reach_a + reach_b < n - margin)

    def linear(self, n_a, n_b, reach_a, reach_b):
        margin, n = self._margin, self.full_well_e
        ok = self.passes(n_a, n_b, reach_a, reach_b)
        never = jnp.maximum(n_a + reach_a, n_b + reach_b) < n - margin
        always = jnp.maximum(n_a - reach_a, n_b - reach_b) > n + margin
        return ok & (never | always), always


def full_well_e(v_reset_v: Array, v_saturated_v: Array, electrons_per_volt: Array,
                given_e: Array | float = 0.0) -> Array:
    """N_sat = (V_reset - V_saturated) C_int / e (§3.2.5), or a data sheet's full well ``given_e``
    when it is > 0 (``pixel.full_well_e``; the SBI threshold is then that charge too)."""
    return jnp.where(given_e > 0.0, given_e, (v_reset_v - v_saturated_v) * electrons_per_volt)


def limit_stage(full_well: Float[Array, ""], sbi: bool, temperature_e: Float[Array, ""] | None = None) -> AbstractLimit:
    """The limit of a pixel: :class:`SBI` if the circuit is enabled, else :class:`Saturation`."""
    return SBI(full_well, temperature_e) if sbi else Saturation(full_well, temperature_e)


def saturate(n_a: Float[Array, "*b"], n_b: Float[Array, "*b"], full_well: Float[Array, ""], sbi: bool,
             temperature_e: Float[Array, ""] | None = None) -> tuple[Float[Array, "*b"], Float[Array, "*b"]]:
    """Apply SBI (if enabled) and saturation to the electrons of taps A and B (module docstring)."""
    return limit_stage(full_well, sbi, temperature_e)(n_a, n_b)


def flags(n_a: Float[Array, "*b"], n_b: Float[Array, "*b"], full_well: Float[Array, ""],
          sbi: bool) -> tuple[Bool[Array, "*b"], Bool[Array, "*b"]]:
    """(pixel saturated, SBI engaged) for unlimited tap electrons (hard criteria)."""
    return limit_stage(full_well, sbi).flags(n_a, n_b)
