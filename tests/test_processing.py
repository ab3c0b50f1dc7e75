"""The camera's own processing (tofjax.processing): each stage's rule for the samples against an
independent NumPy computation, each closed form against its frames (sweeps: a uniform patch; frames:
the image), the calibration against the true distance, and a camera without processing unchanged."""

import math

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest
from helpers import fd_check, small

import tofjax as tj
from tofjax import processing as P
from tofjax._filters import MEDIAN_NEIGHBOUR_CORRELATION
from tofjax._stages import Samples

RNG = np.random.default_rng(7)


def _wrap(x):
    return np.pi - np.mod(np.pi - x, 2 * np.pi)


def test_median_variance_is_that_of_the_median_of_normal_samples():
    for n in (2, 3, 4, 9, 24, 25):
        x = RNG.standard_normal((200_000, n))
        sampled = np.var(np.median(x, axis=1))
        assert float(P.median_variance(n)) == pytest.approx(sampled, rel=0.012), n  # 4 standard errors
    assert float(P.median_variance(2)) == pytest.approx(0.5, abs=1e-9)  # the mean of two
    assert float(P.median_variance(1)) == 1.0


def test_median_neighbour_correlation_is_that_of_overlapping_windows():
    from numpy.lib.stride_tricks import sliding_window_view

    for k, (side, diagonal) in MEDIAN_NEIGHBOUR_CORRELATION.items():
        x = RNG.standard_normal((40_000, k + 1, k + 1))
        med = np.median(sliding_window_view(x, (k, k), axis=(1, 2)).reshape(40_000, 2, 2, -1), axis=-1)
        assert np.corrcoef(med[:, 0, 0], med[:, 0, 1])[0, 1] == pytest.approx(side, abs=0.02), k
        assert np.corrcoef(med[:, 0, 0], med[:, 1, 1])[0, 1] == pytest.approx(diagonal, abs=0.02), k


def test_the_median_of_neighbours_of_different_depths_is_that_of_their_samples():
    """The analytic frame's median filter (tofjax._filters.median_moments) against 4000 samples of each
    of 200 random 3 x 3 neighbourhoods (some neighbours missing), their expected depths spread by 0
    (a flat wall) or 10 (an edge) of their noise: the mean within 0.1 of the median's own noise, and the
    variance of an odd count's median within 5 % at the median of the neighbourhoods."""
    from tofjax._filters import median_moments

    for spread in (0.0, 10.0):
        mu, sd = RNG.normal(0.0, spread, (9, 200)), RNG.uniform(0.5, 1.5, (9, 200))
        ok = RNG.random((9, 200)) > 0.1
        draws = np.where(ok[..., None], mu[..., None] + sd[..., None] * RNG.standard_normal((9, 200, 4000)), np.nan)
        sampled = np.nanmedian(draws, axis=0)
        mean, var = (np.asarray(x) for x in median_moments(*([jnp.asarray(r) for r in a] for a in (mu, sd, ok))))
        odd = (ok.sum(0) % 2 == 1) & (ok.sum(0) >= 3)
        assert np.median(np.abs(mean - sampled.mean(-1)) / sampled.std(-1)) < 0.1
        assert np.median(var[odd] / sampled.var(-1)[odd]) == pytest.approx(1.0, abs=0.05), spread


def _frames(shape=(3, 6, 7)):
    """Frames of phases that straddle the wrap (+-pi) with holes: what a camera's filter sees."""
    phase = _wrap(np.pi + 0.4 * RNG.standard_normal(shape))
    valid = RNG.random(shape) > 0.2
    amplitude = 50.0 + 20.0 * RNG.standard_normal(shape)
    return phase, valid, amplitude


def _neighbourhood(x, r, i, j):
    rows, cols = x.shape[-2:]
    return [(a, b) for a in range(i - r, i + r + 1) for b in range(j - r, j + r + 1) if 0 <= a < rows and 0 <= b < cols]


@jax.jit
def _sample(stage, phase, valid, amplitude):
    return stage.sample(Samples(None, phase=phase, amplitude=amplitude, valid=valid))


@pytest.mark.parametrize("kind", ["box", "median"])
def test_spatial_filter_combines_the_delivered_neighbours_around_the_pixel(kind):
    phase, valid, amplitude = _frames()
    out = _sample(P.SpatialFilter(kind, 5), jnp.asarray(phase), jnp.asarray(valid), jnp.asarray(amplitude))
    expected = np.empty_like(phase)
    for f in range(phase.shape[0]):
        for i in range(phase.shape[1]):
            for j in range(phase.shape[2]):
                devs = [_wrap(phase[f, a, b] - phase[f, i, j]) for a, b in _neighbourhood(phase, 2, i, j) if valid[f, a, b]]
                shift = 0.0 if not devs else (np.mean(devs) if kind == "box" else np.median(devs))
                expected[f, i, j] = _wrap(phase[f, i, j] + shift)
    np.testing.assert_allclose(np.asarray(out.phase), expected, atol=1e-12)
    np.testing.assert_array_equal(np.asarray(out.valid), valid)  # a filter makes no pixel valid
    np.testing.assert_array_equal(np.asarray(out.amplitude), amplitude)


def test_temporal_average_is_the_mean_of_each_group_of_raw_frames():
    phase, valid, amplitude = _frames((6, 2, 3))
    out = _sample(P.TemporalAverage(3), jnp.asarray(phase), jnp.asarray(valid), jnp.asarray(amplitude))
    assert out.phase.shape == (2, 2, 3)
    for g in range(2):
        for i in range(2):
            for j in range(3):
                ok = valid[3 * g:3 * g + 3, i, j]
                p, a = phase[3 * g:3 * g + 3, i, j][ok], amplitude[3 * g:3 * g + 3, i, j][ok]
                assert bool(out.valid[g, i, j]) == bool(ok.any())
                if ok.any():
                    centre = np.angle(np.sum(np.exp(1j * p)))
                    assert float(out.phase[g, i, j]) == pytest.approx(_wrap(centre + np.mean(_wrap(p - centre))), abs=1e-12)
                    assert float(out.amplitude[g, i, j]) == pytest.approx(np.mean(a), rel=1e-12)


@pytest.mark.parametrize("needed", [1, 3])
def test_invalidation_rejects_low_amplitude_and_flying_pixels(needed):
    phase, valid, amplitude = _frames()
    to_m = 0.3  # metres per radian
    stage = P.Invalidation(45.0, 0.12, needed, to_m=jnp.asarray(to_m))
    out = _sample(stage, jnp.asarray(phase), jnp.asarray(valid), jnp.asarray(amplitude))
    expected = valid & (amplitude >= 45.0)
    for f in range(phase.shape[0]):
        for i in range(phase.shape[1]):
            for j in range(phase.shape[2]):
                differ = sum(1 for a, b in _neighbourhood(phase, 1, i, j) if (a, b) != (i, j) and valid[f, a, b]
                             and abs(_wrap(phase[f, a, b] - phase[f, i, j])) * to_m > 0.12)
                expected[f, i, j] &= differ < needed
    np.testing.assert_array_equal(np.asarray(out.valid), expected)


def test_calibration_removes_wiggling_and_offset_and_leaves_the_drift():
    """A noise-free camera with strong wiggling (25 % pulses), a phase offset and a drift: calibrated
    at 25 degC its reading is the true distance there, and off by the drift at 35 degC."""
    params = tj.config_from_dict({"pixel": {"noise": False, "phase_offset_rad": 0.6, "phase_drift_rad_per_c": 0.01}}).params
    d = np.linspace(0.35, 1.8, 12)
    sweep = tj.Sweep("distance", d)
    du = float(params.unambiguity_range_m)
    raw = tj.predict(tj.Camera(params), sweep)
    calibrated = tj.Camera(params, processing=(P.Calibration(temperature_c=25.0),))
    at_25 = tj.predict(calibrated, sweep)
    error_raw = _wrap(2 * np.pi * (np.asarray(raw.depth_mean_m) - d) / du) * du / (2 * np.pi)
    error_cal = _wrap(2 * np.pi * (np.asarray(at_25.depth_mean_m) - d) / du) * du / (2 * np.pi)
    assert np.ptp(error_raw) > 0.02  # the raw reading wiggles by centimetres ...
    np.testing.assert_allclose(error_cal, 0.0, atol=2e-5)  # ... the calibrated one lies on the truth
    warm = tj.predict(calibrated, tj.Sweep("temperature", np.full(3, 35.0)))
    drift_m = 0.01 * 10.0 * du / (2 * np.pi)  # 0.1 rad of phase
    assert float(warm.depth_mean_m[0]) - float(params.scene.distance_m) == pytest.approx(drift_m, abs=2e-5)


def _check_against_frames(analytic, mc, frames, valid_tol=0.03):
    """The closed form against the frames: the depth noise within 4 of its standard errors, the mean
    within 4 of its, the delivered fraction within ``valid_tol``."""
    a_sd, m_sd = np.asarray(analytic.depth_std_m), np.asarray(mc.depth_std_m)
    n = np.asarray(mc.valid_fraction) * frames
    ok = n > 200
    assert ok.sum() >= 3
    np.testing.assert_allclose(m_sd[ok], a_sd[ok], rtol=4.0 / np.sqrt(2.0 * n[ok].min()) + 0.01)
    se = a_sd[ok] / np.sqrt(n[ok])
    assert np.all(np.abs(np.asarray(mc.depth_mean_m)[ok] - np.asarray(analytic.depth_mean_m)[ok]) < 4.0 * se + 2e-5)
    np.testing.assert_allclose(np.asarray(mc.valid_fraction), np.asarray(analytic.valid_fraction), atol=valid_tol)


SWEEP = tj.Sweep.linspace("distance", 0.6, 2.6, 8)
FRAMES = 3000


def test_a_sweep_of_the_whole_processing_matches_its_frames():
    """Calibration, a 3 x 3 box, two frames averaged and both invalidations at once: the closed forms
    (a uniform patch) against the Monte Carlo of the patch, frame by frame. The delivered fraction
    within 0.08: after a spatial filter the closed form counts the neighbours that differ as
    independent given the pixel's own value, where their shared pixels correlate them (it delivers
    0.50 where the frames deliver 0.57; docs/model.md, "The camera's processing")."""
    stages = (P.Calibration(), P.SpatialFilter("box", 3), P.TemporalAverage(2),
              P.Invalidation(min_amplitude_lsb=60.0, flying_pixel_m=0.006))
    camera = tj.Camera(tj.Params(), processing=stages)
    analytic = tj.predict(camera, SWEEP)
    mc = tj.simulate(camera, SWEEP, jax.random.key(3), FRAMES)
    sensor = tj.predict(tj.Camera(tj.Params()), SWEEP)
    kept = np.asarray(analytic.valid_fraction)
    assert kept.max() > 0.9 and kept.min() < 0.3  # both invalidations act along the sweep
    assert np.all(np.asarray(analytic.depth_std_m)[kept > 0.5] < 0.6 * np.asarray(sensor.depth_std_m)[kept > 0.5])
    _check_against_frames(analytic, mc, FRAMES, valid_tol=0.08)


def test_invalidation_of_a_sweep_matches_its_frames():
    """Without a spatial filter the neighbours are independent: the delivered fraction within 0.02."""
    camera = tj.Camera(tj.Params(), processing=(P.TemporalAverage(2),
                                                P.Invalidation(min_amplitude_lsb=60.0, flying_pixel_m=0.012)))
    analytic = tj.predict(camera, SWEEP)
    kept = np.asarray(analytic.valid_fraction)
    assert kept.max() > 0.9 and kept.min() < 0.3
    _check_against_frames(analytic, tj.simulate(camera, SWEEP, jax.random.key(8), FRAMES), FRAMES, valid_tol=0.02)


def test_a_median_filter_of_a_sweep_matches_its_frames():
    camera = tj.Camera(tj.Params(), processing=(P.SpatialFilter("median", 5),))
    analytic = tj.predict(camera, SWEEP)
    sensor = tj.predict(tj.Camera(tj.Params()), SWEEP)
    np.testing.assert_allclose(np.asarray(analytic.depth_std_m) ** 2 / np.asarray(sensor.depth_std_m) ** 2,
                               float(P.median_variance(25)), rtol=1e-12)
    _check_against_frames(analytic, tj.simulate(camera, SWEEP, jax.random.key(4), FRAMES), FRAMES)


EDGE = tj.scenes.step_edge(1.0, 1.3, edge_x_m=0.013)


def test_a_frame_with_processing_matches_its_frames_and_delivers_the_edge():
    """A step edge with a median filter and the flying-pixel filter: the analytic image against 400
    Monte Carlo frames pixel by pixel (their median ratio, the delivered fraction: within 0.03 on
    average, the neighbours' mutual correlation after the filter left out as in the sweep's test),
    and the edge's flying pixels are the ones the camera rejects."""
    camera = tj.Camera(small(), processing=(P.SpatialFilter("median", 3), P.Invalidation(flying_pixel_m=0.05)))
    analytic = tj.predict(camera, EDGE)
    mc = tj.simulate(camera, EDGE, jax.random.key(5), 400)
    ratio = np.asarray(mc.depth_std_m) / np.asarray(analytic.depth_std_m)
    assert np.nanmedian(ratio) == pytest.approx(1.0, abs=0.04)
    a_valid, m_valid = np.asarray(analytic.result.valid_fraction), np.asarray(mc.result.valid_fraction)
    assert np.mean(np.abs(a_valid - m_valid)) < 0.03
    rejected = a_valid < 0.5
    assert 0 < rejected.sum() < 0.2 * rejected.size  # the edge, not the surfaces
    assert np.all(np.any(rejected, axis=1))  # in every row
    # The camera's own flag says so, and it alone removes them (the mixed pixels among them: the truth).
    flags = np.asarray(analytic.flags)
    np.testing.assert_array_equal((flags & 128) != 0, rejected)
    np.testing.assert_array_equal(np.asarray(analytic.delivered), ~rejected)
    frames = camera.expose(EDGE).sample(jax.random.key(6), 2)
    assert frames.radial_m.shape == (2,) + rejected.shape
    assert np.isnan(np.asarray(frames.radial_m))[:, rejected].mean() > 0.5


def test_the_flying_pixel_filter_of_a_frame_matches_its_frames():
    """Without a spatial filter each pixel's neighbours are independent with their own expected
    depths (the edge, the tilted far surface): the delivered fraction within 0.015 on average."""
    camera = tj.Camera(small(), processing=(P.Invalidation(flying_pixel_m=0.05),))
    analytic = tj.predict(camera, EDGE)
    mc = tj.simulate(camera, EDGE, jax.random.key(9), 400)
    a_valid, m_valid = np.asarray(analytic.result.valid_fraction), np.asarray(mc.result.valid_fraction)
    assert a_valid.min() < 0.1 and np.mean(a_valid < 0.9) > 0.1  # the edge, and the far surface's noise
    assert np.mean(np.abs(a_valid - m_valid)) < 0.015


def test_gradients_reach_the_processing_thresholds():
    base = tj.Camera(tj.Params(), processing=(P.Calibration(), P.SpatialFilter("median", 3),
                                              P.Invalidation(min_amplitude_lsb=60.0)))
    sweep = tj.Sweep("distance", [1.9])

    def delivered(threshold):
        camera = eqx.tree_at(lambda c: c.processing[2].min_amplitude_lsb, base, threshold)
        return tj.predict(camera, sweep).valid_fraction[0]

    fd_check(delivered, 60.0)

    def noise(contrast):
        camera = eqx.tree_at(lambda c: c.params.pixel.demodulation_contrast, base, contrast)
        return tj.predict(camera, sweep).depth_std_m[0]

    fd_check(noise, 0.42)
    assert float(jax.jit(noise)(0.42)) == pytest.approx(float(noise(0.42)), rel=1e-12)


def test_a_camera_without_processing_is_the_sensor_bit_for_bit():
    config = tj.config_from_dict({"processing": {}})
    assert config.processing == ()
    a = tj.predict(tj.Camera.from_config(config), SWEEP)
    b = tj.predict(tj.Params(), SWEEP)
    for x, y in zip(jax.tree_util.tree_leaves(a), jax.tree_util.tree_leaves(b), strict=True):
        np.testing.assert_array_equal(np.asarray(x), np.asarray(y))


def test_the_configuration_builds_the_stages_in_order():
    config = tj.config_from_dict({"processing": {"calibration": True, "calibration_temperature_c": 30.0,
                                                 "spatial_filter": "box", "spatial_filter_size": 5,
                                                 "temporal_average_frames": 4, "amplitude_threshold": True,
                                                 "flying_pixel_m": 0.02, "flying_pixel_neighbours": 2},
                                  "frame": {"min_amplitude_lsb": 12.0}})
    calibration, spatial, temporal, invalidation = tj.Camera.from_config(config).processing
    assert calibration.temperature_c == 30.0 and (spatial.kind, spatial.size) == ("box", 5)
    assert temporal.frames == 4
    assert (invalidation.min_amplitude_lsb, invalidation.flying_pixel_m, invalidation.flying_pixel_neighbours) \
        == (12.0, 0.02, 2)


@pytest.mark.parametrize("make, message", [
    (lambda: P.SpatialFilter("gauss", 3), "SpatialFilter: kind = 'gauss' is not allowed"),
    (lambda: P.SpatialFilter("box", 4), "SpatialFilter: size = 4 is out of range: allowed an odd integer"),
    (lambda: P.SpatialFilter("box", 9), "SpatialFilter: size = 9 is out of range"),
    (lambda: P.TemporalAverage(1), "TemporalAverage: frames = 1 is out of range"),
    (lambda: P.Invalidation(min_amplitude_lsb=-1.0), "min_amplitude_lsb = -1.0 is out of range"),
    (lambda: P.Invalidation(flying_pixel_m=0.0), "flying_pixel_m = 0.0 is out of range: allowed 0 < value"),
    (lambda: P.Invalidation(flying_pixel_m=math.nan), "flying_pixel_m = nan is out of range"),
    (lambda: P.Invalidation(flying_pixel_neighbours=0), "flying_pixel_neighbours = 0 is out of range"),
    (lambda: tj.config_from_dict({"processing": {"spatial_filter_size": 4}}),
     "processing.spatial_filter_size = 4 is out of range: allowed an odd integer"),
])
def test_bad_stages_are_refused_in_one_line(make, message):
    with pytest.raises(ValueError, match=message.replace("(", r"\(")):
        make()


def test_processing_must_be_a_tuple_of_stages():
    with pytest.raises(TypeError, match="processing must be a tuple"):
        tj.Camera(tj.Params(), processing=[P.Calibration()])
    with pytest.raises(TypeError, match="every stage must be a tofjax.processing stage, got int"):
        tj.Camera(tj.Params(), processing=(3,))
