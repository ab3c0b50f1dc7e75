"""Pixel saturation and suppression of background illumination (thesis §3.2.4-3.2.5,
§4.2.10-4.2.11, Figs 3.12-3.13, 5.2, 5.15).

Quantities are electrons collected by a tap, n = (V_reset - V) C / e; the full well is
N_sat = (V_reset - V_saturated) C / e.

- Without SBI a tap stops at N_sat (V = V_saturated); the pixel is saturated when either tap is.
- With SBI, from the moment the first tap reaches the threshold the common mode is removed: the
  full tap stays at N_sat and the same compensating charge is taken from the other, so the
  difference n_A - n_B keeps integrating. The other tap rises towards V_reset, and the pixel
  saturates only when it gets there, i.e. when |n_A - n_B| reaches N_sat. In closed form both
  taps lose max(0, max(n_A, n_B) - N_sat), then are floored at 0 (V_reset).

The hard mode is exact. The smooth mode replaces max(0, x) by a C^2 switch of half-width s (the
temperature, in electrons): 0 below -s, x above +s, and s (2u^3 - u^4) with u = (x/s + 1)/2 in
between; max(a, b) = b + relu(a - b). It tends to the hard mode as s -> 0, has finite first and
second derivatives everywhere, and - unlike softplus, whose exponential tails would shift a tap
holding a few hundred electrons - it is exact wherever every tap holds more than s electrons and
lies more than s below the full well (and, with SBI, the taps differ by more than s or both are
more than s below it).
"""

from __future__ import annotations

import jax.numpy as jnp
from jaxtyping import Array, Bool, Float


def _relu(x: Array, temperature: Array | None) -> Array:
    if temperature is None:
        return jnp.maximum(x, 0.0)
    u = jnp.clip(0.5 * (x / temperature + 1.0), 0.0, 1.0)
    inner = temperature * (2.0 * u**3 - u**4)
    return jnp.where(x >= temperature, x, jnp.where(x <= -temperature, 0.0, inner))


def _max(a: Array, b: Array, temperature: Array | None) -> Array:
    return b + _relu(a - b, temperature)


def saturate(
    n_a: Float[Array, "*b"],
    n_b: Float[Array, "*b"],
    full_well_e: Float[Array, ""],
    sbi: bool,
    temperature_e: Float[Array, ""] | None = None,
) -> tuple[Float[Array, "*b"], Float[Array, "*b"]]:
    """Apply SBI (if enabled) and saturation to the electrons collected by taps A and B.

    **Arguments:**
    - ``n_a``, ``n_b``: electrons the taps would collect without any limit.
    - ``full_well_e``: N_sat = (V_reset - V_saturated) C / e.
    - ``sbi``: whether the SBI circuit is enabled.
    - ``temperature_e``: ``None`` for the hard mode, else the smooth-mode temperature in electrons.

    **Returns:** the electrons the taps hold at the end of the exposure.
    """
    if not sbi:
        return n_a - _relu(n_a - full_well_e, temperature_e), n_b - _relu(n_b - full_well_e, temperature_e)
    removed = _relu(_max(n_a, n_b, temperature_e) - full_well_e, temperature_e)
    a, b = n_a - removed, n_b - removed
    return a + _relu(-a, temperature_e), b + _relu(-b, temperature_e)


def flags(
    n_a: Float[Array, "*b"], n_b: Float[Array, "*b"], full_well_e: Float[Array, ""], sbi: bool
) -> tuple[Bool[Array, "*b"], Bool[Array, "*b"]]:
    """(pixel saturated, SBI engaged) for unlimited tap electrons ``n_a``, ``n_b`` (hard criteria)."""
    high = jnp.maximum(n_a, n_b)
    if not sbi:
        return high >= full_well_e, jnp.zeros_like(high, dtype=bool)
    return jnp.abs(n_a - n_b) >= full_well_e, high > full_well_e
