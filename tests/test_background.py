"""Background light (thesis §3.1.2, §4.2.4): lux normalisation, filter band, spectra."""

from importlib import resources

import numpy as np
import pytest

import tofjax
from tofjax import _background as bg
from tofjax import _constants as C

CONSTS = tofjax.PhysicalConstants()
LAMPS = ("sunlight", "halogen", "incandescent", "fluorescent")


def _table(name):
    text = resources.files("tofjax").joinpath("data", name).read_text()
    rows = [r for r in text.splitlines() if r and not r.startswith("#")][1:]
    data = np.array([[float(x) for x in r.split(",")] for r in rows])
    return data[:, 0] * 1e-9, data[:, 1]


@pytest.mark.parametrize("lamp", LAMPS)
def test_linear_in_illuminance_and_zero_in_the_dark(lamp):
    e = np.asarray(bg.background_photon_irradiance(lamp, np.array([0.0, 100.0, 300.0]), 850e-9, 0.0, CONSTS))
    assert e[0] == 0.0 and e[1] > 0
    assert e[2] == pytest.approx(3 * e[1], rel=1e-12)


@pytest.mark.parametrize("lamp", LAMPS)
def test_filter_wider_than_the_detector_band_equals_no_filter(lamp):
    no_filter = bg.background_photon_irradiance(lamp, 500.0, 850e-9, 0.0, CONSTS)
    wide = bg.background_photon_irradiance(lamp, 500.0, 850e-9, 1e-6, CONSTS)
    assert float(wide) == pytest.approx(float(no_filter), rel=1e-12)
    narrow = bg.background_photon_irradiance(lamp, 500.0, 850e-9, 20e-9, CONSTS)
    assert float(narrow) <= float(no_filter)


def test_narrow_filter_on_sunlight_matches_an_independent_integral():
    """+-5 nm around 850 nm, integrated here from the raw ASTM G173 table (in W/m^2/nm) and the
    CIE V(lambda) table with numpy, then compared with tofjax."""
    wl, e = _table("astm_g173_global_tilt.csv")
    vwl, v = _table("cie_1924_photopic_v.csv")
    lux_per_unit = C.LUMINOUS_EFFICACY_LM_PER_W * np.trapezoid(np.interp(vwl, wl, e) * v, vwl)
    scale = 1000.0 / lux_per_unit  # 1000 lx
    x = np.linspace(845e-9, 855e-9, 2001)
    ex = np.interp(x, wl, e)
    photons = scale * np.trapezoid(ex * x, x) / (C.PLANCK_J_S * C.SPEED_OF_LIGHT_M_PER_S)
    power = scale * np.trapezoid(ex, x)
    got = bg.background_photon_irradiance("sunlight", 1000.0, 850e-9, 5e-9, CONSTS)
    got_w = bg.background_irradiance_w_per_m2("sunlight", 1000.0, 850e-9, 5e-9, CONSTS)
    assert float(got) == pytest.approx(photons, rel=2e-3)  # interpolation of V onto the 0.5 nm grid
    assert float(got_w) == pytest.approx(power, rel=2e-3)


def test_sunlight_luminous_efficacy_is_that_of_daylight():
    """AM1.5 global sunlight carries about 100-120 lm per W of total irradiance."""
    grid, e = bg.spectrum("sunlight")
    _, v = bg.photopic_v()
    efficacy = C.LUMINOUS_EFFICACY_LM_PER_W * np.trapezoid(v * e, grid) / np.trapezoid(e, grid)
    assert 95 < efficacy < 125


def test_incandescent_is_cie_illuminant_a_planck():
    grid, e = bg.spectrum("incandescent")
    # CIE A relative SPD, normalised to 100 at 560 nm: 300 nm -> 0.930483, 780 nm -> 241.675 (CIE 15:2004
    # table). The table differs from its own defining formula by ~0.13 % at the ends, hence 2e-3.
    rel = 100 * e / np.interp(560e-9, grid, e)
    assert np.interp(300e-9, grid, rel) == pytest.approx(0.930483, rel=2e-3)
    assert np.interp(780e-9, grid, rel) == pytest.approx(241.675, rel=2e-3)


def test_nothing_beyond_the_silicon_cutoff():
    # A filter entirely beyond 1.107 um passes no detectable light.
    assert float(bg.background_photon_irradiance("halogen", 1e4, 1.1e-6, 0.05e-6, CONSTS)) < float(
        bg.background_photon_irradiance("halogen", 1e4, 1.05e-6, 0.05e-6, CONSTS))
    assert float(bg.background_photon_irradiance("halogen", 1e4, 1.2e-6 - 0.05e-6, 0.04e-6, CONSTS)) == 0.0


def test_fluorescent_has_no_near_infrared():
    assert float(bg.background_photon_irradiance("fluorescent", 1e4, 850e-9, 20e-9, CONSTS)) == 0.0
    # but halogen does: a lamp of the same illuminance puts far more light into the NIR band.
    assert float(bg.background_photon_irradiance("halogen", 1e4, 850e-9, 20e-9, CONSTS)) > 0.0


# --- The sensor's spectral response (pixel.collection_depth_m; docs/model.md "Background light")

def _alpha_per_m(x_m):
    """Silicon's absorption coefficient from the shipped table, read here: 4 pi k / lambda,
    log-interpolated between its points."""
    wl, k = _table("silicon_green2008.csv")
    return np.exp(np.interp(x_m, wl, np.log(4 * np.pi * k / wl)))


def test_a_depth_of_zero_is_the_flat_response_exactly_and_a_deep_diode_approaches_it():
    import jax

    for lamp in LAMPS:
        flat = bg.background_photon_irradiance(lamp, 1000.0, 850e-9, 0.0, CONSTS)
        assert float(bg.background_photon_irradiance(lamp, 1000.0, 850e-9, 0.0, CONSTS, 0.0)) == float(flat)
        deep = bg.background_photon_irradiance(lamp, 1000.0, 850e-9, 0.0, CONSTS, 1.0)  # 1 m absorbs every photon
        assert float(deep) == pytest.approx(float(flat), rel=1e-6)
    # Traced (a fitted or differentiated depth), 0 is still the flat response, to the bit.
    traced = jax.jit(lambda d: bg.background_photon_irradiance("halogen", 1000.0, 850e-9, 0.0, CONSTS, d))
    plain = jax.jit(lambda: bg.background_photon_irradiance("halogen", 1000.0, 850e-9, 0.0, CONSTS))
    assert float(traced(0.0)) == float(plain())


def test_the_response_weights_the_photons_as_an_independent_integral_does():
    """Halogen (Planck, 3200 K) through a +-50 nm filter at 950 nm, a 5 um photodiode: tofjax's
    in-band photons over the flat response's against the same ratio integrated here,
    int P(l) l q(l) dl / int P(l) l dl with q = (1 - exp(-a d)) / (1 - exp(-a(950 nm) d)), to 1e-4."""
    x = np.linspace(900e-9, 1000e-9, 20001)
    planck = x**-5 / np.expm1(C.PLANCK_J_S * C.SPEED_OF_LIGHT_M_PER_S / (C.BOLTZMANN_J_PER_K * x * 3200.0))
    q = -np.expm1(-_alpha_per_m(x) * 5e-6) / -np.expm1(-_alpha_per_m(950e-9) * 5e-6)
    expected = np.trapezoid(planck * x * q, x) / np.trapezoid(planck * x, x)
    got = (bg.background_photon_irradiance("halogen", 1.0, 950e-9, 50e-9, CONSTS, 5e-6)
           / bg.background_photon_irradiance("halogen", 1.0, 950e-9, 50e-9, CONSTS))
    assert float(got) == pytest.approx(expected, rel=1e-4)
    assert abs(expected - 1.0) > 0.03  # the response matters across the band (q from 1.87 at 900 nm to 0.42 at 1000)


def test_a_thin_photodiode_responds_as_the_absorption_coefficient():
    """d -> 0: q(lambda) -> alpha(lambda) / alpha(lambda_0), here at the table's own points."""
    wl, k = _table("silicon_green2008.csv")
    at = wl[(wl > 400e-9) & (wl < 1100e-9)]
    q = np.asarray(bg.relative_response(at, 850e-9, 1e-14))  # alpha d < 1e-6 everywhere
    np.testing.assert_allclose(q, np.interp(at, wl, k / wl) / np.interp(850e-9, wl, k / wl), rtol=1e-6)


def test_the_background_electrons_follow_the_response_through_the_chain_with_a_gradient():
    """predict's background electrons scale by the in-band photons' ratio; d(depth noise)/d(depth)
    against a central difference."""
    import equinox as eqx
    import jax

    import dataclasses

    halogen = dataclasses.replace(tofjax.Params(), scene=dataclasses.replace(tofjax.Params().scene, background="halogen"))

    def params(depth):
        return eqx.tree_at(lambda q: q.pixel.collection_depth_m, halogen, depth)

    sweep = tofjax.Sweep("illuminance", [1000.0])
    ratio = (bg.background_photon_irradiance("halogen", 1.0, 850e-9, 0.0, CONSTS, 20e-6)
             / bg.background_photon_irradiance("halogen", 1.0, 850e-9, 0.0, CONSTS))
    deep, flat = (tofjax.predict(params(d), sweep).noise.background_e for d in (20e-6, 0.0))
    np.testing.assert_allclose(deep, ratio * flat, rtol=1e-12)

    def noise(depth):
        return tofjax.predict(params(depth), sweep).depth_std_m[0]

    h = 1e-8
    fd = (noise(20e-6 + h) - noise(20e-6 - h)) / (2 * h)
    np.testing.assert_allclose(jax.grad(noise)(20e-6), fd, rtol=1e-5)


def test_the_responsivity_and_the_collection_depth_must_agree():
    """QE(lambda) = QE(lambda_0) q(lambda) stays <= 1 only if QE(lambda_0) <= 1 - exp(-alpha(lambda_0) d):
    0.23 A/W at 850 nm (QE 0.335) needs d of at least 7.6 um; a shallower depth is refused in one line
    naming both keys, in the configuration and in the module."""
    import pytest

    table_m, alpha = bg.silicon_absorption_per_m()
    a = np.exp(np.interp(850e-9, table_m, np.log(alpha)))
    assert -np.expm1(-a * 7.6e-6) == pytest.approx(0.334, abs=0.001)  # just short of QE 0.335
    with pytest.raises(tofjax.ConfigError, match=r"pixel.photo_responsivity_a_per_w = 0.23 \(quantum efficiency 0.335 "
                                                  r".*pixel.collection_depth_m = 7.6e-06 absorbs there \(0.334\)"):
        tofjax.config_from_dict({"pixel": {"collection_depth_m": 7.6e-6}})
    tofjax.config_from_dict({"pixel": {"collection_depth_m": 7.7e-6}})
    with pytest.raises(ValueError, match=r"allowed 0 < value <= 0.06944 A/W, or a deeper collection depth"):
        tofjax.Params(pixel=tofjax.Pixel(collection_depth_m=2e-6))
