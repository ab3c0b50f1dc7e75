"""The stepped sensor (tofjax.sensor, issue 51; docs/simulators.md): its frames in ROS's conventions
(REP 118 depth, REP 117 invalid pixels, 16UC1, CameraInfo against OpenCV's projection, PointCloud2's
bytes), the buffers' resampling against tofjax's own ray caster, its state (seed, pattern, key
stream, clock), one compile for every step of one shape, motion and several frequencies as tofjax
has them, and two-bounce light from the buffers against tofjax's own corner."""

import equinox as eqx
import jax.numpy as jnp
import numpy as np
import pytest

import tofjax as tj
from tofjax._motion import instants_s
from tofjax._sensorbuffers import buffer_rays
from tofjax.sensor import ToFSensor, camera_info

from helpers import COLS, ROWS, opencv_project, small, traces


def _camera(**frame):
    return tj.Camera(small(), tj.FrameSettings(**{"subpixel_samples": 1, **frame}))


def _cast(scene, intrinsics):
    """tofjax's own ray caster as the renderer: radial distance, normals, reflectivity and each ray's
    primitive (-1: none) at a pinhole buffer's pixels."""
    rays = jnp.asarray(buffer_rays({**intrinsics, "dist_coeffs": [0.0] * 5}))
    hit = scene.cast(rays)
    ts = np.stack([np.asarray(p.intersect(rays).t) for p in scene.primitives])
    ids = np.where(np.isfinite(np.min(ts, axis=0)), np.argmin(ts, axis=0), -1)
    return np.asarray(hit.t), np.asarray(hit.normal), np.asarray(hit.reflectivity), ids, np.asarray(rays)




@pytest.fixture(scope="module")
def wall():
    """A sensor of the small camera and a planar wall at 1.2 m, with no surface in a 4 x 5 corner
    (NaN, inf and 0) and a black patch (no light: low signal, not delivered)."""
    sensor = ToFSensor(_camera(), seed=7)
    depth = np.full((ROWS, COLS), 1.2, dtype=np.float32)
    depth[:4, :5] = np.nan
    depth[0, 0], depth[1, 1] = np.inf, 0.0
    rho = np.full((ROWS, COLS), 0.9)
    rho[10:14, 20:26] = 0.0
    return sensor, depth, rho


def test_rep118_depth_metres_along_z_nan_where_not_delivered(wall):
    sensor, depth, rho = wall
    frame = sensor.step(depth, reflectivity=rho)
    assert frame.depth_m.dtype == np.float32 and frame.depth_m.shape == (ROWS, COLS)
    # REP 117: NaN exactly where the camera does not deliver; the black patch and the empty corner.
    assert np.array_equal(np.isnan(frame.depth_m), ~frame.delivered)
    assert np.all(np.isnan(frame.depth_m[:4, :5])) and np.all(np.isnan(frame.depth_m[10:14, 20:26]))
    assert np.all(frame.flags[:4, :5] & 4) and np.all(frame.flags[10:14, 20:26] & 2)  # no return; low signal
    assert frame.delivered.sum() == ROWS * COLS - 20 - 24
    assert np.all(frame.confidence[~frame.delivered] == 0.0) and np.all(frame.confidence[frame.delivered] > 0.0)
    # Metres along Z: the wall is planar at 1.2 m, so the delivered depth is 1.2 m everywhere within the noise
    # while the radial distance grows off axis; and Z is the radial distance times the ray's z.
    ok = frame.delivered
    z_ray = np.asarray(sensor.rays.centre[..., 2])
    np.testing.assert_allclose(frame.depth_m[ok], (frame.radial_m * z_ray)[ok], rtol=1e-6)
    assert abs(np.median(frame.depth_m[ok]) - 1.2) < 0.02
    assert np.median(frame.radial_m[ok][z_ray[ok] < 0.99]) > 1.21
    np.testing.assert_allclose(frame.true_radial_m[ok], (1.2 / z_ray)[ok], rtol=1e-6)
    np.testing.assert_allclose(frame.true_depth_m[ok], 1.2, rtol=1e-6)  # the truth as REP 118's depth
    assert np.all(np.isinf(frame.true_depth_m[:4, :5]))  # no surface
    # The message's bytes: 32FC1 keeps the NaN; 16UC1 is millimetres with 0 where nothing is delivered.
    msg = frame.image("depth")
    assert (msg["encoding"], msg["is_bigendian"], msg["step"], msg["height"], msg["width"]) == ("32FC1", 0, 4 * COLS,
                                                                                              ROWS, COLS)
    np.testing.assert_array_equal(np.frombuffer(msg["data"], "<f4").reshape(ROWS, COLS), frame.depth_m)
    mm = frame.image("depth", "16UC1")
    assert (mm["encoding"], mm["step"]) == ("16UC1", 2 * COLS)
    decoded = np.frombuffer(mm["data"], "<u2").reshape(ROWS, COLS)
    assert np.all(decoded[~ok] == 0)
    np.testing.assert_array_equal(decoded[ok], np.rint(frame.depth_m[ok].astype(float) * 1000.0))
    assert np.all(np.abs(decoded[ok].astype(int) - 1200) < 60)
    head = msg["header"]
    assert head["frame_id"] == "tof_optical_frame" and set(head["stamp"]) == {"sec", "nanosec"}


def test_pointcloud2_layout_decodes_to_the_points(wall):
    sensor, depth, rho = wall
    frame = sensor.step(depth, reflectivity=rho)
    cloud = frame.pointcloud2()
    assert (cloud["height"], cloud["width"], cloud["point_step"], cloud["row_step"]) == (ROWS, COLS, 16, 16 * COLS)
    assert cloud["is_dense"] is False and cloud["is_bigendian"] is False
    assert [(f["name"], f["offset"], f["datatype"], f["count"]) for f in cloud["fields"]] == [
        ("x", 0, 7, 1), ("y", 4, 7, 1), ("z", 8, 7, 1), ("intensity", 12, 7, 1)]
    layout = np.dtype({"names": [f["name"] for f in cloud["fields"]], "formats": ["<f4"] * 4,
                       "offsets": [f["offset"] for f in cloud["fields"]], "itemsize": cloud["point_step"]})
    points = np.frombuffer(cloud["data"], layout).reshape(cloud["height"], cloud["width"])
    xyz = np.stack([points["x"], points["y"], points["z"]], axis=-1)
    np.testing.assert_array_equal(xyz, frame.points_m)
    np.testing.assert_array_equal(points["intensity"], frame.amplitude_lsb)
    assert np.array_equal(np.isnan(xyz).any(-1), ~frame.delivered)
    # The optical frame: z is the depth, y grows downwards (row 0 at the top is above the axis).
    np.testing.assert_array_equal(xyz[..., 2], frame.depth_m)
    assert np.nanmean(xyz[0, :, 1]) < 0.0 < np.nanmean(xyz[-1, :, 1])
    assert frame.pointcloud2(intensity=False)["point_step"] == 12


def test_camera_info_projects_the_points_onto_their_pixels_as_opencv():
    """A distorted lens: every delivered point, projected with CameraInfo's K and D by OpenCV's
    formula (tests/helpers.py), lands on its own pixel's centre; plumb_bob for tofjax's five
    coefficients, rational_polynomial for eight."""
    lens = dict(distortion_k1=-0.28, distortion_k2=0.09, distortion_p1=0.002, distortion_p2=-0.0015,
                distortion_k3=-0.01)
    sensor = ToFSensor(_camera(**lens), seed=1, fixed_pattern=False)
    frame = sensor.step(np.full((ROWS, COLS), 1.0))
    info = frame.camera_info()
    assert info["distortion_model"] == "plumb_bob" and (info["width"], info["height"]) == (COLS, ROWS)
    assert info["d"] == [lens[f"distortion_{k}"] for k in ("k1", "k2", "p1", "p2", "k3")]
    k = np.asarray(info["k"]).reshape(3, 3)
    assert info["r"] == [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0]
    np.testing.assert_array_equal(np.asarray(info["p"]).reshape(3, 4), np.hstack([k, np.zeros((3, 1))]))
    ok = frame.delivered
    assert ok.mean() > 0.9
    uv = opencv_project(frame.points_m.astype(float), k, info["d"])
    rows, cols = np.mgrid[:ROWS, :COLS]
    # float32 points: their rounding (6e-8 relative) is 2e-5 pixels at these focal lengths
    np.testing.assert_allclose(uv[..., 0][ok], cols[ok], atol=1e-4)
    np.testing.assert_allclose(uv[..., 1][ok], rows[ok], atol=1e-4)
    # through a pinhole's K alone the points miss their pixels (the distortion is needed)
    assert np.nanmax(np.abs(opencv_project(frame.points_m.astype(float), k, [0.0] * 5)[..., 0] - cols)) > 0.5
    eight = camera_info({**sensor.intrinsics, "dist_coeffs": [0.1] * 8}, ros_version=1)
    assert eight["distortion_model"] == "rational_polynomial" and len(eight["D"]) == 8 and "secs" in eight["header"]["stamp"]


@pytest.mark.parametrize("depth_type", ["planar", "radial"])
def test_resampled_buffers_give_tofjax_own_path_lengths(depth_type):
    """A box on a floor before a wall, cast by tofjax's ray caster into a buffer of another
    resolution, field and principal point: the sensor's returns are tofjax's own scene's (paths to
    1e-6 m, radiance to 1e-9 relative) on every pixel whose buffer neighbourhood sees one surface;
    sub-pixel rays (3 x 3) too; the buffer read in the other convention is millimetres off."""
    scene = tj.scenes.box_on_floor(camera_height_m=0.6, box_m=1.2, box_size_m=0.4)
    subpixels = 1 if depth_type == "planar" else 3
    cam = _camera(subpixel_samples=subpixels)
    own = cam.returns(scene)
    buffer = {"width": 47, "height": 35, "fx": 36.0, "fy": 37.5, "cx": 22.8, "cy": 17.3}
    t, normals, rho, ids, rays = _cast(scene, buffer)
    depth = t if depth_type == "radial" else t * rays[..., 2]
    sensor = ToFSensor(cam, subpixel_samples=subpixels, fixed_pattern=False)
    table = {i: float(np.max(np.where(ids == i, rho, 0.0))) for i in range(len(scene.primitives))}
    if depth_type == "planar":  # the reflectivity by segmentation id (which also keeps objects apart)
        looks = {"segmentation": ids, "reflectivity_table": table}
        mine = sensor.returns(depth, intrinsics=buffer, depth_type=depth_type, normals=normals, **looks)
    else:  # a renderer's Render (tofjax.renderers), as a backend hands it over
        from tofjax.renderers import Render
        from tofjax.renderers._render import pinhole_intrinsics

        render = Render(depth, "radial", pinhole_intrinsics(**buffer), ids.astype(np.int32), normals, rays, "open3d")
        looks = {"reflectivity": rho}
        mine = sensor.returns(**render.step_arguments(), **looks)
        looks["segmentation"] = ids
    assert mine.path_m.shape == own.path_m.shape
    # Where a pixel's rays read buffer pixels of one plane only (each ray's 4 x 4 neighbourhood: one
    # primitive, one normal; a box's faces meet in creases).
    plan = sensor.plan(dict(buffer, dist_coeffs=[0.0] * 5))
    corner = np.asarray(plan.corner)
    r0, c0 = corner // buffer["width"], corner % buffer["width"]
    same = np.ones(corner.shape, bool)
    for dr in (-1, 0, 1, 2):
        for dc in (-1, 0, 1, 2):
            rr, cc = np.clip(r0 + dr, 0, buffer["height"] - 1), np.clip(c0 + dc, 0, buffer["width"] - 1)
            same &= (ids[rr, cc] == ids[r0, c0]) & (ids[r0, c0] >= 0) & np.all(normals[rr, cc] == normals[r0, c0], -1)
    interior = same.all(axis=-1)
    assert interior.mean() > 0.6 and (~interior).sum() > 20
    np.testing.assert_allclose(np.asarray(mine.path_m)[interior], np.asarray(own.path_m)[interior], rtol=0, atol=1e-6)
    np.testing.assert_allclose(np.asarray(mine.radiance_per_w)[interior], np.asarray(own.radiance_per_w)[interior],
                               rtol=1e-9)
    np.testing.assert_allclose(np.asarray(mine.radial_m)[interior], np.asarray(own.radial_m)[interior], atol=1e-6)
    other = "radial" if depth_type == "planar" else "planar"
    wrong = sensor.returns(depth, intrinsics=buffer, depth_type=other, normals=normals, **looks)
    assert np.max(np.abs(np.asarray(wrong.radial_m) - np.asarray(own.radial_m))[interior]) > 1e-3


def test_the_seed_makes_the_frames_and_the_pattern_persists(wall):
    sensor, depth, rho = wall
    a, b, c = (ToFSensor(_camera(), seed=s) for s in (3, 3, 4))
    pattern, prepared = a.pattern, a.prepared
    fa = [a.step(depth, reflectivity=rho) for _ in range(2)]
    fb = [b.step(depth, reflectivity=rho) for _ in range(2)]
    fc = c.step(depth, reflectivity=rho)
    assert a.pattern is pattern and a.prepared is prepared and a.camera.pattern is pattern  # drawn once, kept
    for x, y in zip(fa, fb, strict=True):  # the same seed, the same frames
        for name in ("depth_m", "amplitude_lsb", "flags", "points_m"):
            np.testing.assert_array_equal(getattr(x, name), getattr(y, name))
    np.testing.assert_array_equal(np.asarray(a.pattern.gain), np.asarray(b.pattern.gain))
    assert not np.array_equal(np.asarray(a.pattern.gain), np.asarray(c.pattern.gain))  # another seed: another camera
    assert not np.allclose(fa[0].depth_m, fc.depth_m, equal_nan=True)  # ... and other frames
    assert not np.allclose(fa[0].depth_m, fa[1].depth_m, equal_nan=True)  # each step its own noise
    # Step k draws the frame tofjax's prepared camera draws for the key of step k.
    returns = a.returns(depth, reflectivity=rho)
    own = a.prepared.sample(returns, a.key(1))
    np.testing.assert_allclose(fa[1].radial_m, np.where(fa[1].delivered, np.asarray(own.radial_m[0]), np.nan),
                               rtol=1e-6)
    # The clock: the frame period of the camera's timing, unless the step gives its time.
    assert fa[1].stamp_s - fa[0].stamp_s == pytest.approx(1.0 / float(a.timing.frame_rate_hz))
    assert a.step(depth, time_s=12.5).stamp_s == 12.5 and a.steps == 3


def test_steps_of_one_shape_compile_once(wall):
    sensor, depth, rho = wall
    sensor.step(depth, reflectivity=rho)  # compiled (here or by an earlier test)
    rng = np.random.default_rng(0)
    scenes = [depth * (1.0 + 0.2 * rng.uniform()) for _ in range(3)]
    traced, _ = traces(lambda: [sensor.step(d, reflectivity=np.clip(rho * rng.uniform(), 0, 1)) for d in scenes])
    assert traced == [], f"new scenes of the same shape should run the compiled step: traced {traced}"
    traced, _ = traces(lambda: sensor.step(np.full((ROWS + 2, COLS + 4), 1.2), fov_deg=(80.0, 60.0)))
    assert "_step" in traced  # the counter sees a compile (another buffer shape)


def test_motion_is_tofjax_moving_depth_map():
    """A depth growing at 3 m/s: the sensor's returns are camera.returns(depth, velocity_m_per_s=...)'s,
    tagged by phase image; the previous step's depth gives the same velocity."""
    cam = _camera()
    sensor = ToFSensor(cam, fixed_pattern=False)
    depth = np.full((ROWS, COLS), 1.3)
    own = cam.returns(depth, velocity_m_per_s=3.0)
    mine = sensor.returns(depth, velocity_m_per_s=3.0)
    assert mine.phase_image == own.phase_image
    np.testing.assert_allclose(np.asarray(mine.path_m), np.asarray(own.path_m), atol=1e-9)
    np.testing.assert_allclose(np.asarray(mine.radiance_per_w), np.asarray(own.radiance_per_w), rtol=1e-9)
    dt = sensor.frame_period_s  # 0.2 s: 5 frames/s, the thesis camera's
    previous = sensor.returns(depth, previous_depth=depth - 0.3 * dt)
    slower = cam.returns(depth, velocity_m_per_s=0.3)
    np.testing.assert_allclose(np.asarray(previous.path_m), np.asarray(slower.path_m), atol=1e-9)
    still = sensor.returns(depth, previous_depth=depth - 1.0)  # another surface, not a motion: still
    np.testing.assert_allclose(np.asarray(still.path_m)[..., 0], np.asarray(cam.returns(depth).path_m)[..., 0])


def test_a_stack_of_buffers_is_tofjax_moving_scene():
    """A step edge moving sideways (1.37 pixels per phase image), rendered by tofjax's ray caster at
    each of the sensor's instants_s(2) (4 phase images, 2 instants each): the sensor's returns are
    camera.returns(tj.scenes.moving(edge, ..., substeps=2))'s, path for path, each tagged with its
    phase image (the pixels the edge sweeps see both surfaces, each in its own phase images); the
    truth is the buffer nearest the stamp's. A stack of another length, or with a velocity, is refused."""
    cam = _camera()
    sensor = ToFSensor(cam, fixed_pattern=False)
    intr = sensor.intrinsics
    times = sensor.instants_s(2)
    assert times.shape == (8,) and np.allclose(times, -times[::-1]) and np.all(np.diff(times) > 0)
    v = 1.37 / float(np.diff(times[::2]).mean()) / intr["fx"]  # m/s at 1 m: 1.37 pixels per phase image (no ray on the edge)
    scene = tj.scenes.moving(tj.scenes.step_edge(1.0, 1.6), [v, 0.0, 0.0], substeps=2)
    own = cam.returns(scene)
    casts = [_cast(scene.at(t), intr) for t in times]
    depth, normals, rho = (np.stack([c[i] for c in casts]) for i in range(3))
    mine = sensor.returns(depth, depth_type="radial", normals=normals, reflectivity=rho)
    assert mine.phase_image == own.phase_image
    np.testing.assert_allclose(np.asarray(mine.path_m), np.asarray(own.path_m), rtol=0, atol=1e-9)
    np.testing.assert_allclose(np.asarray(mine.radiance_per_w), np.asarray(own.radiance_per_w), rtol=1e-9)
    path = np.where(np.asarray(own.radiance_per_w) > 0, np.asarray(own.path_m), np.nan)
    swept = np.nanmax(path, axis=-1) - np.nanmin(path, axis=-1) > 0.5
    assert swept.sum(axis=1).min() >= 4  # every row: a band of pixels that see both surfaces during the frame
    np.testing.assert_allclose(np.asarray(mine.radial_m), casts[3][0], rtol=1e-12)
    frame = sensor.step(depth, depth_type="radial", normals=normals, reflectivity=rho)
    assert frame.delivered.mean() > 0.9
    with pytest.raises(ValueError, match=r"one per instant of sensor.instants_s\(substeps\), n x substeps = 4, 8"):
        sensor.step(depth[:5], depth_type="radial")
    with pytest.raises(ValueError, match="a stack of buffers .* is the motion"):
        sensor.step(depth, depth_type="radial", velocity_m_per_s=1.0)


def test_a_preset_of_several_frequencies_and_processing():
    """kinect-v2 (three frequencies, calibration and a spatial filter) on the small array: the fused
    frame is tofjax's own noisy frame of the step's key, the raw phase images come per frequency; a
    stack of buffers is one per phase image of the frame, every frequency's."""
    config = tj.preset_config("kinect-v2")
    pitch = config.params.camera.pixel_pitch_m
    params = eqx.tree_at(lambda q: q.camera.optical_area_m, config.params, jnp.array([COLS, ROWS], dtype=float) * pitch)
    cam = tj.Camera(params, config.frame, config.modulation_frequencies_hz,
                    config.values["illumination_waveform"]["frequency_fusion"], processing=config.processing)
    sensor = ToFSensor(cam, seed=2)
    depth = np.full((ROWS, COLS), 2.5)
    frame = sensor.step(depth, raw=True)
    assert frame.codes.shape == (3, 3, ROWS, COLS) and frame.tap_a_e.shape == (3, 3, ROWS, COLS)
    own = sensor.prepared.sample(sensor.returns(depth), sensor.key(0))
    ok = frame.delivered
    assert ok.mean() > 0.75  # the array's corners: low signal
    np.testing.assert_allclose(frame.radial_m[ok], np.asarray(own.radial_m[0])[ok], rtol=1e-6)
    assert abs(np.median(frame.depth_m[ok]) - 2.5) < 0.05  # beyond the 80 MHz range (1.87 m): unwrapped
    # Its motion: the frame's 9 phase images (3 frequencies of 3 phases, in turn), each at its own instant;
    # a stack of buffers receding at 0.4 m/s is the camera's depth map with that velocity.
    timing = cam.timing
    times = sensor.instants_s(1)
    np.testing.assert_allclose(times, np.ravel(instants_s(9, timing.phase_image_time_s, timing.readout_time_s, 1)))
    mine = sensor.returns(depth + 0.4 * times[:, None, None])
    own = cam.returns(depth, velocity_m_per_s=0.4, substeps=1)
    assert mine.phase_image == own.phase_image and max(own.phase_image) == 8
    np.testing.assert_allclose(np.asarray(mine.path_m), np.asarray(own.path_m), rtol=0, atol=1e-9)


def _corner_bias(cam, returns, truth):
    """The expected delivered depth's bias (the analytic frame's), NaN where it is not delivered."""
    frame = tj.predict(cam, returns)
    return np.where(np.asarray(frame.delivered), np.asarray(frame.radial_m) - truth, np.nan)


def test_multipath_from_buffers_agrees_with_tofjax_corner():
    """tj.scenes.corner(1.5) at 56 x 43 pixels. The sensor fed the corner's own depth and normal
    buffers (224 x 172, the camera's field) with multipath: its delivered depth bias is the corner's
    with the corner's patches the camera sees (the multipath shift about 31 mm: median within 0.5
    mm, 95 % within 4 mm, the patches' discretisation); a buffer as wide as the illumination (80
    degrees) holds the walls lit outside the camera's view, and agrees with the whole corner (shift
    about 40 mm: median within 1.5 mm, 95 % within 5 mm). Without multipath the bias is 30 mm off."""
    pitch = 4 * 17.5e-6
    params = eqx.tree_at(lambda q: (q.camera.pixel_pitch_m, q.camera.optical_area_m), tj.Params(),
                         (jnp.array([pitch, pitch]), jnp.array([56 * pitch, 43 * pitch])))
    cam = tj.Camera(params, tj.FrameSettings(subpixel_samples=1))
    corner = tj.scenes.corner(1.5)
    own = cam.returns(corner)
    truth = np.asarray(own.radial_m)
    intr = tj.optics.intrinsics(params, cam.settings)
    c = np.asarray(corner.patches.centre)
    u, v = intr["fx"] * c[:, 0] / c[:, 2] + intr["cx"], -intr["fy"] * c[:, 1] / c[:, 2] + intr["cy"]
    seen = (u >= -0.5) & (u <= intr["width"] - 0.5) & (v >= -0.5) & (v <= intr["height"] - 0.5)
    p = corner.patches
    visible = tj.scenes.SceneGeometry(corner.primitives, tj.scenes.Patches(p.centre[seen], p.normal[seen],
                                                                            p.area_m2[seen], p.reflectivity[seen]))
    bias_direct = _corner_bias(cam, cam.returns(tj.scenes.SceneGeometry(corner.primitives)), truth)
    bias_visible = _corner_bias(cam, cam.returns(visible), truth)
    bias_whole = _corner_bias(cam, own, truth)
    assert np.mean(np.isfinite(bias_whole)) > 0.95
    assert 25e-3 < np.nanmedian(bias_visible - bias_direct) < 35e-3 < np.nanmedian(bias_whole - bias_direct) < 45e-3

    sensor = ToFSensor(cam, fixed_pattern=False)
    fine = {"width": 224, "height": 172, "fx": 4 * intr["fx"], "fy": 4 * intr["fy"], "cx": 111.5, "cy": 85.5}
    t, normals, rho, _, _ = _cast(corner, fine)
    mine = _corner_bias(cam, sensor.returns(t, intrinsics=fine, depth_type="radial", normals=normals,
                                            reflectivity=rho, multipath=True), truth)
    error = np.abs(mine - bias_visible)
    assert abs(np.nanmedian(mine - bias_visible)) < 0.5e-3 and np.nanpercentile(error, 95) < 4e-3, (
        np.nanmedian(mine - bias_visible), np.nanpercentile(error, 95))
    without = _corner_bias(cam, sensor.returns(t, intrinsics=fine, depth_type="radial", normals=normals,
                                               reflectivity=rho), truth)
    assert np.nanmedian(without - bias_visible) < -25e-3

    wide = ToFSensor(cam, fixed_pattern=False, multipath_patches=256)
    f80 = 0.5 * 300 / np.tan(np.radians(40.0))
    buffer = {"width": 300, "height": 300, "fx": f80, "fy": f80, "cx": 149.5, "cy": 149.5}
    t, normals, rho, _, _ = _cast(corner, buffer)
    mine = _corner_bias(cam, wide.returns(t, intrinsics=buffer, depth_type="radial", normals=normals,
                                          reflectivity=rho, multipath=True), truth)
    error = np.abs(mine - bias_whole)
    assert abs(np.nanmedian(mine - bias_whole)) < 1.5e-3 and np.nanpercentile(error, 95) < 5e-3, (
        np.nanmedian(mine - bias_whole), np.nanpercentile(error, 95))


def test_bad_inputs_are_one_line_errors(wall):
    """Each bad argument is one ValueError naming it, its value and what is allowed; a refused step
    is no step."""
    sensor, depth, rho = wall
    steps = sensor.steps
    with pytest.raises(ValueError, match="dtype uint16: allowed a float array in metres"):
        sensor.step(np.full((ROWS, COLS), 1200, dtype=np.uint16))
    with pytest.raises(ValueError, match=r"= 0.0005 m is nearer than 0.001 m: .* \(metres, not millimetres\)"):
        sensor.step(np.full((ROWS, COLS), 5e-4))
    with pytest.raises(ValueError, match="give the renderer's intrinsics"):
        sensor.step(np.ones((10, 12)))
    with pytest.raises(ValueError, match="does not cover the camera's field of view: .* render a wider field"):
        sensor.step(np.ones((10, 12)), fov_deg=20.0)
    with pytest.raises(ValueError, match="depth_type = 'Z'"):
        sensor.step(depth, depth_type="Z")
    with pytest.raises(ValueError, match="reflectivity_table needs segmentation"):
        sensor.step(depth, reflectivity_table={1: 0.5})
    with pytest.raises(ValueError, match="out of range: allowed 0 to 1"):
        sensor.step(depth, reflectivity=1.5)
    for bad, match in (({"depth": np.ones(5)}, r"depth has shape \(5,\): allowed \(rows, cols\) or \(instants, rows"),
                       ({"normals": np.ones((ROWS, COLS))}, rf"normals has shape \({ROWS}, {COLS}\): allowed \({ROWS}, {COLS}, 3\)"),
                       ({"normals_frame": "ros"}, "normals_frame = 'ros': allowed 'tofjax', 'optical'"),
                       ({"segmentation": np.ones((ROWS, COLS))}, "segmentation has shape .* dtype float64: allowed integer"),
                       ({"velocity_m_per_s": np.ones((3, 3))}, r"velocity_m_per_s has shape \(3, 3\): allowed a finite"),
                       ({"fov_deg": 200.0}, r"fov_deg = 200.0: allowed the horizontal field of view in degrees \(0, 180\)"),
                       ({"intrinsics": (1, 2, 3)}, r"intrinsics = \(1, 2, 3\): allowed \(fx, fy, cx, cy\)"),
                       ({"time_s": float("nan")}, "time_s = nan: allowed a finite time")):
        with pytest.raises(ValueError, match=match):
            sensor.step(**{"depth": depth, **bad})
    with pytest.raises(TypeError, match="must be a tofjax.Camera"):
        ToFSensor(tj.Params())
    assert sensor.steps == steps  # a refused step is no step
    # A buffer that sees nothing at all is no error (nor a warning): nothing delivered, no return.
    frame = sensor.step(np.full((ROWS, COLS), np.nan), reflectivity=rho)
    assert not frame.delivered.any() and np.all(frame.flags & 4) and np.all(np.isinf(frame.true_depth_m))
