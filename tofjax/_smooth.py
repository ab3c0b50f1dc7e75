"""Temperatures of the smooth relaxation of saturation, SBI and the ADC (docs/model.md, "Smooth
relaxation")."""

from __future__ import annotations

import equinox as eqx
import jax
import jax.numpy as jnp
from jaxtyping import Array, Float


def _f64(x) -> Array:
    return jnp.asarray(x, dtype=float)


class Smooth(eqx.Module):
    """Temperatures of the smooth relaxation (differentiable everywhere; hard mode as they -> 0).

    **Fields:**
    - ``saturation_temperature_v``: half-width of the soft saturation and SBI switching, V at the
      tap (1 mV = 87 electrons at 14 fF); exact where every tap is further than that from a limit.
    - ``adc_temperature_lsb``: width of each smoothed quantiser step and of the soft ADC rails,
      LSB; physically the rms input noise that would blur the staircase that much.
    """

    saturation_temperature_v: Float[Array, ""] = eqx.field(converter=_f64, default=1e-3)
    adc_temperature_lsb: Float[Array, ""] = eqx.field(converter=_f64, default=0.3)

    def __check_init__(self):
        for name in ("saturation_temperature_v", "adc_temperature_lsb"):
            value = getattr(self, name)
            if not isinstance(value, jax.core.Tracer) and not float(value) > 0.0:
                raise ValueError(f"Smooth.{name} = {float(value)!r} is out of range: allowed value > 0")
