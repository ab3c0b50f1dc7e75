"""Closed-form depth-noise estimates (thesis §5.5.4, Fig 5.18), from the chain's noise budget.

CW estimate (N-phase, 2-tap). Each phase image is D_j = A cos(phi - theta_j) + noise of variance
sigma_D^2. The estimator arg(sum_j D_j e^{i theta_j}) has phase variance (2 / N) sigma_D^2 / A^2
(for N = 2, Z = D_0 + i D_90 directly: sigma_D^2 / A^2, the same expression), so

    sigma_d = d_u / (2 pi) sigma_phi = c / (4 pi f) * sqrt(2) sigma_D / (sqrt(N) A).

A is the fundamental amplitude of the differential in electrons, K N_s 4 abs(R_1 S_1) / S_0 (K the
demodulation contrast, N_s the active electrons of one image, R_k, S_k the Fourier coefficients of
reference and emitted waveforms; 0.5 K N_s for sine/sine); sigma_D^2 is the variance of A - B from
every source of the noise budget (:class:`tofjax.chain.NoiseBudget`: shot noise of every collected electron,
reset and hold kTC of both taps, ...) plus the quantisation variance, in electrons. Exact for
sinusoidal correlation without ADC and saturation.

Pulsed estimate (the Perenzoni-Stoppa approach the thesis cites; its Eq 5.2 is not in the available
text, so it is derived here). A rectangular pulse of width T_p = duty / f inside complementary
gates splits the signal electrons N_sig as Q_A = (1 - x) N_sig, Q_B = x N_sig, with d = (c T_p / 2) x.
With background removed and per-tap variance v, at the centre of the range (x = 1/2)
sigma_x^2 = v / (2 N_sig^2); the N images form N/2 complementary pairs, so

    sigma_d = (c T_p / 2) sqrt(v / 2) / N_sig / sqrt(N / 2),

with N_sig = K N_s and v = sigma_D^2 / 2, half the differential variance. It ignores the waveforms'
shape and the mixing, as the thesis notes.
"""

from __future__ import annotations

import equinox as eqx
import jax.numpy as jnp
from jaxtyping import Array, Float

from ._chain import build_chain
from ._noise import Noise
from ._params import Params
from ._reduce import mean_last
from ._stages import Moments, fold_moments
from ._sweep import Sweep, check_inputs
from ._waveforms import fourier_coefficients


def _budget(params: Params, sweep: Sweep):
    """Active electrons and the differential variance sigma_D^2 (mean over the phase images), e-^2:
    the moments folded through the chain's noise stages as they stand in its tuple, with no limit
    acting (the estimate's premise), plus the readout's quantisation variance."""
    check_inputs(params, sweep)
    chain = build_chain(params, points=sweep.samples)
    charges = chain.expose(*sweep.operating_points(params))
    m = fold_moments(tuple(s for s in chain.stages if isinstance(s, Noise)), Moments.of(charges))
    readout = chain.readout
    quant_e2 = readout.quantization_variance_lsb2 * readout.lsb_e**2 if readout.dithered else 0.0
    return charges.signal_e, mean_last(m.var_a + m.var_b) + quant_e2


@eqx.filter_jit
def cw_depth_noise(params: Params, sweep: Sweep) -> Float[Array, "*b"]:
    """Shot-noise-limited CW estimate of the depth standard deviation, m (module docstring)."""
    active_e, var_d = _budget(params, sweep)
    r = fourier_coefficients(params.reference_waveform, 1)
    s = fourier_coefficients(params.illumination_waveform, 1)
    amplitude_e = params.pixel.demodulation_contrast * active_e * 4.0 * jnp.abs(r[1] * s[1]) / jnp.real(s[0])
    f = params.illumination_waveform.modulation_frequency_hz
    c = params.constants.speed_of_light_m_per_s
    n = params.pixel.n_phases
    return c / (4.0 * jnp.pi * f) * jnp.sqrt(2.0) * jnp.sqrt(var_d) / (jnp.sqrt(float(n)) * amplitude_e)


@eqx.filter_jit
def pulsed_depth_noise(params: Params, sweep: Sweep) -> Float[Array, "*b"]:
    """Pulsed (Perenzoni-Stoppa type) estimate of the depth standard deviation, m (module docstring)."""
    active_e, var_d = _budget(params, sweep)
    wave = params.illumination_waveform
    pulse_s = wave.duty_cycle / wave.modulation_frequency_hz
    n_sig = params.pixel.demodulation_contrast * active_e
    c = params.constants.speed_of_light_m_per_s
    return 0.5 * c * pulse_s * jnp.sqrt(0.25 * var_d) / n_sig / jnp.sqrt(0.5 * params.pixel.n_phases)
