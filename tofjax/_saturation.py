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

The hard mode is exact. The smooth mode replaces max(0, x) by s softplus(x / s) and the max of
the two taps by s logaddexp(n_A/s, n_B/s) with a temperature s in electrons; it tends to the hard
mode as s -> 0 and has finite gradients everywhere.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
from jaxtyping import Array, Bool, Float


def _relu(x: Array, temperature: Array | None) -> Array:
    if temperature is None:
        return jnp.maximum(x, 0.0)
    return temperature * jax.nn.softplus(x / temperature)


def _max(a: Array, b: Array, temperature: Array | None) -> Array:
    if temperature is None:
        return jnp.maximum(a, b)
    return temperature * jnp.logaddexp(a / temperature, b / temperature)


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
