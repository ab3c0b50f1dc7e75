"""The ADC (thesis §3.3.1-3.3.2, §4.2.15): quantiser, errors, DNL, rails, smooth mode."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import tofjax
from tofjax import _adc
from tofjax._stages import Samples

IDEAL = tofjax.ADC(offset_error_lsb=0.0, gain_error_percent_fsr=0.0, integral_nonlinearity_lsb=0.0,
                   differential_nonlinearity_lsb=0.0)


def test_fsr_and_lsb():
    adc = tofjax.ADC()
    assert float(adc.v_ref_v) == pytest.approx(0.8)
    assert float(adc.lsb_v) == pytest.approx(1.6 / 4096)


def test_ideal_quantiser_rounds_to_the_nearest_code_and_clips():
    v = np.linspace(-1.0, 1.0, 20001)
    code = np.asarray(_adc.quantize(IDEAL, _adc.code_position(IDEAL, v)))
    q = 1.6 / 4096
    expected = np.clip(np.floor(v / q + 0.5) + 2048, 0, 4095)
    np.testing.assert_array_equal(code, expected)
    inside = np.abs(v) < 0.79
    assert np.max(np.abs((code - 2048) * q - v)[inside]) <= q / 2 + 1e-15  # |error| <= q/2
    sat = np.asarray(_adc.saturated(IDEAL, _adc.code_position(IDEAL, v)))
    np.testing.assert_array_equal(sat, (expected == 0) | (expected == 4095))


def test_offset_and_gain_errors():
    adc = tofjax.ADC(offset_error_lsb=30.0, gain_error_percent_fsr=5.0, integral_nonlinearity_lsb=0.0,
                     differential_nonlinearity_lsb=0.0)
    v = jnp.array([0.0, 0.2])
    u = _adc.code_position(adc, v)
    assert float(u[0]) == pytest.approx(2048 + 30)
    assert float(u[1] - u[0]) == pytest.approx(0.2 / float(adc.lsb_v) * 1.05)


def test_inl_bow_peaks_at_mid_scale_and_vanishes_at_the_ends():
    adc = tofjax.ADC(offset_error_lsb=0.0, gain_error_percent_fsr=0.0, integral_nonlinearity_lsb=10.0,
                     differential_nonlinearity_lsb=0.0)
    ideal = lambda v: float(_adc.code_position(IDEAL, v))  # noqa: E731
    assert float(_adc.code_position(adc, 0.0)) - ideal(0.0) == pytest.approx(10.0)
    assert float(_adc.code_position(adc, 0.8)) - ideal(0.8) == pytest.approx(0.0, abs=1e-9)


def test_dnl_step_widths_within_bounds_no_missing_codes_monotone():
    dnl = 0.8
    adc = tofjax.ADC(offset_error_lsb=0.0, gain_error_percent_fsr=0.0, integral_nonlinearity_lsb=0.0,
                     differential_nonlinearity_lsb=dnl)
    u = np.linspace(-2, 4100, 4102 * 200 + 1)
    code = np.asarray(_adc.quantize(adc, jnp.asarray(u)))
    assert np.all(np.diff(code) >= 0)
    assert set(np.unique(code)) == set(range(4096))  # no missing codes
    edges = u[1:][np.diff(code) > 0]
    widths = np.diff(edges)[:-1]
    assert np.max(np.abs(widths - 1)) <= dnl + 0.01
    assert np.max(np.abs(widths - 1)) > 0.5 * dnl  # the DNL does act


def test_smooth_quantiser_is_the_expected_code_under_gaussian_noise():
    """Independent check: average the hard quantiser over Gaussian input noise of the temperature."""
    adc = tofjax.ADC(offset_error_lsb=0.0, gain_error_percent_fsr=0.0, integral_nonlinearity_lsb=0.0,
                     differential_nonlinearity_lsb=0.6)
    tau = 0.35
    u = jnp.linspace(1000.0, 1003.0, 13)
    noise = tau * jax.random.normal(jax.random.key(3), (200_000, 1))
    mc = jnp.mean(_adc.quantize(adc, u[None, :] + noise), axis=0)
    smooth = _adc.quantize(adc, u, jnp.asarray(tau))
    np.testing.assert_allclose(smooth, mc, atol=5e-3)  # MC error ~ 0.5 / sqrt(2e5) ~ 1e-3


def test_smooth_quantiser_tends_to_hard_and_has_finite_gradients():
    adc = tofjax.ADC()  # DNL 0.8 LSB: edges move by up to 0.4 LSB
    u = jnp.linspace(-5.0, 4100.0, 50001)
    hard = _adc.quantize(adc, u)
    # Only edges c = floor(u) and floor(u) + 1 can lie within 0.1 LSB of u (|delta_c| <= 0.4).
    candidates = jnp.floor(u)[:, None] + jnp.array([[0.0, 1.0]])
    nearest = jnp.min(jnp.abs(u[:, None] - _adc._edge(adc, candidates)), axis=1)
    far = nearest > 0.02
    errors = [float(jnp.max(jnp.abs(_adc.quantize(adc, u, jnp.asarray(t)) - hard)[far])) for t in (0.1, 0.01, 0.003)]
    assert errors[0] > errors[1] > errors[2] and errors[2] < 1e-9
    g = jax.vmap(jax.grad(lambda x: _adc.quantize(adc, x, jnp.asarray(0.3))))(u)
    assert np.all(np.isfinite(g)) and np.all(np.asarray(g) >= 0)


def test_disabled_adc_is_the_ideal_continuous_readout():
    adc = tofjax.ADC(enabled=False)
    v = jnp.array([-2.0, 0.1, 2.0])
    u = _adc.code_position(adc, v)
    np.testing.assert_allclose(_adc.quantize(adc, u), 2048 + v / (1.6 / 4096))
    assert not np.any(_adc.saturated(adc, u))


@pytest.mark.parametrize("dnl", [0.0, 0.8, 0.999])
def test_the_hard_codes_are_at_a_rail_exactly_where_the_code_positions_saturate(dnl):
    """The Monte Carlo reads the ADC's flags from its codes (``Readout.saturated_codes``): the hard
    quantiser's code is 0 or the top code exactly where :func:`saturated` finds u outside the first
    and last edges, for any DNL below 1 LSB (the largest allowed, 0.999, moves an edge by almost 1/2).
    A 6-bit ADC puts many DNL patterns' edges near both rails; u densely around both ends, on the two
    edges and just below them, through the readout stage (phase images on the first axis)."""
    adc = tofjax.ADC(resolution_bits=6, offset_error_lsb=0.3, integral_nonlinearity_lsb=1.5,
                     differential_nonlinearity_lsb=dnl)
    top = _adc.max_code(adc)
    edges = np.asarray([_adc._edge(adc, jnp.asarray(c)) for c in (1.0, top)])
    u = jnp.asarray(np.concatenate([np.linspace(-3.0, 4.0, 7001), np.linspace(top - 4.0, top + 3.0, 7001),
                                    edges, np.nextafter(edges, -np.inf)]))
    codes = _adc.quantize(adc, u)
    expected = np.asarray(_adc.saturated(adc, u))
    np.testing.assert_array_equal(_adc.saturated_code(adc, codes), expected)
    assert 0 < expected.sum() < expected.size and set(np.asarray(codes)[expected]) == {0.0, top}
    # The stage, per frame over 4 phase images: its flags from the codes equal those from u.
    readout = _adc.Readout(adc, 1.0 / adc.lsb_v)
    assert readout.codes_show_saturation and not _adc.Readout(adc, 1.0 / adc.lsb_v, jnp.asarray(0.3)).codes_show_saturation
    diff = jnp.asarray(np.random.default_rng(2).uniform(-36.0, 36.0, (4, 5000)))  # in LSB: past both rails
    frames = readout.sample(Samples(diff))
    assert 0 < int(frames.adc_saturated.sum()) < 5000
    np.testing.assert_array_equal(readout.saturated_codes(frames.codes), frames.adc_saturated)
    off = tofjax.ADC(enabled=False)
    assert not np.any(_adc.saturated_code(off, _adc.quantize(off, u)))


@pytest.mark.parametrize("dnl", [0.0, 0.4, 0.8])
def test_quantization_variance_matches_a_dithered_measurement(dnl):
    """Independent: the variance of code - u for u spread uniformly over many codes."""
    adc = tofjax.ADC(offset_error_lsb=0.0, gain_error_percent_fsr=0.0, integral_nonlinearity_lsb=0.0,
                     differential_nonlinearity_lsb=dnl)
    u = jnp.asarray(np.random.default_rng(1).uniform(100.0, 3900.0, 400_000))
    measured = np.mean(np.asarray(_adc.quantize(adc, u) - u) ** 2)
    assert float(_adc.quantization_variance_lsb2(adc)) == pytest.approx(measured, rel=0.01)  # MC: ~0.3 %
    if dnl == 0.0:
        assert float(_adc.quantization_variance_lsb2(adc)) == pytest.approx(1 / 12, rel=1e-9)


@pytest.mark.parametrize("enabled", [True, False])
def test_readout_stage_matches_the_adc_functions_and_their_derivatives(enabled):
    """The readout's folded per-frame position, and its slopes, are those of the ADC functions."""
    adc = tofjax.ADC(enabled=enabled)
    readout = _adc.Readout(adc, jnp.asarray(14e-15 / 1.602176634e-19))
    charge = jnp.linspace(-9e4, 9e4, 41)
    v = charge / readout.electrons_per_volt
    np.testing.assert_allclose(readout.position(charge), _adc.code_position(adc, v), rtol=1e-13, atol=1e-10)
    slope = jax.vmap(jax.grad(lambda x: _adc.code_position(adc, x)))(v)
    np.testing.assert_allclose(_adc.code_position_slope(adc, v), slope, rtol=1e-12)
    for t in (None, jnp.asarray(0.3)):
        stage = _adc.Readout(adc, readout.electrons_per_volt, t)
        code, dcode, u, du = stage.linearize(charge)

        def expected_code(c, t=t):
            return _adc.expected_code(adc, _adc.code_position(adc, c, readout.electrons_per_volt), t)

        np.testing.assert_allclose(code, jax.vmap(expected_code)(charge), rtol=1e-13)
        np.testing.assert_allclose(dcode, jax.vmap(jax.grad(expected_code))(charge), rtol=1e-9, atol=1e-15)
        np.testing.assert_allclose(u, readout.position(charge), rtol=1e-13)  # the frames' position (vs v: above)
        np.testing.assert_allclose(du, slope / readout.electrons_per_volt, rtol=1e-12)
