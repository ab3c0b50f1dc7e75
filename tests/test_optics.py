"""Optical path (thesis §3.1): Eq 3.11 closed form, spot areas, lens, quantum efficiency."""

import math

import equinox as eqx
import jax.numpy as jnp
import numpy as np
import pytest

import tofjax
from tofjax import _constants as C
from tofjax._optics import active_electrons, collection_gain_m2, quantum_efficiency, scene_irradiance_w_per_m2


def test_unambiguity_range_at_80_32_mhz(default_params):
    assert float(default_params.unambiguity_range_m) == pytest.approx(1.8662, abs=5e-5)
    assert float(default_params.unambiguity_range_m) == pytest.approx(C.SPEED_OF_LIGHT_M_PER_S / (2 * 80.32e6))


def test_pixel_flux_equals_eq_3_11_closed_form(default_params):
    p = default_params
    d = 1.7
    flux = scene_irradiance_w_per_m2(p.illumination, d) * collection_gain_m2(p.scene, p.camera, d)
    # Eq 3.11, last line, with the defaults written out by hand.
    fov = math.radians(75.0)
    expected = (1.2 * 0.9 * 0.9 * 1.0 / 1.4**2) * (17.5e-6 * 17.5e-6) / (4 * math.pi * (math.tan(fov / 2) * d) ** 2)
    assert float(flux) == pytest.approx(expected, rel=1e-12)


def test_rectangular_spot_area():
    ill = tofjax.Illumination(fov_deg=[60.0, 40.0])
    expected = (2 * 2.0 * math.tan(math.radians(30))) * (2 * 2.0 * math.tan(math.radians(20)))
    assert float(tofjax.spot_area_m2(ill, 2.0)) == pytest.approx(expected, rel=1e-12)
    circ = tofjax.Illumination(fov_deg=75.0)
    assert float(tofjax.spot_area_m2(circ, 2.0)) == pytest.approx(math.pi * (2 * math.tan(math.radians(37.5))) ** 2)


def test_lens_from_diagonal_fov_and_f_number():
    cam = tofjax.Camera()
    lens = tofjax.lens(cam)
    diag = math.hypot(224 * 17.5e-6, 172 * 17.5e-6)
    assert float(lens.focal_length_m) == pytest.approx(diag / 2 / math.tan(math.radians(37.5)), rel=1e-12)
    assert float(lens.diameter_m) == pytest.approx(float(lens.focal_length_m) / 1.4, rel=1e-12)
    # A [h, v] FoV with the same diagonal gives the same lens.
    th = math.tan(math.radians(37.5))
    h = 2 * math.degrees(math.atan(th * 0.8))
    v = 2 * math.degrees(math.atan(th * 0.6))
    rect = tofjax.lens(tofjax.Camera(fov_deg=[h, v]))
    assert float(rect.focal_length_m) == pytest.approx(float(lens.focal_length_m), rel=1e-12)


def test_quantum_efficiency_from_responsivity(default_params):
    eta = quantum_efficiency(default_params.pixel, default_params.illumination.wavelength_m, default_params.constants)
    expected = 0.23 * C.PLANCK_J_S * C.SPEED_OF_LIGHT_M_PER_S / (C.ELEMENTARY_CHARGE_C * 850e-9)
    assert float(eta) == pytest.approx(expected, rel=1e-12)
    assert 0.33 < float(eta) < 0.34


def test_active_electrons_inverse_square_and_linear_in_time(default_params):
    d = jnp.array([0.5, 1.0, 2.0, 4.0])
    n = active_electrons(default_params, d, 2e-3, 0.25)
    np.testing.assert_allclose(n * d**2, n[0] * 0.25, rtol=1e-12)
    n2 = active_electrons(default_params, d, 4e-3, 0.25)
    np.testing.assert_allclose(n2, 2 * n, rtol=1e-12)
    # Electrons = responsivity x mean optical power x time / e (independent of the photon route).
    flux = scene_irradiance_w_per_m2(default_params.illumination, d) * collection_gain_m2(
        default_params.scene, default_params.camera, d)
    np.testing.assert_allclose(n, 0.23 * flux * 0.25 * 2e-3 / C.ELEMENTARY_CHARGE_C, rtol=1e-12)


def test_reflectivity_k_lens_fill_factor_scale_linearly(default_params):
    base = collection_gain_m2(default_params.scene, default_params.camera, 1.0)
    for where, value in [(lambda p: p.scene.reflectivity, 0.45), (lambda p: p.camera.k_lens, 0.45),
                         (lambda p: p.camera.fill_factor, 0.5)]:
        p = eqx.tree_at(where, default_params, jnp.asarray(value))
        ratio = float(collection_gain_m2(p.scene, p.camera, 1.0) / base)
        assert ratio == pytest.approx(0.5, rel=1e-12)
