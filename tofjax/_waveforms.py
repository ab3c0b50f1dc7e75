"""Periodic waveforms on one period and their Fourier coefficients (thesis §3.2.1, §4.2.3, Fig 4.2).

Every shape has peak 1 and is *centred* on t = 0: its on-time, ``duty_cycle`` periods long, spans
[-D/2, D/2]. Centring reference and illumination on the same instant is exactly the duty-centring
phase offset of §4.2.9 (45 deg for a 25 % pulse inside a 50 % gate), so no extra offset is needed.
``duty_cycle`` is the fraction of the period in which the output is non-zero (for gauss_extended,
the full width at half maximum), so every shape tends to the pulse of the same duty as its
order grows:

- ``pulse``: 1 on the on-time, 0 elsewhere.
- ``sine``: a raised cosine 0.5 (1 + cos(2 pi t / D)) on the on-time; D = 1 is the pure sinusoid.
- ``triangle``: rises linearly to 1 at t = 0 and back to 0 at the ends of the on-time.
- ``sawtooth``: rises linearly from 0 to 1 over the on-time, then drops to 0.
- ``gauss_extended``: super-Gaussian exp(-ln 2 (2t/D)^(2 p)), p = ``gauss_order`` (p = 1 Gaussian).
- ``fourier``: the pulse's Fourier series truncated after ``fourier_order`` harmonics, absolute
  value taken (optical power cannot be negative), normalised to peak 1.

Time is in periods. The correlation in :mod:`tofjax._mixer` uses the complex Fourier coefficients
c_k = int_0^1 w(t) exp(-2 pi i k t) dt, k = 0..K, which are closed-form for pulse, sine, triangle
and sawtooth (hence exact and differentiable in the duty cycle) and an FFT of a fine grid for the
two smooth numeric shapes.
"""

from __future__ import annotations

import functools

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Complex, Float

from ._params import AbstractWaveform

#: Harmonics kept in the correlation. The correlation of two waveforms with jumps decays as
#: 1/k^2, so 1024 harmonics put the truncation error below 1e-4 of the swing.
N_HARMONICS = 1024
#: Samples per period for the numerically transformed shapes (gauss_extended, fourier).
N_GRID = 8192


def _wrap(t: Array) -> Array:
    """Map time in periods to [-0.5, 0.5)."""
    return t - jnp.floor(t + 0.5)


def _fourier_series_of_pulse(u: Array, duty: Array, order: int) -> Array:
    k = jnp.arange(1, order + 1, dtype=float).reshape((1,) * u.ndim + (order,))
    terms = 2.0 * duty * jnp.sinc(k * duty) * jnp.cos(2.0 * jnp.pi * k * u[..., None])
    return duty + jnp.sum(terms, axis=-1)


def _gauss_extended(u: Array, duty: Array, order: int) -> Array:
    # Sum the neighbouring periods so wide, low-order pulses stay periodic. The five images added one
    # by one: as a reduction over a last axis of 5, XLA's CPU library kernel took 0.5 ms per waveform
    # on the coefficients' grid, a third of every call's correlation table.
    images = [jnp.exp(-jnp.log(2.0) * ((u + k) / (0.5 * duty)) ** (2 * order)) for k in (-2.0, -1.0, 0.0, 1.0, 2.0)]
    return functools.reduce(jnp.add, images)


@eqx.filter_jit
def waveform(wave: AbstractWaveform, t: Float[Array, "*t"]) -> Float[Array, "*t"]:
    """Evaluate a waveform at times ``t`` (in periods, any shape); peak 1, centred on t = 0.

    **Arguments:**
    - ``wave``: the waveform parameters (:class:`tofjax.IlluminationWaveform` or
      :class:`tofjax.ReferenceWaveform`).
    - ``t``: times in periods.

    **Returns:** the waveform values, same shape as ``t``.
    """
    u = _wrap(jnp.asarray(t, dtype=float))
    d = wave.duty_cycle
    half = 0.5 * d
    inside = jnp.abs(u) < half
    if wave.shape == "pulse":
        return jnp.where(inside | (d >= 1.0), 1.0, 0.0)
    if wave.shape == "sine":
        return jnp.where(inside | (d >= 1.0), 0.5 * (1.0 + jnp.cos(2.0 * jnp.pi * u / d)), 0.0)
    if wave.shape == "triangle":
        return jnp.maximum(0.0, 1.0 - jnp.abs(u) / half)
    if wave.shape == "sawtooth":
        return jnp.where(inside, (u + half) / d, 0.0)
    if wave.shape == "gauss_extended":
        peak = _gauss_extended(jnp.zeros(()), d, wave.gauss_order)
        return _gauss_extended(u, d, wave.gauss_order) / peak
    if wave.shape == "fourier":
        grid = jnp.arange(N_GRID, dtype=float) / N_GRID - 0.5
        peak = jnp.max(jnp.abs(_fourier_series_of_pulse(grid, d, wave.fourier_order)))
        return jnp.abs(_fourier_series_of_pulse(u, d, wave.fourier_order)) / peak
    raise ValueError(f"waveform shape = {wave.shape!r} is not one of sine, pulse, fourier, gauss_extended, "
                     "sawtooth, triangle")


@eqx.filter_jit
def fourier_coefficients(
    wave: AbstractWaveform, n_harmonics: int = N_HARMONICS
) -> Complex[Array, " harmonics"]:
    """Complex Fourier coefficients c_k, k = 0..n_harmonics, of one period of ``wave``.

    c_0 is the waveform's mean over the period: the fraction of the peak power actually emitted.
    """
    d = wave.duty_cycle
    k = jnp.arange(n_harmonics + 1, dtype=float)
    if wave.shape == "pulse":
        c = d * jnp.sinc(k * d)
    elif wave.shape == "sine":
        # 0.5 rect + 0.25 (rect shifted by +-1/D in frequency): a raised cosine of width D.
        c = 0.5 * d * jnp.sinc(k * d) + 0.25 * d * (jnp.sinc(k * d - 1.0) + jnp.sinc(k * d + 1.0))
    elif wave.shape == "triangle":
        c = 0.5 * d * jnp.sinc(0.5 * k * d) ** 2
    elif wave.shape == "sawtooth":
        # w = (t + D/2)/D on |t| < D/2: the odd part int t e^{-iat} dt = -2i (sin(ah)/a^2 - h cos(ah)/a).
        h = 0.5 * d
        a = 2.0 * jnp.pi * jnp.where(k == 0, 1.0, k)
        odd = ((jnp.sin(a * h) / a**2 - h * jnp.cos(a * h) / a) / d).astype(complex) * -2j
        c = (0.5 * d * jnp.sinc(k * d)).astype(complex) + jnp.where(k == 0, 0j, odd)
    elif wave.shape in ("gauss_extended", "fourier"):
        if n_harmonics > N_GRID // 2:
            raise ValueError(f"n_harmonics = {n_harmonics} exceeds the numeric grid: allowed <= {N_GRID // 2}")
        t = jnp.arange(N_GRID, dtype=float) / N_GRID
        c = jnp.fft.rfft(waveform(wave, t))[: n_harmonics + 1] / N_GRID
    else:
        raise ValueError(f"waveform shape = {wave.shape!r} is not one of sine, pulse, fourier, gauss_extended, "
                         "sawtooth, triangle")
    return jnp.asarray(c, dtype=complex)


def waveform_mean(wave: AbstractWaveform) -> Float[Array, ""]:
    """Mean of the waveform over one period (c_0): emitted energy / (peak power x period)."""
    return jnp.real(fourier_coefficients(wave, n_harmonics=0)[0])


def phase_steps(n_phases: int) -> np.ndarray:
    """Reference phase steps theta_j of an N-phase measurement, rad (thesis §2.1.1.1, §4.3).

    2 phases are 0 and 90 deg (the 2-tap pixel supplies the 180/270 deg complements); 3-5 are
    equally spaced over 360 deg.
    """
    if n_phases == 2:
        return np.array([0.0, 0.5 * np.pi])
    if n_phases in (3, 4, 5):
        return 2.0 * np.pi * np.arange(n_phases) / n_phases
    raise ValueError(f"pixel.n_phases = {n_phases!r} is out of range: allowed integer 2 <= value <= 5")
