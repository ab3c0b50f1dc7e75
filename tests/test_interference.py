"""Another camera's light in the scene (tofjax._interference; docs/model.md "Interference"): at the
same frequency it is one more return; at an offset whose drift spans whole periods in an integration
it carries no modulation, only light; in between, the drift's average against the correlation series
averaged in the test; the frame's axis pixel is the sweep's; Monte Carlo agrees; gradients."""

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

import tofjax as tj
from tofjax import scenes
from tofjax._correlation import correlation, drift_correlation, series
from tofjax._interference import averaged_fractions

from helpers import COLS, ROWS, small

ONE_RAY = tj.FrameSettings(subpixel_samples=1)
CENTRE = (ROWS // 2, COLS // 2)


def configured(**values):
    config = tj.Config().replace("interference.enabled", True)
    for key, value in values.items():
        config = config.replace(f"interference.{key}", value)
    return config


def test_at_the_same_frequency_the_other_camera_is_one_more_return():
    """Its light as a return of this camera's own: the path lengthened by its phase (phase c / (2 pi
    f)), the radiance scaled by its power and duty; the frame is the same to 1e-12."""
    params = small(configured(peak_power_w=0.6, phase_rad=1.0, duty=0.5).params)
    camera = tj.Camera(params, ONE_RAY)
    both = camera.returns(scenes.wall(1.3))
    mine, theirs = (np.asarray(both.source) == k for k in (0, 1))
    f, c = 80.32e6, float(params.constants.speed_of_light_m_per_s)
    extra = tj.Returns(both.path_m[..., theirs] + 1.0 * c / (2 * np.pi * f),
                       both.radiance_per_w[..., theirs] * 0.5 * 0.6 / 1.2, both.ambient_reflectivity, both.radial_m)
    own = tj.Returns(both.path_m[..., mine], both.radiance_per_w[..., mine], both.ambient_reflectivity, both.radial_m)
    plain = tj.Camera(small(), ONE_RAY)
    a, b = tj.predict(camera, both), tj.predict(plain, own + extra)
    for name in ("radial_m", "depth_std_m", "amplitude_lsb", "intensity_e"):
        np.testing.assert_allclose(getattr(a, name), getattr(b, name), rtol=1e-12, err_msg=name)
    assert abs(float(a.radial_m[CENTRE] - tj.predict(plain, own).radial_m[CENTRE])) > 1e-3  # a bias


def test_an_offset_spanning_whole_periods_adds_light_and_no_modulation():
    """df T = 2 (1 kHz over 2 ms): every harmonic averages to zero, so each tap gains the same
    electrons in every phase image (tap A K P_0 N_i + (1 - K) N_i / 2, tap B the rest of N_i, P_0 the
    reference's mean) and the reading (noise and ADC off) does not move; the noise grows (the shot
    noise of that light)."""
    config = configured(frequency_offset_hz=1000.0).replace("pixel.noise", False).replace("adc.enabled", False)
    sweep = tj.Sweep.linspace("distance", 0.5, 4.0, 5)
    off = dataclasses_replace(config.params, enabled=False)
    with_it, without = tj.predict(config.params, sweep), tj.predict(off, sweep)
    gain_a = np.asarray(with_it.tap_a_e - without.tap_a_e)
    gain_b = np.asarray(with_it.tap_b_e - without.tap_b_e)
    np.testing.assert_allclose(gain_a, gain_a[:, :1] * np.ones((1, 4)), rtol=1e-9)  # no phase image favoured
    np.testing.assert_allclose(gain_b, gain_b[:, :1] * np.ones((1, 4)), rtol=1e-9)
    p0 = float(jnp.real(correlation(config.params.illumination_waveform, config.params.reference_waveform,
                                    4).coefficients[0]))  # the reference's mean
    contrast = float(config.params.pixel.demodulation_contrast)
    np.testing.assert_allclose(gain_a - gain_b, contrast * (2 * p0 - 1) * (gain_a + gain_b), rtol=1e-9)
    np.testing.assert_allclose(with_it.depth_mean_m, without.depth_mean_m, atol=1e-12)
    noisy = configured(frequency_offset_hz=1000.0).params
    assert np.all(tj.predict(noisy, sweep).depth_std_m > tj.predict(dataclasses_replace(noisy, enabled=False),
                                                                        sweep).depth_std_m)


def dataclasses_replace(params, **changes):
    import dataclasses

    return dataclasses.replace(params, interference=dataclasses.replace(params.interference, **changes))


def test_the_drift_average_is_the_series_averaged_over_the_integration():
    """abar_j against the correlation series evaluated at 1001 instants of each phase image's
    integration (t_j = j (T + t_ro)) and averaged (Simpson), for offsets from 0 to 3 kHz: 1e-9."""
    p = tj.Params()
    wave, ref = p.illumination_waveform, p.reference_waveform
    table, drift = correlation(wave, ref, 4), drift_correlation(wave, ref, 4)
    delay, t_int, t_ro = 0.37, 2e-3, 1e-3
    offsets = np.array([0.0, 37.0, 250.0, 1234.5, 3000.0])
    got = np.stack([np.asarray(averaged_fractions(table, drift, jnp.asarray(delay), f, t_int, t_ro)) for f in offsets])
    t = np.arange(4)[:, None] * (t_int + t_ro) + np.linspace(0.0, t_int, 1001)[None, :]  # (phase image, instant)
    values = np.asarray(jax.jit(lambda x: series(wave, ref, 4, x))(jnp.asarray(delay - offsets[:, None, None] * t)))
    weights = np.ones(t.shape[1])
    weights[1:-1:2], weights[2:-1:2] = 4.0, 2.0
    averaged = np.einsum("n,fjnp->fjp", weights, values) / (3.0 * (t.shape[1] - 1))  # (offset, image, step)
    np.testing.assert_allclose(got, np.einsum("fjj->fj", averaged), atol=1e-9)


def test_the_frames_axis_pixel_is_the_sweeps_centre_pixel():
    """Two code paths, one physics: the frame's pixel on the axis and the sweep's centre pixel under
    the same interfering camera (100 Hz off, 20 cm to the side)."""
    config = configured(frequency_offset_hz=100.0, baseline_m=[0.2, 0.0], phase_rad=0.4)
    frame = tj.predict(tj.Camera(small(config.params), ONE_RAY), scenes.wall(1.3))
    point = tj.predict(config.params, tj.Sweep("distance", [1.3]))
    for name, field in (("radial_m", "depth_mean_m"), ("depth_std_m", "depth_std_m")):
        np.testing.assert_allclose(getattr(frame, name)[CENTRE], getattr(point, field)[0], rtol=1e-12)


def test_monte_carlo_with_an_interfering_camera_matches_the_analytic_noise():
    """2000 frames at 3 distances, 150 Hz off: the frames' std against the analytic one (4 % for 2000
    frames, 3 sigma)."""
    params = configured(frequency_offset_hz=150.0, phase_rad=2.0).params
    sweep = tj.Sweep.linspace("distance", 1.0, 3.0, 3)
    ratio = np.asarray(tj.simulate(params, sweep, jax.random.key(2), 2000).depth_std_m
                       / tj.predict(params, sweep).depth_std_m)
    assert np.all(np.abs(ratio - 1.0) < 3 * 1 / np.sqrt(2 * 1999)), ratio


def test_the_bias_has_a_gradient_in_the_other_cameras_phase():
    params = configured(phase_rad=0.7).params

    def depth(phase):
        p = eqx.tree_at(lambda q: q.interference.phase_rad, params, phase)
        return tj.predict(p, tj.Sweep("distance", [1.3])).depth_mean_m[0]

    h = 1e-6
    np.testing.assert_allclose(jax.grad(depth)(0.7), (depth(0.7 + h) - depth(0.7 - h)) / (2 * h), rtol=1e-6)


def test_another_cameras_light_needs_a_camera_that_expects_it():
    both = tj.Camera(small(configured().params), ONE_RAY).returns(scenes.wall(1.3))
    with pytest.raises(ValueError, match="include another camera's light .* interference.enabled is false"):
        tj.predict(tj.Camera(small(), ONE_RAY), both)
