"""Noise magnitudes (thesis §2.4.2, §4.2.12-4.2.14) and the mixer's correlation (§3.2.2)."""

import equinox as eqx
import jax.numpy as jnp
import numpy as np
import pytest

import tofjax
from tofjax._mixer import tap_a_fraction, tap_photo_electrons
from tofjax._noise import dark_electrons, hold_noise_e, reset_noise_e

CONSTS = tofjax.PhysicalConstants()


def test_ktc_noise_of_14_ff_at_25_c():
    pixel = tofjax.Pixel()  # C_diode = C_sample&hold = 7 fF
    assert float(reset_noise_e(pixel, CONSTS)) == pytest.approx(47.4, abs=0.05)
    # hold noise: kTC of 7 fF, referred to the 14 fF node
    assert float(hold_noise_e(pixel, CONSTS)) == pytest.approx(47.38 * np.sqrt(2), abs=0.1)


def test_dark_electrons_from_the_dark_slope():
    pixel = tofjax.Pixel()
    assert float(dark_electrons(pixel, 2e-3, CONSTS)) == pytest.approx(244.7, abs=0.05)
    assert float(dark_electrons(pixel, 4e-3, CONSTS)) == pytest.approx(2 * 244.7, abs=0.1)


def _params(ref="pulse", ref_duty=0.5, ill="pulse", ill_duty=0.5, n=4):
    return tofjax.Params(
        pixel=tofjax.Pixel(n_phases=n),
        illumination_waveform=tofjax.IlluminationWaveform(shape=ill, duty_cycle=ill_duty),
        reference_waveform=tofjax.ReferenceWaveform(shape=ref, duty_cycle=ref_duty),
    )


def _distance(p, delay_periods):
    return delay_periods * float(p.unambiguity_range_m)


def test_rectangular_pair_correlates_to_a_triangle():
    p = _params()
    tau = np.linspace(0, 1, 41, endpoint=False)
    a = np.array([np.asarray(tap_a_fraction(p, _distance(p, t)))[0] for t in tau])
    expected = 1 - 2 * np.abs(tau - np.round(tau))  # 1 in phase, 0 in anti-phase
    np.testing.assert_allclose(a, expected, atol=2e-3)  # harmonic truncation at the corners


def test_sine_pair_correlates_to_a_cosine():
    p = _params("sine", 1.0, "sine", 1.0)
    for t in np.linspace(0, 1, 13):
        a = np.asarray(tap_a_fraction(p, _distance(p, t)))
        theta = tofjax.phase_steps(4)
        np.testing.assert_allclose(a, 0.5 + 0.25 * np.cos(2 * np.pi * t - theta), atol=1e-12)


def test_quarter_duty_pulse_inside_half_gate_has_a_flat_top():
    """Fig 5.4: at 25 % duty the pulse fits the 50 % gate for delays up to 1/8 period."""
    p = _params(ill_duty=0.25)
    for t in (0.0, 0.05, 0.1):
        assert float(tap_a_fraction(p, _distance(p, t))[0]) == pytest.approx(1.0, abs=2e-3)
    assert float(tap_a_fraction(p, _distance(p, 0.5))[0]) == pytest.approx(0.0, abs=2e-3)


@pytest.mark.parametrize("n", [2, 3, 4, 5])
def test_two_tap_pixel_conserves_charge(n):
    p = _params("gauss_extended", 0.5, "gauss_extended", 0.25, n)
    contrast = float(p.pixel.demodulation_contrast)
    a, b = tap_photo_electrons(p, 1.3, jnp.asarray(1e4), jnp.asarray(3e3))
    np.testing.assert_allclose(a + b, 1e4 + 3e3, rtol=1e-12)
    # Above the equally distributed share ((1 - K) / 2 of the active electrons plus half the
    # background) each tap holds between none and all of the K-modulated electrons.
    equal = 0.5 * (1 - contrast) * 1e4 + 1.5e3
    assert np.all(a >= equal - 1e-6) and np.all(a <= equal + contrast * 1e4 + 1e-6)


def test_contrast_scales_the_differential():
    p = _params()
    a1, b1 = tap_photo_electrons(p, 0.7, jnp.asarray(1e4), jnp.asarray(0.0))
    p2 = eqx.tree_at(lambda q: q.pixel.demodulation_contrast, p, jnp.asarray(0.21))
    a2, b2 = tap_photo_electrons(p2, 0.7, jnp.asarray(1e4), jnp.asarray(0.0))
    np.testing.assert_allclose(a2 - b2, 0.5 * (a1 - b1), rtol=1e-12)
