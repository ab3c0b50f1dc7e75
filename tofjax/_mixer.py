"""The 2-tap photonic mixer (thesis §3.2.2, §4.2.9, Table 4.17, Eqs 3.19-3.21).

Within one period the tap-A gate is the reference r(t) and tap B its complement 1 - r(t)
(A = r s, B = s - r s). With r and s written as Fourier series, the fraction of the received
light that tap A collects at the reflected delay tau (in periods) and phase step theta_j is

    a_j = sum_k R_k conj(S_k) exp(i k (2 pi tau - theta_j)) / S_0,

exact up to the truncation at N_HARMONICS, continuous and differentiable in the distance.
"""

from __future__ import annotations

import jax.numpy as jnp
from jaxtyping import Array, Float

from ._params import Params
from ._waveforms import fourier_coefficients, phase_steps


def reflected_phase_rad(params: Params, distance_m: Float[Array, "*b"]) -> Float[Array, "*b"]:
    """phi_reflected = 4 pi f_mod d / c (Eq 3.22)."""
    f = params.illumination_waveform.modulation_frequency_hz
    return 4.0 * jnp.pi * f * distance_m / params.constants.speed_of_light_m_per_s


def tap_a_fraction(params: Params, distance_m: Float[Array, ""]) -> Float[Array, " phases"]:
    """Fraction of the *modulated* electrons that tap A collects, for each phase step.

    Tap B collects the rest (1 - a_j): the 2-tap pixel dumps no charge.
    """
    r = fourier_coefficients(params.reference_waveform)
    s = fourier_coefficients(params.illumination_waveform)
    product = r * jnp.conj(s)
    k = jnp.arange(product.shape[0])
    theta = jnp.asarray(phase_steps(params.pixel.n_phases))
    delay = reflected_phase_rad(params, distance_m) - theta  # phi = phi_phase + phi_reflected (Eq 3.23)
    terms = jnp.real(product[None, 1:] * jnp.exp(1j * k[None, 1:] * delay[:, None]))
    correlation = jnp.real(product[0]) + 2.0 * jnp.sum(terms, axis=-1)  # int_0^1 r_j(t) s(t) dt (Eq 3.24)
    return correlation / jnp.real(s[0])


def tap_photo_electrons(
    params: Params,
    distance_m: Float[Array, ""],
    active_e: Float[Array, ""],
    background_e: Float[Array, ""],
) -> tuple[Float[Array, " phases"], Float[Array, " phases"]]:
    """Expected photo-electrons collected by taps A and B in each phase exposure.

    The demodulation contrast K sorts K of the active electrons by phase (Eq 3.20); the rest,
    (1 - K)/2 per tap (Eq 3.19), and the background electrons go equally to both taps (Eq 3.21, but
    split in half: each background electron lands in one tap, see docs/model.md). Dark electrons
    are added per tap by the caller.
    """
    a = tap_a_fraction(params, distance_m)
    contrast = params.pixel.demodulation_contrast
    modulated = contrast * active_e
    equal = 0.5 * (1.0 - contrast) * active_e + 0.5 * background_e
    return modulated * a + equal, modulated * (1.0 - a) + equal
