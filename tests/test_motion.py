"""A camera in time: scenes that move during a frame (tofjax._motion; docs/model.md "A camera in time:
motion"). Each phase image is the scene where it stands then: against static frames at those
instants, a NumPy demodulation written here, and the band a moving edge sweeps. And the sensor
warming up: its phase drifts as a longer path ("Dark current and temperature")."""

import dataclasses

import equinox as eqx

import jax
import numpy as np
import pytest

import tofjax as tj
from tofjax import scenes
from tofjax._motion import instants_s
from tofjax._multiframe import _at

from helpers import COLS, ROWS, small

ONE_RAY = tj.FrameSettings(subpixel_samples=1)
CENTRE = (ROWS // 2, COLS // 2)


def test_instants_are_the_phase_images_slices_around_the_frame_centre():
    """4 phase images of 2 ms read out in 1 ms: the exposure is 11 ms, its centre 5.5 ms; phase image j
    starts at 3j ms; two slices each at its 0.5 and 1.5 ms."""
    t = np.asarray(instants_s(4, 2e-3, 1e-3, 2))
    np.testing.assert_allclose(t, np.array([[0.5, 1.5], [3.5, 4.5], [6.5, 7.5], [9.5, 10.5]]) * 1e-3 - 5.5e-3,
                               atol=1e-15)


def test_a_scene_that_does_not_move_is_the_static_scene():
    """Zero velocity: the static returns themselves (every result to the bit); the static returns
    given once per phase image: the static frame to rounding."""
    camera = tj.Camera(small(), ONE_RAY)
    wall = scenes.wall(1.3)
    static = camera.returns(wall)
    still = camera.returns(scenes.moving(wall, [0.0, 0.0, 0.0]))
    assert still.phase_image is None
    np.testing.assert_array_equal(still.path_m, static.path_m)
    per_phase = camera.returns([static] * 4)
    assert per_phase.phase_image == (0, 1, 2, 3) and per_phase.path_m.shape == (ROWS, COLS, 4)
    a, b = tj.predict(camera, static), tj.predict(camera, per_phase)
    for name in ("radial_m", "depth_std_m", "amplitude_lsb", "intensity_e"):
        np.testing.assert_allclose(getattr(b, name), getattr(a, name), rtol=1e-12, err_msg=name)


def test_an_axially_moving_wall_is_each_phase_image_at_its_own_distance():
    """A wall receding at 3 m/s, one instant per phase image: phase image j's tap charges are the
    static wall's at 1.3 m + v t_j (t_j its centre), and the frame's distance and amplitude are what
    a NumPy demodulation of those four differences gives (noise and ADC off: the expected reading
    exactly); the bias against the wall at the frame's centre and the amplitude loss follow."""
    config = tj.Config().replace("pixel.noise", False).replace("adc.enabled", False)
    camera = tj.Camera(small(config.params), ONE_RAY)
    v, d0 = 3.0, 1.3
    moving = tj.predict(camera, scenes.moving(scenes.wall(d0), [0.0, 0.0, v], substeps=1))
    t = np.asarray(instants_s(4, 2e-3, 1e-3, 1))[:, 0]
    static = [tj.predict(camera, scenes.wall(d0 + v * tj_)) for tj_ in t]
    r = moving.result
    for j in range(4):
        np.testing.assert_allclose(r.tap_a_e[..., j], static[j].result.tap_a_e[..., j], rtol=1e-12)
        np.testing.assert_allclose(r.tap_b_e[..., j], static[j].result.tap_b_e[..., j], rtol=1e-12)
    diff = np.stack([np.asarray(static[j].result.tap_a_e - static[j].result.tap_b_e)[..., j] for j in range(4)], -1)
    theta = np.arange(4) * np.pi / 2
    z = np.sum(diff * np.exp(1j * theta), axis=-1)
    du = float(camera.params.unambiguity_range_m)
    expected = np.mod(np.angle(z), 2 * np.pi) / (2 * np.pi) * du
    np.testing.assert_allclose(moving.radial_m, expected, atol=1e-9)
    centre = tj.predict(camera, scenes.wall(d0))
    z0 = np.sum(np.asarray(centre.result.tap_a_e - centre.result.tap_b_e) * np.exp(1j * theta), axis=-1)
    np.testing.assert_allclose(moving.amplitude_lsb / centre.amplitude_lsb, np.abs(z) / np.abs(z0), rtol=1e-9)
    bias = float(moving.radial_m[CENTRE] - centre.radial_m[CENTRE])
    assert 1e-4 < abs(bias) < v * 11e-3  # a bias, less than the 33 mm the wall travels in the frame


def test_two_frequencies_see_the_scene_during_their_own_phase_images():
    """Two frequencies of 4 phases: the frame's 8 phase images in turn, frequency i's phase image j
    the frame's 4 i + j. A wall receding at 3 m/s, one instant per phase image: frequency i's phase
    image j has the tap charges of a one-frequency camera at f_i looking at the static wall at
    1.3 m + v t_(4i+j), the instants of the frame's 8 phase images around its centre (the second
    frequency saw the first's four instants before). One Returns per phase image is 8 for this
    camera, the frame's; 4 are refused."""
    config = tj.Config().replace("pixel.noise", False).replace("adc.enabled", False)
    params = small(config.params)
    freqs = (float(params.illumination_waveform.modulation_frequency_hz), 60.24e6)
    camera = tj.Camera(params, ONE_RAY, freqs)
    v, d0 = 3.0, 1.3
    t = np.asarray(instants_s(8, 2e-3, 1e-3, 1))[:, 0]
    assert camera.timing.phase_images == 8
    moving = camera.expose(scenes.moving(scenes.wall(d0), [0.0, 0.0, v], substeps=1))
    for i, f in enumerate(freqs):
        one = tj.Camera(eqx.tree_at(lambda q: q.illumination_waveform.modulation_frequency_hz, params, f), ONE_RAY)
        mine = _at(moving.frames, i).predict().result
        for j in range(4):
            static = tj.predict(one, scenes.wall(d0 + v * t[4 * i + j])).result
            np.testing.assert_allclose(mine.tap_a_e[..., j], static.tap_a_e[..., j], rtol=1e-12, err_msg=(i, j))
            np.testing.assert_allclose(mine.tap_b_e[..., j], static.tap_b_e[..., j], rtol=1e-12, err_msg=(i, j))
    walls = [camera.returns(scenes.wall(d0 + v * tj_)) for tj_ in t]
    given = tj.predict(camera, walls)  # the same frame from one Returns per phase image
    np.testing.assert_allclose(given.radial_m, moving.predict().radial_m, atol=1e-12)
    with pytest.raises(ValueError, match=r"has 4 tofjax.Returns: the camera's frame has 8 phase images"):
        camera.returns(walls[:4])


def test_a_turning_wall_is_each_phase_image_at_its_own_tilt():
    """A wall at 1.3 m turning at w = 20 rad/s about the vertical axis through a pivot 0.5 m behind it,
    one instant per phase image: phase image j is the wall tilted by -w t_j crossing the axis at
    1.8 - 0.5 / cos(w t_j) m (the plane through the turned point with the turned normal, written out
    here with ``tilted_plane``), tap charges to 1e-12. The reading's gradient in w is a central
    difference's. A sphere turning about its own centre is the static sphere (a pivot taken as the
    origin would move it)."""
    config = tj.Config().replace("pixel.noise", False).replace("adc.enabled", False)
    camera = tj.Camera(small(config.params), ONE_RAY)
    d0, behind, w = 1.3, 0.5, 20.0

    def turning(rate):
        return scenes.moving(scenes.wall(d0), angular_velocity_rad_per_s=jax.numpy.stack([0.0 * rate, rate, 0.0 * rate]),
                             pivot_m=[0.0, 0.0, d0 + behind], substeps=1)

    r = tj.predict(camera, turning(w)).result
    for j, t in enumerate(np.asarray(instants_s(4, 2e-3, 1e-3, 1))[:, 0]):
        tilt = w * t
        static = tj.predict(camera, scenes.tilted_plane(d0 + behind - behind / np.cos(tilt), -np.rad2deg(tilt))).result
        np.testing.assert_allclose(r.tap_a_e[..., j], static.tap_a_e[..., j], rtol=1e-12)
        np.testing.assert_allclose(r.tap_b_e[..., j], static.tap_b_e[..., j], rtol=1e-12)
    reading = lambda rate: tj.predict(camera, turning(rate)).radial_m[CENTRE]  # noqa: E731
    eps = 1e-3
    np.testing.assert_allclose(jax.grad(reading)(w), (reading(w + eps) - reading(w - eps)) / (2 * eps), rtol=1e-5)
    ball = scenes.SceneGeometry(scenes.sphere(1.2).primitives[:1])
    spun = scenes.moving(ball, angular_velocity_rad_per_s=[30.0, 50.0, 10.0], pivot_m=ball.primitives[0].centre)
    np.testing.assert_allclose(tj.predict(camera, spun).radial_m, tj.predict(camera, ball).radial_m, rtol=1e-12)


def test_a_depth_map_with_a_velocity_moves_as_the_scene_it_maps():
    """A Z-depth map of the wall at 1.3 m growing at 3 m/s is the receding wall, to rounding; a velocity
    of 0 is the static map's returns."""
    camera = tj.Camera(small(), ONE_RAY)
    depth = np.full((ROWS, COLS), 1.3)
    mapped = tj.predict(camera, camera.returns(depth, velocity_m_per_s=3.0, substeps=2))
    scene = tj.predict(camera, scenes.moving(scenes.wall(1.3), [0.0, 0.0, 3.0], substeps=2))
    np.testing.assert_allclose(mapped.radial_m, scene.radial_m, rtol=1e-9)
    np.testing.assert_allclose(mapped.amplitude_lsb, scene.amplitude_lsb, rtol=1e-9)
    assert camera.returns(depth, velocity_m_per_s=np.zeros((ROWS, COLS))).phase_image is None


def test_a_laterally_moving_edge_widens_the_mixed_band_by_the_distance_travelled():
    """A step edge at 1 m moving sideways four pixels' width during the 11 ms exposure: the band of
    pixels that see both surfaces (flagged mixed) is four columns wider than the static edge's (+-1
    for where the edge starts within its pixel); the others are the static frame's."""
    from tofjax._flags import FLAG_MIXED

    params = small()
    camera = tj.Camera(params, tj.FrameSettings(subpixel_samples=2))
    fx = tj.optics.intrinsics(params, camera.settings)["fx"]
    v = 4.0 / (fx * 11e-3)  # m/s: 4 pixels of 1/fx m at 1 m in 11 ms
    edge = scenes.step_edge(1.0, 1.6)
    row = CENTRE[0]

    def band(scene):
        return int(np.sum((np.asarray(tj.predict(camera, scene).flags)[row] & FLAG_MIXED) > 0))

    still, swept = band(edge), band(scenes.moving(edge, [v, 0.0, 0.0], substeps=8))
    assert 1 <= still <= 2 and 3 <= swept - still <= 5, (still, swept)


def test_monte_carlo_frames_of_a_moving_scene_match_its_analytic_frame():
    """200 frames of the receding wall: their mean distance within 4 standard errors of the analytic
    expectation at every pixel (the per-phase-image light reaches the noise and the draws)."""
    camera = tj.Camera(small(), ONE_RAY)
    scene = camera.returns(scenes.moving(scenes.wall(1.3), [0.0, 0.0, 3.0], substeps=2))
    analytic = tj.predict(camera, scene)
    frames = tj.simulate(camera, scene, jax.random.key(4), 200)
    error = np.asarray(frames.radial_m - analytic.radial_m) / (np.asarray(analytic.depth_std_m) / np.sqrt(200))
    assert np.max(np.abs(error)) < 4.5


def test_what_cannot_move_is_refused_in_one_line():
    camera = tj.Camera(small(), ONE_RAY)
    wall = scenes.wall(1.3)
    with pytest.raises(ValueError, match="a scene given per phase image has 3 tofjax.Returns: the camera's frame has 4"):
        camera.returns([camera.returns(wall)] * 3)
    with pytest.raises(ValueError, match=r"substeps = 0 is out of range: allowed integer 1 <= value <= 64"):
        scenes.moving(wall, [0.0, 0.0, 1.0], substeps=0)
    with pytest.raises(ValueError, match=r"velocity_m_per_s has shape \(2,\)"):
        scenes.moving(wall, [0.0, 1.0])
    with pytest.raises(ValueError, match=r"angular_velocity_rad_per_s has shape \(2,\): allowed three numbers"):
        scenes.moving(wall, angular_velocity_rad_per_s=[0.0, 1.0], pivot_m=[0.0, 0.0, 1.0])
    with pytest.raises(ValueError, match="pivot_m is required with angular_velocity_rad_per_s"):
        scenes.moving(wall, angular_velocity_rad_per_s=[0.0, 1.0, 0.0])
    with pytest.raises(ValueError, match=r"the scene cannot turn: primitives\[0\]: Plane is bounded by an "
                                         r"axis-aligned box \(hi finite\)"):
        scenes.moving(scenes.step_edge(1.0, 1.6), angular_velocity_rad_per_s=[0.0, 1.0, 0.0], pivot_m=[0.0, 0.0, 1.0])
    assert scenes.moving(wall, angular_velocity_rad_per_s=[0.0, 0.0, 0.0], pivot_m=[0.0, 0.0, 1.0]).still
    moving = camera.returns(scenes.moving(wall, [0.0, 0.0, 1.0], substeps=1))
    with pytest.raises(ValueError, match="save_returns: these returns belong to phase images of a moving scene"):
        tj.frameio.save_returns("unused.npz", moving)
    three = tj.Camera(small(dataclasses.replace(tj.Params(), pixel=tj.Pixel(n_phases=3))), ONE_RAY)
    with pytest.raises(ValueError, match="phase_image names phase image 3: the camera has 3"):
        tj.predict(three, moving)
    two = tj.Camera(small(), ONE_RAY, (80.32e6, 60.24e6))  # 8 phase images, each frequency's 4 in turn
    with pytest.raises(ValueError, match=r"phase_image names phase image 11: the camera's frame has 8 \(4 phases x 2 "
                                         r"frequencies"):
        tj.predict(two, tj.Camera(small(), ONE_RAY, (80.32e6, 60.24e6, 40e6)).returns(scenes.moving(wall, [0, 0, 1.0],
                                                                                                     substeps=1)))
    static = camera.returns(wall)
    uneven = two.returns([static] * 8) + dataclasses.replace(static, phase_image=(0,) * static.path_m.shape[-1])
    with pytest.raises(ValueError, match="every frequency's phase images need the same returns"):
        tj.predict(two, uneven)


def test_the_phase_drifts_with_temperature_as_a_longer_path():
    """pixel.phase_drift_rad_per_c k: at T the camera reads every return as if its path were longer by
    k (T - T_ref) c / (2 pi f) (noise and ADC off, where the dark current's growth cancels in the
    taps' differences); the sweep's centre pixel reads what the frame's axis pixel reads; d/dT of
    the reading by a central difference."""
    config = tj.Config().replace("pixel.noise", False).replace("adc.enabled", False) \
        .replace("pixel.phase_drift_rad_per_c", 0.01)
    warm = config.replace("pixel.temperature_c", 45.0)
    returns = tj.Camera(small(config.params), ONE_RAY).returns(scenes.wall(1.3))
    c, f = 299792458.0, 80.32e6
    longer = dataclasses.replace(returns, path_m=returns.path_m + 0.01 * 20.0 * c / (2 * np.pi * f))
    hot = tj.predict(tj.Camera(small(warm.params), ONE_RAY), returns)
    np.testing.assert_allclose(hot.radial_m, tj.predict(tj.Camera(small(config.params), ONE_RAY), longer).radial_m,
                               rtol=1e-12)
    point = tj.predict(warm.params, tj.Sweep("distance", [1.3]))
    np.testing.assert_allclose(point.depth_mean_m[0], hot.radial_m[CENTRE], rtol=1e-12)

    def reading(t_c):
        p = eqx.tree_at(lambda q: q.pixel.temperature_c, warm.params, t_c)
        return tj.predict(p, tj.Sweep("distance", [1.3])).depth_mean_m[0]

    h = 1e-4
    np.testing.assert_allclose(jax.grad(reading)(45.0), (reading(45.0 + h) - reading(45.0 - h)) / (2 * h), rtol=1e-6)
