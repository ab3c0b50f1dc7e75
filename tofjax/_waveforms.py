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
from typing import ClassVar

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
    # by one: a reduction over a last axis of 5 is a slow library kernel on a CPU (docs/model.md,
    # "Performance", measurement 3).
    images = [jnp.exp(-jnp.log(2.0) * ((u + k) / (0.5 * duty)) ** (2 * order)) for k in (-2.0, -1.0, 0.0, 1.0, 2.0)]
    return functools.reduce(jnp.add, images)


class AbstractShape:
    """One waveform shape: its values on one period and its Fourier coefficients. A new shape is
    one subclass with its ``name`` (and the name in the schema's ``WAVEFORM_SHAPES``, the
    configuration's choices; a test holds the two equal); :data:`SHAPES` finds it by name.

    ``values(u, duty, wave)``: the waveform at times ``u`` in [-0.5, 0.5) periods, before any
    normalisation; ``peak 1`` is each shape's own business. ``coefficients(k, duty, wave)``: c_k at
    the harmonics ``k`` (float array), closed form where the shape has one; by default the FFT of
    :data:`N_GRID` samples of the values (the numeric shapes)."""

    name: ClassVar[str]

    def values(self, u: Array, duty: Array, wave: AbstractWaveform) -> Array:
        raise NotImplementedError

    def coefficients(self, k: Array, duty: Array, wave: AbstractWaveform) -> Array:
        n_harmonics = k.shape[0] - 1
        if n_harmonics > N_GRID // 2:
            raise ValueError(f"n_harmonics = {n_harmonics} exceeds the numeric grid: allowed <= {N_GRID // 2}")
        t = jnp.arange(N_GRID, dtype=float) / N_GRID
        return jnp.fft.rfft(self.values(_wrap(t), duty, wave))[: n_harmonics + 1] / N_GRID


def _on(u: Array, duty: Array) -> Array:
    """Inside the on-time |u| < D/2, or everywhere when D >= 1."""
    return (jnp.abs(u) < 0.5 * duty) | (duty >= 1.0)


class Pulse(AbstractShape):
    """1 on the on-time, 0 elsewhere; c_k = D sinc(k D)."""

    name: ClassVar[str] = "pulse"

    def values(self, u, duty, wave):
        return jnp.where(_on(u, duty), 1.0, 0.0)

    def coefficients(self, k, duty, wave):
        return duty * jnp.sinc(k * duty)


class Sine(AbstractShape):
    """A raised cosine 0.5 (1 + cos(2 pi t / D)) on the on-time (D = 1: the pure sinusoid)."""

    name: ClassVar[str] = "sine"

    def values(self, u, duty, wave):
        return jnp.where(_on(u, duty), 0.5 * (1.0 + jnp.cos(2.0 * jnp.pi * u / duty)), 0.0)

    def coefficients(self, k, duty, wave):
        # 0.5 rect + 0.25 (rect shifted by +-1/D in frequency): a raised cosine of width D.
        return 0.5 * duty * jnp.sinc(k * duty) + 0.25 * duty * (jnp.sinc(k * duty - 1.0) + jnp.sinc(k * duty + 1.0))


class Triangle(AbstractShape):
    """Rises linearly to 1 at t = 0 and back to 0 at the ends of the on-time."""

    name: ClassVar[str] = "triangle"

    def values(self, u, duty, wave):
        return jnp.maximum(0.0, 1.0 - jnp.abs(u) / (0.5 * duty))

    def coefficients(self, k, duty, wave):
        return 0.5 * duty * jnp.sinc(0.5 * k * duty) ** 2


class Sawtooth(AbstractShape):
    """Rises linearly from 0 to 1 over the on-time, then drops to 0."""

    name: ClassVar[str] = "sawtooth"

    def values(self, u, duty, wave):
        return jnp.where(jnp.abs(u) < 0.5 * duty, (u + 0.5 * duty) / duty, 0.0)

    def coefficients(self, k, duty, wave):
        # w = (t + D/2)/D on |t| < D/2: the odd part int t e^{-iat} dt = -2i (sin(ah)/a^2 - h cos(ah)/a).
        h = 0.5 * duty
        a = 2.0 * jnp.pi * jnp.where(k == 0, 1.0, k)
        odd = ((jnp.sin(a * h) / a**2 - h * jnp.cos(a * h) / a) / duty).astype(complex) * -2j
        return (0.5 * duty * jnp.sinc(k * duty)).astype(complex) + jnp.where(k == 0, 0j, odd)


class GaussExtended(AbstractShape):
    """Super-Gaussian exp(-ln 2 (2t/D)^(2 p)), p = ``gauss_order``, normalised to peak 1 (numeric)."""

    name: ClassVar[str] = "gauss_extended"

    def values(self, u, duty, wave):
        peak = _gauss_extended(jnp.zeros(()), duty, wave.gauss_order)
        return _gauss_extended(u, duty, wave.gauss_order) / peak


class Fourier(AbstractShape):
    """The pulse's Fourier series after ``fourier_order`` harmonics, absolute value, peak 1 (numeric)."""

    name: ClassVar[str] = "fourier"

    def values(self, u, duty, wave):
        grid = jnp.arange(N_GRID, dtype=float) / N_GRID - 0.5
        peak = jnp.max(jnp.abs(_fourier_series_of_pulse(grid, duty, wave.fourier_order)))
        return jnp.abs(_fourier_series_of_pulse(u, duty, wave.fourier_order)) / peak


#: The shapes by name (:class:`AbstractShape`).
SHAPES: dict[str, AbstractShape] = {cls.name: cls() for cls in (Sine, Pulse, Fourier, GaussExtended, Sawtooth, Triangle)}


def _shape(wave: AbstractWaveform) -> AbstractShape:
    try:
        return SHAPES[wave.shape]
    except KeyError:
        raise ValueError(f"waveform shape = {wave.shape!r} is not one of {', '.join(SHAPES)}") from None


@eqx.filter_jit
def waveform(wave: AbstractWaveform, t: Float[Array, "*t"]) -> Float[Array, "*t"]:
    """Evaluate a waveform at times ``t`` (in periods, any shape); peak 1, centred on t = 0.

    **Arguments:**
    - ``wave``: the waveform parameters (:class:`tofjax.IlluminationWaveform` or
      :class:`tofjax.ReferenceWaveform`).
    - ``t``: times in periods.

    **Returns:** the waveform values, same shape as ``t``.
    """
    return _shape(wave).values(_wrap(jnp.asarray(t, dtype=float)), wave.duty_cycle, wave)


@eqx.filter_jit
def fourier_coefficients(
    wave: AbstractWaveform, n_harmonics: int = N_HARMONICS
) -> Complex[Array, " harmonics"]:
    """Complex Fourier coefficients c_k, k = 0..n_harmonics, of one period of ``wave``.

    c_0 is the waveform's mean over the period: the fraction of the peak power actually emitted.
    """
    k = jnp.arange(n_harmonics + 1, dtype=float)
    return jnp.asarray(_shape(wave).coefficients(k, wave.duty_cycle, wave), dtype=complex)


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
