"""One camera, two verbs (tofjax._camera): tj.predict(camera, scene) and tj.simulate(camera, scene, key,
frames) for sweeps, several frequencies and frames, and the two explicit preparations
(camera.expose(scene), camera.prepare()); they work under jit, vmap and grad; bad input is one clear
line."""

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

import tofjax as tj
from tofjax import scenes

PITCH = 17.5e-6
COLS, ROWS = 31, 21  # tests/test_frame.py's small camera: the same compiled programs


def _small(config):
    return eqx.tree_at(lambda c: c.params.camera.optical_area_m, tj.Camera.from_config(config),
                       jnp.array([COLS * PITCH, ROWS * PITCH]))


SWEEP = tj.Sweep.linspace("distance", 0.5, 4.0, 7)


def test_a_camera_of_the_configuration_runs_sweeps_as_the_sweep_functions():
    config = tj.Config()
    camera = tj.Camera.from_config(config)
    assert camera.frequencies_hz == () and not camera.multifrequency and camera.pattern is None
    for name, x in (("predict", tj.predict(camera, SWEEP)), ("simulate", tj.simulate(camera, SWEEP, jax.random.key(2), 64))):
        old = (tj.predict(config.params, SWEEP) if name == "predict"
               else tj.simulate(config.params, SWEEP, jax.random.key(2), 64))
        for field in ("depth_mean_m", "depth_std_m", "amplitude_mean_lsb", "valid_fraction"):
            np.testing.assert_array_equal(getattr(x, field), getattr(old, field), err_msg=f"{name} {field}")
    # Kept frames and their raw phase images through the verb.
    kept = tj.simulate(camera, SWEEP, jax.random.key(2), 64, keep_frames=4, raw=True)
    assert kept.frames_tap_a_e.shape == kept.codes.shape == (7, 4, 4)


def test_several_frequencies_are_one_camera():
    config = tj.config_from_dict({"illumination_waveform": {"extra_modulation_frequencies_hz": [60.24e6]}})
    camera = tj.Camera.from_config(config)
    assert camera.multifrequency and camera.frequencies_hz == (80.32e6, 60.24e6)
    fused = tj.predict(camera, SWEEP)
    # Inverse-variance fusion of the frequencies' own depth noise: sigma = 1 / sqrt(sum 1 / sigma_i^2).
    alone = [tj.predict(eqx.tree_at(lambda p: p.illumination_waveform.modulation_frequency_hz, config.params, f),
                        SWEEP).depth_std_m for f in camera.frequencies_hz]
    np.testing.assert_allclose(fused.depth_std_m, 1 / np.sqrt(sum(1 / np.asarray(s) ** 2 for s in alone)), rtol=1e-12)
    assert np.all(np.asarray(fused.depth_std_m) < np.minimum(*alone))
    # 2000 frames: the program of test_compare's fused noise (inverse-variance), built once for both.
    assert isinstance(tj.simulate(camera, SWEEP, jax.random.key(0), 2000), tj.MultiFrequencyResult)
    # A frame of the two frequencies is a fused frame (tofjax/_multiframe.py; tests/test_multifrequency.py).
    assert float(tj.predict(camera, scenes.wall(1.3)).result.unambiguity_range_m) == pytest.approx(7.465, abs=1e-3)


def test_frames_of_a_scene_depth_map_or_returns():
    camera = _small(tj.Config())
    returns = camera.returns(scenes.wall(1.3, 0.9))
    an = tj.predict(camera, returns)
    assert isinstance(an, tj.FrameResult) and an.depth_std_m.shape == (ROWS, COLS)
    np.testing.assert_allclose(tj.predict(camera, scenes.wall(1.3, 0.9)).depth_std_m, an.depth_std_m, rtol=1e-13)
    np.testing.assert_allclose(camera.expose(returns).noise_image(), an.depth_std_m, rtol=1e-12)
    depth = tj.predict(camera, np.full((ROWS, COLS), 1.3))  # a depth map: Z depth, reflectivity 0.9
    assert depth.depth_std_m.shape == (ROWS, COLS) and np.all(np.isfinite(depth.depth_std_m))
    # The verb's kept frames are those the prepared camera streams and the exposed scene samples.
    mc = tj.simulate(camera, returns, jax.random.key(1), 2, keep_frames=2)
    streamed = camera.prepare().sample(returns, jax.random.key(1), 2)
    np.testing.assert_allclose(streamed.radial_m, mc.frames_radial_m, rtol=1e-15)
    np.testing.assert_array_equal(camera.expose(returns).sample(jax.random.key(1), 2).valid,
                                  mc.result.valid.transpose(2, 0, 1))


def test_the_verbs_work_under_jit_vmap_and_grad():
    camera = tj.Camera.from_config(tj.Config())
    jitted = jax.jit(lambda c: tj.predict(c, SWEEP).depth_std_m)(camera)
    np.testing.assert_allclose(jitted, tj.predict(camera, SWEEP).depth_std_m, rtol=1e-12)
    powers = jnp.array([0.6, 1.2, 2.4])
    cameras = jax.vmap(lambda w: eqx.tree_at(lambda c: c.params.illumination.peak_power_w, camera, w))(powers)
    batch = jax.vmap(lambda c: tj.predict(c, SWEEP).depth_std_m)(cameras)
    for i, w in enumerate(powers):
        one = eqx.tree_at(lambda c: c.params.illumination.peak_power_w, camera, w)
        np.testing.assert_allclose(batch[i], tj.predict(one, SWEEP).depth_std_m, rtol=1e-12)

    def noise(w):
        return jnp.sum(tj.predict(eqx.tree_at(lambda c: c.params.illumination.peak_power_w, camera, w),
                                  SWEEP).depth_std_m)

    slope = jax.grad(noise)(1.2)
    h = 1e-4
    assert float(slope) < 0 and float(slope) == pytest.approx(float((noise(1.2 + h) - noise(1.2 - h)) / (2 * h)),
                                                              rel=1e-5)


@pytest.mark.parametrize("call, error, message", [
    (lambda c: tj.predict(c, "wall"), TypeError, r"^scene must be a tofjax.Sweep, tofjax.Returns, .* got str$"),
    (lambda c: tj.predict(c.params.pixel, SWEEP), TypeError, r"^camera must be a tofjax.Camera .* got Pixel$"),
    (lambda c: tj.predict(c, SWEEP, smooth=tj.Smooth()), ValueError, r"^smooth belongs to the camera"),
    (lambda c: tj.Camera(c.params, fusion="best"), ValueError, r"^Camera: fusion = 'best' is not allowed"),
    (lambda c: tj.Camera(c.params, frequencies_hz=(80e6,)), ValueError, r"^Camera: frequencies_hz = \[80000000.0\]"),
    (lambda c: tj.Camera(c.settings), TypeError, r"^Camera: params must be a tofjax.Params, got FrameSettings$"),
    (lambda c: tj.simulate(c, SWEEP, jax.random.key(0), 0), ValueError, r"^frames = 0 is out of range: allowed integer"),
])
def test_bad_input_is_one_line(call, error, message):
    with pytest.raises(error, match=message):
        call(tj.Camera())


def test_one_pattern_door_a_swept_pixel_is_the_one_pixel_frame_with_its_sample():
    """A camera's pattern acts on sweeps as on frames: a pattern of one pixel (tj.draw_pattern(...,
    (1, 1))) makes the swept centre pixel that pixel, and a sweep equals the frame of one pixel on
    the axis looking at a wall, to rounding: gain, dark slopes, phase offset, tap asymmetry and full
    well all act. A pattern of several pixels is refused for a sweep; fixed_pattern and pattern
    together too."""
    config = tj.config_from_dict({"frame": {"prnu_sigma": 0.1, "phase_offset_sigma_rad": 0.2, "subpixel_samples": 1,
                                            "tap_asymmetry_sigma": 0.05, "threshold_sigma": 0.1, "seed": 3}})
    params = eqx.tree_at(lambda p: p.camera.optical_area_m, config.params, jnp.array([PITCH, PITCH]))  # 1 x 1
    settings = config.frame
    pattern = tj.draw_pattern(params, settings, (1, 1))
    assert abs(float(pattern.gain[0, 0]) - 1) > 0.01 and abs(float(pattern.phase_offset_rad[0, 0])) > 0.01
    camera = tj.Camera(params, settings, pattern=pattern)
    d = 1.3
    frame = tj.predict(camera, np.full((1, 1), d)).result
    swept = tj.predict(camera, tj.Sweep("distance", [d]))
    mean = tj.predict(tj.Camera(params, settings), tj.Sweep("distance", [d]))
    for field in ("tap_a_e", "tap_b_e", "depth_mean_m", "depth_std_m", "amplitude_mean_lsb", "intensity_e",
                  "full_well_fraction"):
        np.testing.assert_allclose(np.asarray(getattr(swept, field))[0], np.asarray(getattr(frame, field))[0, 0],
                                   rtol=1e-12, err_msg=field)
        assert not np.allclose(getattr(swept, field), getattr(mean, field), rtol=1e-6), field  # the pattern acts
    mc = tj.simulate(camera, tj.Sweep("distance", [d]), jax.random.key(0), 400)
    np.testing.assert_allclose(mc.depth_mean_m, swept.depth_mean_m, atol=5 * float(swept.depth_std_m[0]) / 20)
    big = tj.Camera(tj.Params(), pattern=tj.draw_pattern(tj.Params(), settings, (2, 2)))
    with pytest.raises(ValueError, match=r"^a sweep's pixel sample is a pattern of one pixel, got \(2, 2\)"):
        tj.predict(big, SWEEP)
    with pytest.raises(ValueError, match=r"^give fixed_pattern or pattern, not both"):
        tj.simulate(params, SWEEP, jax.random.key(0), 8, fixed_pattern=True, pattern=pattern)
