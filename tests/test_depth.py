"""Phase, amplitude and depth statistics (thesis §2.1.1.1, §3.3.3, §5.4)."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import tofjax
from tofjax import _depth


@pytest.mark.parametrize("n", [2, 3, 4, 5])
def test_estimator_recovers_phase_and_amplitude_of_a_cosine(n):
    theta = tofjax.waveforms.phase_steps(n)
    phi = np.linspace(0, 2 * np.pi, 37, endpoint=False)
    values = 123.0 * np.cos(phi[:, None] - theta[None, :])
    z = _depth.demodulate(jnp.asarray(values))
    np.testing.assert_allclose(_depth.phase_rad(z), phi, atol=1e-12)
    np.testing.assert_allclose(_depth.amplitude(z, n), 123.0, rtol=1e-12)


def test_four_phase_matches_thesis_eq_2_2_and_2_4():
    q = jnp.array([300.0, -120.0, -250.0, 90.0])  # Q0, Q90, Q180, Q270
    z = _depth.demodulate(q)
    # Eqs 2.2/2.4 in this sign convention: phi = atan2(Q90 - Q270, Q0 - Q180), A = sqrt(...) / 2.
    assert float(_depth.phase_rad(z)) == pytest.approx(np.mod(np.arctan2(-120 - 90, 300 + 250), 2 * np.pi))
    assert float(_depth.amplitude(z, 4)) == pytest.approx(np.hypot(-120 - 90, 300 + 250) / 2)


def test_circular_statistics_are_free_of_wrap_outliers():
    rng = np.random.default_rng(0)
    sigma = 0.05
    dev = sigma * rng.standard_normal(5000)
    phases = np.mod(dev, 2 * np.pi)  # around 0: half of them wrap to ~2 pi
    mean, std, n = _depth.circular_stats(jnp.asarray(phases)[None], jnp.ones((1, 5000), bool))
    assert int(n[0]) == 5000
    assert float(std[0]) == pytest.approx(np.std(dev, ddof=1), rel=1e-9)
    assert min(float(mean[0]), 2 * np.pi - float(mean[0])) == pytest.approx(abs(np.mean(dev)), abs=1e-12)
    naive = np.std(phases, ddof=1)
    assert naive > 50 * float(std[0])  # what Fig 5.7(a) suffers from


def test_statistics_use_valid_frames_only_and_flag_empty_rows():
    x = jnp.array([[1.0, 2.0, 100.0, 3.0], [1.0, 2.0, 3.0, 4.0]])
    valid = jnp.array([[True, True, False, True], [True, False, False, False]])
    mean, std = _depth.masked_mean_std(x, valid)
    assert float(mean[0]) == pytest.approx(2.0) and float(std[0]) == pytest.approx(1.0)
    assert np.isnan(mean[1]) and np.isnan(std[1])  # fewer than two valid frames: NaN, never 0


def test_unwrap_along_sweep_steps_over_invalid_samples():
    true = np.linspace(0.2, 9.0, 60)
    wrapped = np.mod(true, 2 * np.pi)
    valid = np.ones(60, bool)
    valid[[0, 1, 20, 21, 22, 40]] = False
    out = np.asarray(_depth.unwrap_along_sweep(jnp.asarray(wrapped), jnp.asarray(valid)))
    np.testing.assert_allclose(out[valid], true[valid], atol=1e-12)
    assert np.all(np.isnan(out[~valid]))
    # Every sample valid (the fill is skipped): numpy's unwrap; under vmap (both branches) the same.
    all_valid = np.ones(60, bool)
    np.testing.assert_allclose(np.asarray(_depth.unwrap_along_sweep(jnp.asarray(wrapped), jnp.asarray(all_valid))),
                               np.unwrap(wrapped), atol=1e-12)
    both = jax.vmap(_depth.unwrap_along_sweep)(jnp.asarray([wrapped, wrapped]), jnp.asarray([valid, all_valid]))
    np.testing.assert_array_equal(np.asarray(both[0]), out)
    np.testing.assert_allclose(np.asarray(both[1]), true, atol=1e-12)


def test_phase_of_zero_has_zero_gradient_not_nan():
    g = jax.grad(lambda v: _depth.phase_rad(_depth.demodulate(v)) + _depth.amplitude(_depth.demodulate(v), 4))(
        jnp.zeros(4))
    assert np.all(np.isfinite(g))


def test_rational_atan2_equals_numpy_everywhere():
    rng = np.random.default_rng(4)
    y, x = rng.standard_normal(200_000) * 10.0 ** rng.uniform(-8, 8, 200_000), rng.standard_normal(200_000)
    special = np.array([0.0, -0.0, 1.0, -1.0, 1e-300, np.inf])
    y = np.concatenate([y, np.repeat(special, 6)])
    x = np.concatenate([x, np.tile(special, 6)])
    ok = np.isfinite(x) & np.isfinite(y) & ((x != 0) | (y != 0))
    # (-pi, pi]: a negative zero y counts as zero (numpy returns -pi there).
    np.testing.assert_allclose(np.asarray(_depth.atan2(jnp.asarray(y[ok]), jnp.asarray(x[ok]))),
                               np.arctan2(y[ok] + 0.0, x[ok]), rtol=2e-16 * 4, atol=1e-15)
    assert float(_depth.atan2(jnp.asarray(0.0), jnp.asarray(0.0))) == 0.0
    # Near the top of the float range, where num + den of the pi/4 reduction would overflow.
    y, x = np.array([1e308, -1.2e308, 1.7e308, 9e307]), np.array([1.5e308, -1.7e308, 1.1e308, -1.6e308])
    np.testing.assert_allclose(np.asarray(_depth.atan2(jnp.asarray(y), jnp.asarray(x))), np.arctan2(y, x), rtol=1e-15)


@pytest.mark.parametrize("n", [2, 3, 4, 5])
def test_per_frame_phasor_is_the_demodulation(n):
    values = jnp.asarray(np.random.default_rng(n).normal(size=(n, 7, 3)))
    re, im = _depth.phasor(values)
    z = _depth.demodulate(jnp.moveaxis(values, 0, -1))
    np.testing.assert_allclose(re, jnp.real(z), atol=1e-12)
    np.testing.assert_allclose(im, jnp.imag(z), atol=1e-12)


@pytest.mark.parametrize("n", [2, 3, 4, 5])
def test_delta_method_without_signal_is_rayleigh_noise_and_a_uniform_phase(n):
    """Z = 0: the amplitude is the modulus of circular noise of s^2 = var n / 2 per quadrature
    (Rayleigh: mean s sqrt(pi / 2), variance (2 - pi / 2) s^2) and the phase uniform (pi^2 / 3)."""
    var = 2.5
    phase, var_phase, v, amp_mean, var_amp = _depth.delta_method(jnp.zeros(n), jnp.full(n, var), n)
    s2, k = var * n / 2, _depth.amplitude_scale(n)
    assert float(v) == np.inf and float(phase) == 0.0
    assert float(var_phase) == pytest.approx(np.pi**2 / 3, rel=1e-12)
    assert float(amp_mean) == pytest.approx(k * np.sqrt(0.5 * np.pi * s2), rel=1e-12)
    assert float(var_amp) == pytest.approx(k**2 * (2.0 - 0.5 * np.pi) * s2, rel=1e-12)


@pytest.mark.parametrize("n", [2, 4, 5])
def test_delta_method_matches_sampled_phase_images(n):
    """Closed-form phase and amplitude statistics against 400 000 sampled frames of independent
    Gaussian phase images, at SNRs from the delta method's home (v = 1e-3) to where the phase wraps
    (v = 0.5); the phase statistic is the wrapped deviation's, as the Monte Carlo takes it. Equal
    variances (the chain's case away from limits: the taps' charges add to the same total in every
    phase image) make the noise circular and the closed form exact at every SNR; unequal ones (the
    chain near a limit) leave it exact to second order, within 2 % at v = 0.05."""
    theta = tofjax.waveforms.phase_steps(n)
    rng = np.random.default_rng(7)
    for v_target, var in ((1e-3, np.ones(n)), (0.05, np.ones(n)), (0.5, np.ones(n)), (0.05, np.linspace(0.7, 1.3, n))):
        amp = np.sqrt(np.mean(var) / v_target / (n / 2 if n > 2 else 1.0))
        values = amp * np.cos(0.7 - theta)
        phase, var_phase, v, amp_mean, var_amp = _depth.delta_method(jnp.asarray(values), jnp.asarray(var), n)
        z0 = values @ np.exp(1j * theta)
        assert float(v) == pytest.approx(np.sum(var * np.sin(theta - np.angle(z0)) ** 2) / abs(z0) ** 2, rel=1e-9)
        frames = values + np.sqrt(var) * rng.standard_normal((400_000, n))
        z = frames @ np.exp(1j * theta)
        dev = np.angle(z * np.exp(-1j * float(phase)))
        assert float(var_phase) == pytest.approx(np.mean(dev**2), rel=0.02)
        assert float(amp_mean) == pytest.approx(_depth.amplitude_scale(n) * np.mean(np.abs(z)), rel=2e-3)
        assert float(np.sqrt(var_amp)) == pytest.approx(_depth.amplitude_scale(n) * np.std(np.abs(z)), rel=0.01)
