"""Waveforms (thesis §4.2.3, Fig 4.2): peak 1, centring, means, and Fourier coefficients checked
against an independent FFT of the time-domain samples."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import tofjax
from tofjax import IlluminationWaveform, ReferenceWaveform

SHAPES = ("sine", "pulse", "fourier", "gauss_extended", "sawtooth", "triangle")
T = np.arange(65536) / 65536 - 0.5


@pytest.mark.parametrize("shape", SHAPES)
@pytest.mark.parametrize("duty", [0.25, 0.5, 1.0])
def test_peak_one_and_non_negative(shape, duty):
    w = np.asarray(tofjax.waveforms.waveform(ReferenceWaveform(shape=shape, duty_cycle=duty), T))
    assert w.min() >= 0.0
    assert w.max() == pytest.approx(1.0, abs=1e-4)


@pytest.mark.parametrize("shape", ["sine", "pulse", "fourier", "gauss_extended", "triangle"])
def test_symmetric_shapes_are_centred_on_zero(shape):
    wave = ReferenceWaveform(shape=shape, duty_cycle=0.3)
    t = np.linspace(0.01, 0.49, 97)
    np.testing.assert_allclose(tofjax.waveforms.waveform(wave, t), tofjax.waveforms.waveform(wave, -t), atol=1e-12)
    c = tofjax.waveforms.fourier_coefficients(wave)
    assert np.max(np.abs(np.imag(c))) < 1e-9  # centred -> real coefficients


@pytest.mark.parametrize(
    "shape, duty, mean",
    [("pulse", 0.25, 0.25), ("sine", 1.0, 0.5), ("sine", 0.5, 0.25), ("triangle", 0.5, 0.25),
     ("sawtooth", 0.4, 0.2), ("gauss_extended", 0.25, 0.25)],
)
def test_mean_is_emitted_energy_fraction(shape, duty, mean):
    wave = IlluminationWaveform(shape=shape, duty_cycle=duty, gauss_order=60)
    assert float(tofjax.waveforms.waveform_mean(wave)) == pytest.approx(mean, rel=2e-3)
    assert float(tofjax.waveforms.waveform_mean(wave)) == pytest.approx(float(np.mean(tofjax.waveforms.waveform(wave, T))), rel=1e-3)


@pytest.mark.parametrize("shape", ["sine", "triangle", "pulse", "sawtooth"])
@pytest.mark.parametrize("duty", [0.25, 0.5, 0.8])
def test_closed_form_coefficients_match_fft_of_samples(shape, duty):
    wave = ReferenceWaveform(shape=shape, duty_cycle=duty)
    c = np.asarray(tofjax.waveforms.fourier_coefficients(wave, n_harmonics=20))
    # Independent: FFT of the waveform sampled on a fine grid starting at t = 0.
    t = np.arange(2**18) / 2**18
    fft = np.fft.rfft(np.asarray(tofjax.waveforms.waveform(wave, t)))[:21] / t.size
    # Jumps alias at O(1/N): 1e-5 for the pulse and sawtooth, far below for continuous shapes.
    np.testing.assert_allclose(c, fft, atol=2e-5)


def test_a_shape_is_one_class_found_by_its_name():
    """Every shape the configuration offers is one class of tofjax._waveforms.SHAPES; a new one needs
    only its values (the coefficients default to the FFT of a fine grid): cos^2(pi t), a sinusoid
    of mean 1/2, has c_0 = 1/2, c_1 = 1/4 and nothing above."""
    from tofjax._schema import WAVEFORM_SHAPES
    from tofjax._waveforms import SHAPES, AbstractShape

    assert tuple(SHAPES) == WAVEFORM_SHAPES and all(isinstance(s, AbstractShape) for s in SHAPES.values())

    class SquaredCosine(AbstractShape):
        name = "squared_cosine"

        def values(self, u, duty, wave):
            return jnp.cos(jnp.pi * u) ** 2

    wave = ReferenceWaveform()
    c = np.asarray(SquaredCosine().coefficients(jnp.arange(4.0), wave.duty_cycle, wave))
    np.testing.assert_allclose(c, [0.5, 0.25, 0.0, 0.0], atol=1e-15)
    with pytest.raises(ValueError, match="reference_waveform.shape = 'squared_cosine' is not allowed: expected one of"):
        __import__("dataclasses").replace(wave, shape="squared_cosine")  # the configuration's choices: the schema's


def test_sine_of_full_duty_is_a_pure_sinusoid():
    c = np.asarray(tofjax.waveforms.fourier_coefficients(ReferenceWaveform(shape="sine", duty_cycle=1.0), n_harmonics=8))
    np.testing.assert_allclose(c, [0.5, 0.25, 0, 0, 0, 0, 0, 0, 0], atol=1e-15)


def test_high_order_gauss_extended_tends_to_the_pulse():
    pulse = np.asarray(tofjax.waveforms.fourier_coefficients(ReferenceWaveform(shape="pulse", duty_cycle=0.5), 6))
    low = ReferenceWaveform(shape="gauss_extended", duty_cycle=0.5, gauss_order=2)
    high = ReferenceWaveform(shape="gauss_extended", duty_cycle=0.5, gauss_order=100)
    err_low = np.max(np.abs(np.asarray(tofjax.waveforms.fourier_coefficients(low, 6)) - pulse))
    err_high = np.max(np.abs(np.asarray(tofjax.waveforms.fourier_coefficients(high, 6)) - pulse))
    assert err_high < 0.25 * err_low and err_high < 0.01


@pytest.mark.parametrize("order", [1, 5, 40])
def test_fourier_shape_is_the_normalised_absolute_truncated_series(order):
    d = 0.3
    wave = ReferenceWaveform(shape="fourier", duty_cycle=d, fourier_order=order)
    t = np.linspace(-0.5, 0.5, 4001)
    k = np.arange(1, order + 1)[:, None]
    series = np.abs(d + np.sum(2 * d * np.sinc(k * d) * np.cos(2 * np.pi * k * t), axis=0))
    expected = series / series.max()
    np.testing.assert_allclose(tofjax.waveforms.waveform(wave, t), expected, atol=2e-3)  # max taken on a finite grid


@pytest.mark.parametrize("shape", SHAPES)
def test_coefficients_differentiable_in_duty(shape):
    def c1(d):
        return jnp.real(tofjax.waveforms.fourier_coefficients(ReferenceWaveform(shape=shape, duty_cycle=d), 3)[1])

    d0, h = 0.37, 1e-6
    fd = (c1(d0 + h) - c1(d0 - h)) / (2 * h)
    assert np.isfinite(jax.grad(c1)(d0))
    assert float(jax.grad(c1)(d0)) == pytest.approx(float(fd), rel=1e-5, abs=1e-8)


def test_phase_steps():
    np.testing.assert_allclose(tofjax.waveforms.phase_steps(2), [0, np.pi / 2])
    np.testing.assert_allclose(tofjax.waveforms.phase_steps(4), [0, np.pi / 2, np.pi, 1.5 * np.pi])
    np.testing.assert_allclose(tofjax.waveforms.phase_steps(3), [0, 2 * np.pi / 3, 4 * np.pi / 3])
    with pytest.raises(ValueError, match="n_phases"):
        tofjax.waveforms.phase_steps(6)
