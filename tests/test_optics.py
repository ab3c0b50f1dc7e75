"""Optical path (thesis §3.1): the exposure against Eq 3.11 in closed form, spot areas, lens, quantum efficiency."""

import math

import equinox as eqx
import jax.numpy as jnp
import numpy as np
import pytest

import tofjax
from tofjax import _constants as C
from tofjax._chain import build_chain
from tofjax._optics import quantum_efficiency


def test_unambiguity_range_at_80_32_mhz(default_params):
    assert float(default_params.unambiguity_range_m) == pytest.approx(1.8662, abs=5e-5)
    assert float(default_params.unambiguity_range_m) == pytest.approx(C.SPEED_OF_LIGHT_M_PER_S / (2 * 80.32e6))


def _eq_3_11_electrons(p, d, t, rectangular=False):
    """The thesis' centre pixel in closed form, written out independently of the model's camera
    equation: the illumination's peak flux over the spot area (Eqs 3.1-3.2), the Lambertian
    reflection of the pixel's footprint into the lens, p FF A_pixel k_lens / (4 N^2) (Eq 3.11), the
    waveform's mean, and responsivity x power x time / e (Eqs 3.14-3.18)."""
    fov = np.deg2rad(np.asarray(p.illumination.fov_deg, dtype=float))
    spot = (4 * np.tan(fov[0] / 2) * np.tan(fov[1] / 2) if rectangular else np.pi * np.tan(fov / 2) ** 2) * d**2
    cam = p.camera
    gain = (float(p.scene.reflectivity) * float(cam.fill_factor) * float(cam.pixel_pitch_m[0] * cam.pixel_pitch_m[1])
            * float(cam.k_lens) / (4 * float(cam.f_number) ** 2))
    flux = float(p.illumination.peak_power_w) / spot * gain
    mean = float(tofjax.waveforms.waveform_mean(p.illumination_waveform))
    return float(p.pixel.photo_responsivity_a_per_w) * flux * mean * t / C.ELEMENTARY_CHARGE_C, gain


def _exposure(p, d, t=2e-3, lux=0.0):
    d = jnp.asarray(d, dtype=float)
    return build_chain(p).expose(d, jnp.full(d.shape, lux), jnp.full(d.shape, t))


@pytest.mark.parametrize("rectangular", [False, True])
def test_the_exposure_is_eq_3_11_on_the_axis(default_params, rectangular):
    """The one camera equation (tofjax._photometry, the etendue of the pixel on the axis) gives the
    thesis' spot-area form: active electrons inverse-square in distance and linear in time, the
    background through the same optics (photon irradiance x gain x t x QE), to rounding."""
    p = default_params
    if rectangular:
        p = eqx.tree_at(lambda q: q.illumination.fov_deg, p, jnp.array([60.0, 45.0]))
    d = np.array([0.5, 1.0, 1.7, 4.0])
    q = _exposure(p, d)
    expected, gain = _eq_3_11_electrons(p, d, 2e-3, rectangular)
    np.testing.assert_allclose(q.signal_e, expected, rtol=1e-12)
    np.testing.assert_allclose(_exposure(p, d, t=4e-3).signal_e, 2 * expected, rtol=1e-12)
    lit = _exposure(p, d, lux=500.0)
    irradiance = tofjax.optics.background_photon_irradiance("sunlight", 500.0, p.illumination.wavelength_m,
                                                     p.scene.filter_half_width_m, p.constants)
    eta = quantum_efficiency(p.pixel, p.illumination.wavelength_m, p.constants)
    np.testing.assert_allclose(lit.background_e, float(irradiance) * gain * 2e-3 * float(eta), rtol=1e-12)
    # The defaults written out by hand (Eq 3.11's last line): 1.2 W, p 0.9, k_lens 0.9, FF 1, N 1.4.
    if not rectangular:
        fov = math.radians(75.0)
        flux = (1.2 * 0.9 * 0.9 * 1.0 / 1.4**2) * (17.5e-6 * 17.5e-6) / (4 * math.pi * (math.tan(fov / 2) * 1.7) ** 2)
        assert float(q.signal_e[2]) == pytest.approx(
            0.23 * flux * float(tofjax.waveforms.waveform_mean(p.illumination_waveform)) * 2e-3 / C.ELEMENTARY_CHARGE_C, rel=1e-12)


def test_rectangular_spot_area():
    ill = tofjax.Illumination(fov_deg=[60.0, 40.0])
    expected = (2 * 2.0 * math.tan(math.radians(30))) * (2 * 2.0 * math.tan(math.radians(20)))
    assert float(tofjax.optics.spot_area_m2(ill, 2.0)) == pytest.approx(expected, rel=1e-12)
    circ = tofjax.Illumination(fov_deg=75.0)
    assert float(tofjax.optics.spot_area_m2(circ, 2.0)) == pytest.approx(math.pi * (2 * math.tan(math.radians(37.5))) ** 2)


def test_lens_from_diagonal_fov_and_f_number():
    cam = tofjax.Optics()
    lens = tofjax.optics.lens(cam)
    diag = math.hypot(224 * 17.5e-6, 172 * 17.5e-6)
    assert float(lens.focal_length_m) == pytest.approx(diag / 2 / math.tan(math.radians(37.5)), rel=1e-12)
    assert float(lens.diameter_m) == pytest.approx(float(lens.focal_length_m) / 1.4, rel=1e-12)
    # A [h, v] FoV with the same diagonal gives the same lens.
    th = math.tan(math.radians(37.5))
    h = 2 * math.degrees(math.atan(th * 0.8))
    v = 2 * math.degrees(math.atan(th * 0.6))
    rect = tofjax.optics.lens(tofjax.Optics(fov_deg=[h, v]))
    assert float(rect.focal_length_m) == pytest.approx(float(lens.focal_length_m), rel=1e-12)


def test_quantum_efficiency_from_responsivity(default_params):
    eta = quantum_efficiency(default_params.pixel, default_params.illumination.wavelength_m, default_params.constants)
    expected = 0.23 * C.PLANCK_J_S * C.SPEED_OF_LIGHT_M_PER_S / (C.ELEMENTARY_CHARGE_C * 850e-9)
    assert float(eta) == pytest.approx(expected, rel=1e-12)
    assert 0.33 < float(eta) < 0.34


def test_reflectivity_k_lens_fill_factor_scale_linearly(default_params):
    base = _exposure(default_params, [1.0], lux=300.0)
    for where, value in [(lambda p: p.scene.reflectivity, 0.45), (lambda p: p.camera.k_lens, 0.45),
                         (lambda p: p.camera.fill_factor, 0.5)]:
        p = eqx.tree_at(where, default_params, jnp.asarray(value))
        half = _exposure(p, [1.0], lux=300.0)
        for name in ("signal_e", "background_e"):
            assert float(getattr(half, name)[0] / getattr(base, name)[0]) == pytest.approx(0.5, rel=1e-12)
