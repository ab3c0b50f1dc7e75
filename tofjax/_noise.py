"""Noise sources of the pixel (thesis §2.4.2, §3.2.3, §4.2.12-4.2.14).

All in electrons referred to the integration node (conversion gain e / C_int, C_int = C_diode +
C_sample&hold):

- reset noise: kTC on the integration capacitance, sqrt(k T C_int) / e (Eq 2.22);
- hold noise: kTC of the sample-and-hold switch on C_sample&hold, sqrt(k T / C_sh) volts, i.e.
  C_int sqrt(k T / C_sh) / e electrons;
- photon shot noise: Poisson, variance = mean, of every photo-electron a tap collects (signal and
  background, including those SBI later compensates) (Eq 2.24);
- dark signal: mean slope t C_int / e per tap (§4.2.14) and its shot noise sqrt(mean). The
  thesis' "dark slope sigma" is read as the pixel-to-pixel (fixed-pattern) spread of the slope,
  not as temporal noise (docs/model.md).
"""

from __future__ import annotations

import jax.numpy as jnp
from jaxtyping import Array, Float

from . import _constants as const
from ._params import PhysicalConstants, Pixel


def _kelvin(pixel: Pixel) -> Array:
    return pixel.temperature_c + const.ZERO_CELSIUS_K


def reset_noise_e(pixel: Pixel, constants: PhysicalConstants) -> Float[Array, ""]:
    """Reset (kTC) noise of one tap, electrons rms: sqrt(k T C_int) / e (Eqs 2.21-2.22)."""
    c = pixel.integration_capacitance_f
    return jnp.sqrt(constants.boltzmann_j_per_k * _kelvin(pixel) * c) / constants.elementary_charge_c


def hold_noise_e(pixel: Pixel, constants: PhysicalConstants) -> Float[Array, ""]:
    """Sample-and-hold (kTC) noise of one tap, in electrons at the integration node, rms."""
    v = jnp.sqrt(constants.boltzmann_j_per_k * _kelvin(pixel) / pixel.c_sample_and_hold_f)
    return v * pixel.integration_capacitance_f / constants.elementary_charge_c


def dark_electrons(
    pixel: Pixel, integration_time_s: Float[Array, "*b"], constants: PhysicalConstants, slope_v_per_s=None
) -> Float[Array, "*b"]:
    """Mean dark electrons of one tap: slope t C_int / e (§4.2.14)."""
    slope = pixel.dark_slope_mean_v_per_s if slope_v_per_s is None else slope_v_per_s
    return slope * integration_time_s * pixel.integration_capacitance_f / constants.elementary_charge_c
