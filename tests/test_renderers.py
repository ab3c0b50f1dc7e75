"""Real renderers behind tofjax (issue 51 item 3; docs/renderers.md): MuJoCo's OpenGL depth and
Open3D's ray caster, rendered for real (no mocks) on the small camera, give through
``camera.returns`` the path lengths of tofjax's own scenes of the same geometry; ``tofjax render
--mesh`` of a box written here renders as ``--scene`` of tofjax's own box; a missing extra is one
line. MuJoCo renders headless through EGL (``MUJOCO_GL``, set here, before MuJoCo is imported)."""

import os
import subprocess
import sys
import textwrap

os.environ.setdefault("MUJOCO_GL", "egl")

import equinox as eqx  # noqa: E402
import jax.numpy as jnp  # noqa: E402
import mujoco  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402
from helpers import small  # noqa: E402

import tofjax as tj  # noqa: E402
from tofjax.renderers import mujoco as tmj  # noqa: E402
from tofjax.renderers import open3d as to3  # noqa: E402

#: tofjax's own box: a cube on the floor half a metre below the camera, in front of a wall.
BOX = {"camera_height_m": 0.5, "wall_m": 3.0, "box_m": 1.5, "box_size_m": 0.6, "reflectivity": 0.9,
       "floor_reflectivity": 0.3}
TOL_M = 1e-6


def _boxes(wall_m=BOX["wall_m"]):
    """The scene as boxes ``(lo, hi)`` in tofjax's camera frame: floor, wall, cube (the order is the
    geometry ids)."""
    h, s, b = BOX["camera_height_m"], BOX["box_size_m"], BOX["box_m"]
    floor = ((-20.0, -h - 0.1, -1.0), (20.0, -h, 30.0))
    wall = ((-20.0, -20.0, wall_m), (20.0, 20.0, wall_m + 0.1))
    cube = ((-s / 2, -h, b), (s / 2, -h + s, b + s))
    return [tuple(np.array(x, dtype=float) for x in box) for box in (floor, wall, cube)]


def _box_mesh(lo, hi):
    """A box's 8 corners and 12 triangles, wound counter-clockwise seen from outside."""
    corners = np.array([[(lo, hi)[i >> k & 1][k] for k in range(3)] for i in range(8)])
    quads = [(0, 4, 6, 2), (1, 3, 7, 5), (0, 1, 5, 4), (2, 6, 7, 3), (0, 2, 3, 1), (4, 5, 7, 6)]
    return corners, np.array([t for a, b, c, d in quads for t in ((a, b, c), (a, c, d))])


def _mujoco_model(boxes, camera='fovy="40"'):
    """The boxes as MuJoCo box geoms seen by camera "tof" at the origin: MuJoCo's camera looks along
    -z, so tofjax's (x, y, z) is MuJoCo's (x, y, -z)."""
    geoms = "".join(f'<geom name="g{i}" type="box" size="{" ".join(map(repr, ((hi - lo) / 2).tolist()))}" '
                    f'pos="{" ".join(map(repr, ((hi + lo) / 2 * [1, 1, -1]).tolist()))}"/>'
                    for i, (lo, hi) in enumerate(boxes))
    model = mujoco.MjModel.from_xml_string(f'<mujoco><worldbody><camera name="tof" {camera}/>{geoms}'
                                           '</worldbody></mujoco>')
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    return model, data


def _camera(subpixel_samples=1):
    return tj.Camera(small(), tj.FrameSettings(subpixel_samples=subpixel_samples))


def _interior(segmentation):
    """Pixels whose 3 x 3 neighbourhood sees one geometry (away from depth edges)."""
    padded = np.pad(segmentation, 1, mode="edge")
    rows, cols = segmentation.shape
    same = np.ones(segmentation.shape, dtype=bool)
    for dr in range(3):
        for dc in range(3):
            same &= padded[dr:dr + rows, dc:dc + cols] == segmentation
    return same & (segmentation >= 0)


def _compare(returns, own, segmentation, path_tol, radiance_rtol):
    """``returns`` against tofjax's ``own``, away from edges: the interior must hold every geometry."""
    inside = _interior(segmentation)
    assert set(np.unique(segmentation[inside])) == {0, 1, 2}, "the comparison must see the floor, wall and cube"
    assert inside.mean() > 0.6
    path, own_path = np.asarray(returns.path_m)[..., 0], np.asarray(own.path_m)[..., 0]
    err = np.abs(path - own_path)[inside]
    assert err.max() < path_tol, err.max()
    assert np.abs(np.asarray(returns.radial_m) - np.asarray(own.radial_m))[inside].max() < path_tol / 2
    rad, own_rad = np.asarray(returns.radiance_per_w)[..., 0], np.asarray(own.radiance_per_w)[..., 0]
    assert np.abs(rad / own_rad - 1.0)[inside].max() < radiance_rtol
    return err.max()


def test_mujoco_depth_is_planar_z_and_gives_tofjax_path_lengths():
    """MuJoCo's depth (planar Z, at the tofjax camera's intrinsics) through ``camera.returns`` gives
    the path lengths of tofjax's own box_on_floor to 1e-6 m away from edges (MuJoCo's float32
    depth: a few float32 steps); read as radial it would be 1/cos off, and the wrong field of view
    or principal point moves every tilted surface (the floor) by millimetres. The model camera's own
    fovy gives the same intrinsics and the same depth."""
    camera = _camera()
    own = camera.returns(tj.scenes.box_on_floor(**BOX))
    intr = tj.optics.intrinsics(camera.params, camera.settings)
    fovy = float(np.degrees(2 * np.arctan(intr["height"] / 2 / intr["fy"])))
    model, data = _mujoco_model(_boxes(), camera=f'fovy="{fovy!r}"')
    rendered = tmj.render(model, data, "tof", tofjax_camera=camera)
    assert rendered.depth_type == "z" and rendered.normals is None and rendered.depth_m.dtype == np.float64
    table = {0: BOX["floor_reflectivity"]}  # the floor is geom 0
    err = _compare(rendered.to_returns(camera, reflectivity=0.9, reflectivity_table=table), own,
                   rendered.segmentation, TOL_M, 1e-4)
    print(f"MuJoCo: largest path error {err:.2e} m")
    with pytest.raises(AssertionError):  # the same depth read as radial distances is far off
        _compare(camera.returns(rendered.depth_m, reflectivity=rendered.reflectivity(0.9, table), radial=True), own,
                 rendered.segmentation, TOL_M, 1e-4)
    native = tmj.render(model, data, "tof", width=intr["width"], height=intr["height"])
    for key in ("fx", "fy", "cx", "cy"):
        assert native.intrinsics[key] == pytest.approx(intr[key], rel=1e-12), key
    np.testing.assert_array_equal(native.segmentation, rendered.segmentation)
    inside = _interior(native.segmentation)
    assert np.abs(native.depth_m[inside] - rendered.depth_m[inside]).max() < TOL_M


def test_mujoco_sensorsize_camera_intrinsics_from_its_frustum():
    """A MuJoCo camera given by sensor size, focal length and an off-centre principal point renders
    a tilted plate with the intrinsics :func:`frustum_intrinsics` derives (against Open3D's pinhole
    cast at them, planar depth, to 1e-6 m): with the principal point at the image centre instead the
    plate would be millimetres off. Pixels that see nothing are inf, id -1."""
    plate = _box_mesh(np.array([-0.5, -0.4, 1.6]), np.array([0.7, 0.3, 1.7]))
    turned = (plate[0] @ to3.pose_matrix((0, 0, 0, 10, 25, 0))[:3, :3].T, plate[1])
    verts = " ".join(map(repr, (turned[0] * [1, 1, -1]).ravel().tolist()))
    faces = " ".join(map(str, turned[1][:, ::-1].ravel().tolist()))  # the mirror z -> -z turns the winding: undo it
    model = mujoco.MjModel.from_xml_string(
        f'<mujoco><asset><mesh name="plate" vertex="{verts}" face="{faces}"/></asset><worldbody>'
        '<camera name="tof" sensorsize="0.0054 0.0036" focal="0.004 0.0041" principal="0.0003 -0.0002" '
        'resolution="31 21"/><geom type="mesh" mesh="plate"/></worldbody></mujoco>')
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    rendered = tmj.render(model, data, "tof")
    intr = rendered.intrinsics
    assert (intr["width"], intr["height"]) == (31, 21)
    assert abs(intr["cx"] - 15.0) > 1.0 and abs(intr["cy"] - 10.0) > 1.0 and abs(intr["fx"] / intr["fy"] - 1) > 1e-3
    cast = to3.render([turned], intrinsics=intr, depth_type="z")
    inside = _interior(cast.segmentation)
    assert inside.sum() > 100 and (cast.segmentation == -1).sum() > 50
    np.testing.assert_array_equal(rendered.segmentation >= 0, cast.segmentation >= 0)
    assert np.abs(rendered.depth_m[inside] - cast.depth_m[inside]).max() < TOL_M
    assert np.all(np.isinf(rendered.depth_m[cast.segmentation == -1]))
    centred = dict(intr, cx=15.0, cy=10.0)
    off = to3.render([turned], intrinsics=centred, depth_type="z")
    both = inside & (off.segmentation >= 0)
    assert np.abs(rendered.depth_m[both] - off.depth_m[both]).max() > 1e-3


def test_open3d_depth_and_returns_give_tofjax_path_lengths():
    """Open3D's radial distances along the camera's own rays give tofjax's box_on_floor path lengths
    to 1e-6 m away from edges (its float32 hits refined in float64: to 1e-12 here), with the normals
    tofjax's ray caster finds; its returns of every sub-pixel ray equal tofjax's own, flying pixels
    included; a lens with distortion is cast along its own rays."""
    meshes = [_box_mesh(lo, hi) for lo, hi in _boxes()]
    table = {0: BOX["floor_reflectivity"]}
    camera = _camera()
    rendered = to3.render(meshes, camera)
    assert rendered.depth_type == "radial"
    own = camera.returns(tj.scenes.box_on_floor(**BOX))
    err = _compare(rendered.to_returns(camera, reflectivity=0.9, reflectivity_table=table), own,
                   rendered.segmentation, 1e-12, 1e-9)
    print(f"Open3D: largest path error {err:.2e} m")
    from tofjax._scene import surface

    rays = tj.optics.frame_rays(camera.params, camera.settings)
    truth = surface(tj.scenes.box_on_floor(**BOX), rays)
    inside = _interior(rendered.segmentation)
    np.testing.assert_allclose(rendered.normals[inside], np.asarray(truth.centre_normal)[inside], atol=1e-12)
    np.testing.assert_allclose(rendered.z_m[inside], (np.asarray(truth.centre_t_m) * rays.centre[..., 2])[inside],
                               rtol=1e-12)

    fine = _camera(3)
    mine, theirs = to3.returns(fine, meshes, reflectivity_table=table), fine.returns(tj.scenes.box_on_floor(**BOX))
    np.testing.assert_allclose(mine.path_m, theirs.path_m, rtol=0, atol=1e-9)
    np.testing.assert_allclose(mine.radiance_per_w, theirs.radiance_per_w, rtol=1e-9, atol=1e-300)
    np.testing.assert_allclose(mine.ambient_reflectivity, theirs.ambient_reflectivity, rtol=1e-12)
    spread = np.ptp(np.where(np.asarray(mine.radiance_per_w) > 0, mine.path_m, np.nan), axis=-1)
    assert np.nanmax(spread) > 1.0  # pixels on the cube's silhouette mix it with the wall

    barrel = eqx.tree_at(lambda s: s.distortion_k1, camera.settings, jnp.asarray(-0.15))
    lens = tj.Camera(camera.params, barrel)
    bent = to3.render(meshes, lens)
    truth = surface(tj.scenes.box_on_floor(**BOX), tj.optics.frame_rays(lens.params, lens.settings))
    inside = _interior(bent.segmentation)
    np.testing.assert_allclose(bent.depth_m[inside], np.asarray(truth.centre_t_m)[inside], rtol=1e-12)
    assert np.abs(bent.depth_m - rendered.depth_m)[inside].max() > 1e-2  # the lens bends the rays
    with pytest.raises(ValueError, match="lens has distortion"):
        tmj.DepthCamera(*_mujoco_model(_boxes())[:1], "tof", tofjax_camera=lens)


def _write_obj(path, vertices, triangles):
    path.write_text("".join(f"v {x!r} {y!r} {z!r}\n" for x, y, z in vertices.tolist())
                    + "".join(f"f {a + 1} {b + 1} {c + 1}\n" for a, b, c in triangles.tolist()))


def _write_ply(path, vertices, triangles):
    head = (f"ply\nformat ascii 1.0\nelement vertex {len(vertices)}\nproperty double x\nproperty double y\n"
            f"property double z\nelement face {len(triangles)}\nproperty list uchar int vertex_indices\nend_header\n")
    path.write_text(head + "".join(f"{x!r} {y!r} {z!r}\n" for x, y, z in vertices.tolist())
                    + "".join(f"3 {a} {b} {c}\n" for a, b, c in triangles.tolist()))


def test_render_mesh_matches_render_scene(tmp_path):
    """``tofjax render --mesh`` of the box scene written as an OBJ (in the camera frame) and as a PLY
    (in a frame of its own, placed by ``--mesh-pose``), both of ``--reflectivity 0.5``, writes the
    frame ``--scene box_on_floor`` of reflectivity 0.5 writes: the truth, the Monte Carlo depth and
    the analytic noise image (which the reflectivity sets), to 1e-6 m away from edges, every pixel
    flagged alike."""
    from tofjax.cli import main

    parts = [_box_mesh(lo, hi) for lo, hi in _boxes()]
    offsets = np.cumsum([0] + [len(v) for v, _ in parts])
    vertices = np.concatenate([v for v, _ in parts])
    triangles = np.concatenate([t + o for (_, t), o in zip(parts, offsets, strict=False)])
    _write_obj(tmp_path / "box.obj", vertices, triangles)
    pose = (0.1, -0.2, 2.0, 0.0, 90.0, 30.0)  # the PLY holds the scene in a frame turned and moved away
    m = to3.pose_matrix(pose)
    _write_ply(tmp_path / "box.ply", (vertices - m[:3, 3]) @ m[:3, :3], triangles)
    (tmp_path / "small.toml").write_text("[camera]\noptical_area_m = [0.0005425, 0.0003675]\n")
    common = ["--config", str(tmp_path / "small.toml"), "--frames", "2", "--quiet"]
    one = {**BOX, "reflectivity": 0.5, "floor_reflectivity": 0.5}  # the configuration's scene.reflectivity is 0.9
    scene = "box_on_floor:" + ",".join(f"{k}={v}" for k, v in one.items())
    assert main(["render", "--scene", scene, *common, "--out", str(tmp_path / "scene")]) == 0
    assert main(["render", "--mesh", str(tmp_path / "box.obj"), "--reflectivity", "0.5", *common,
                 "--out", str(tmp_path / "obj")]) == 0
    assert main(["render", "--mesh", str(tmp_path / "box.ply"), "--mesh-pose", ",".join(map(str, pose)),
                 "--reflectivity", "0.5", *common, "--out", str(tmp_path / "ply")]) == 0
    want = np.load(tmp_path / "scene" / "frame.npz")
    segmentation = to3.render([(vertices, triangles)], _camera()).segmentation
    inside = _interior(segmentation)
    assert inside.mean() > 0.9
    for name in ("obj", "ply"):
        got = np.load(tmp_path / name / "frame.npz")
        for key in ("radial_true_m", "z_true_m", "radial_m", "z_m"):
            assert np.abs(got[key] - want[key])[inside].max() < TOL_M, (name, key)
        np.testing.assert_allclose(got["predicted_std_m"][inside], want["predicted_std_m"][inside], rtol=1e-6)
        np.testing.assert_array_equal(got["flags"], want["flags"])


def test_importing_tofjax_imports_no_renderer_and_a_missing_extra_is_one_line(tmp_path):
    """``import tofjax`` and ``tofjax.renderers`` load neither MuJoCo nor Open3D; where one is missing,
    importing its module and ``render --mesh`` each say so in one line, naming the extra."""
    (tmp_path / "quad.obj").write_text("v 0 0 1\nv 1 0 1\nv 0 1 1\nf 1 2 3\n")
    code = textwrap.dedent(f"""
        import sys
        import tofjax as tj, tofjax.renderers
        tj.Camera, tj.optics.intrinsics, tj.renderers.Render
        assert "mujoco" not in sys.modules and "open3d" not in sys.modules, "a renderer was imported"
        sys.modules["mujoco"] = sys.modules["open3d"] = None  # as where neither is installed
        for name in ("mujoco", "open3d"):
            try:
                __import__("tofjax.renderers." + name)
            except tj.renderers.MissingExtra as err:
                print(err)
        from tofjax.cli import main
        sys.exit(main(["render", "--mesh", {str(tmp_path / "quad.obj")!r}, "--out", {str(tmp_path / "out")!r}]))
    """)
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=tmp_path)
    assert done.returncode == 2, done.stderr
    assert done.stdout.splitlines() == [
        'tofjax.renderers.mujoco needs mujoco, which is not installed: pip install "tofjax[mujoco]"',
        'tofjax.renderers.open3d needs open3d, which is not installed: pip install "tofjax[open3d]"']
    assert done.stderr.strip().splitlines() == [
        'tofjax: error: --mesh: tofjax.renderers.open3d needs open3d, which is not installed: pip install '
        '"tofjax[open3d]"']


def test_a_pixel_that_sees_nothing_has_no_error_and_no_warning():
    """A mesh in empty space leaves pixels with no truth (inf): their error is NaN, without the
    warning inf - inf gave (which stopped ``render --mesh`` under the tests' warnings-as-errors)."""
    import warnings

    from tofjax.frameio import distance_error_m

    arrays = {"radial_m": np.array([1.0, 1.0, np.nan, 2.0]), "radial_true_m": np.array([0.9, np.inf, np.inf, 0.1]),
              "unambiguity_range_m": np.array(1.8)}
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        err = distance_error_m(arrays)
    np.testing.assert_allclose(err, [0.1, np.nan, np.nan, 1.9 - 1.8])


def _one_plane(plan, segmentation):
    """Camera pixels whose ray reads buffer pixels of one geometry only (the 4 x 4 buffer pixels
    around the cell it falls in: the bilinear cell and the normals' neighbours)."""
    rows, cols = segmentation.shape
    corner = np.asarray(plan.corner)[..., 0]
    r0, c0 = corner // cols, corner % cols
    same = segmentation[r0, c0] >= 0
    for dr in (-1, 0, 1, 2):
        for dc in (-1, 0, 1, 2):
            same &= segmentation[np.clip(r0 + dr, 0, rows - 1), np.clip(c0 + dc, 0, cols - 1)] == segmentation[r0, c0]
    return same


def test_mujoco_and_open3d_renders_through_the_sensor_give_tofjax_path_lengths():
    """Each backend's render of the wall and box fed to ``ToFSensor`` as it is
    (``sensor.returns(**render.step_arguments())``: MuJoCo's planar Z without normals, Open3D's radial
    distances with normals): the sensor's path lengths are tofjax's own box_on_floor's to 1e-6 m away
    from edges, at the camera's intrinsics (read pixel for pixel) and from a buffer of another
    resolution, field and principal point (resampled onto the camera's rays: the intrinsics and the
    planar / radial conversion). A step's truth is tofjax's radial distance and its delivered depth
    is the cube's Z."""
    from tofjax.renderers import DEPTH_TYPES as RENDER_DEPTH_TYPES
    from tofjax.sensor import DEPTH_TYPES, ToFSensor

    assert set(RENDER_DEPTH_TYPES) <= set(DEPTH_TYPES)  # a Render's depth_type is a sensor's
    camera = _camera()
    own = camera.returns(tj.scenes.box_on_floor(**BOX))
    intr = tj.optics.intrinsics(camera.params, camera.settings)
    sensor = ToFSensor(camera, fixed_pattern=False, seed=3)
    table = {0: BOX["floor_reflectivity"]}
    meshes = [_box_mesh(lo, hi) for lo, hi in _boxes()]
    model, data = _mujoco_model(_boxes(), camera='fovy="60"')
    # A buffer of another resolution, a wider field and an off-centre principal point, covering the camera's.
    wide = {"width": 47, "height": 35, "fx": 36.0, "fy": 37.5, "cx": 22.8, "cy": 17.3}
    renders = {"mujoco": tmj.render(model, data, "tof", tofjax_camera=camera),
               "open3d": to3.render(meshes, camera),
               "mujoco, resampled": tmj.render(model, data, "tof", width=47, height=35),
               "open3d, resampled": to3.render(meshes, intrinsics=wide, depth_type="z")}
    assert renders["mujoco, resampled"].intrinsics["fx"] != pytest.approx(intr["fx"], rel=0.05)
    for name, render in renders.items():
        args = render.step_arguments()
        assert args["depth_type"] == ("z" if name.startswith("mujoco") or "resampled" in name else "radial")
        returns = sensor.returns(**args, reflectivity_table=table)
        plan = sensor.plan(_sensor_buffer(render, intr))
        assert plan.identity == ("resampled" not in name), name
        inside = _interior(render.segmentation) if plan.identity else _one_plane(plan, render.segmentation)
        assert inside.mean() > 0.5 and set(np.unique(render.segmentation)) >= {0, 1, 2}, name
        # The distance to the surface to 1e-6 m; the round trip (out and back, twice it) to 2e-6 m:
        # MuJoCo's float32 depth is 2-3 float32 steps off (0.65 um at 3 m), which interpolating
        # between its pixels keeps (at the camera's intrinsics, read pixel for pixel, it met 1e-6).
        radial = np.abs(np.asarray(returns.radial_m) - np.asarray(own.radial_m))[inside].max()
        path = np.abs(np.asarray(returns.path_m)[..., 0] - np.asarray(own.path_m)[..., 0])[inside].max()
        assert radial < TOL_M and path < 2 * TOL_M, (name, radial, path)
        print(f"{name}: largest errors through the sensor: distance {radial:.2e} m, path {path:.2e} m")
    frame = sensor.step(**renders["mujoco"].step_arguments(), reflectivity_table=table)
    inside = _interior(renders["mujoco"].segmentation)
    np.testing.assert_allclose(frame.true_radial_m[inside], np.asarray(own.radial_m)[inside], rtol=1e-6)
    cube = inside & (renders["mujoco"].segmentation == 2) & frame.delivered  # its face 1.5 m away, within range
    assert cube.sum() > 20 and abs(np.median(frame.depth_m[cube]) - BOX["box_m"]) < 0.02


def _sensor_buffer(render, camera_intrinsics):
    """The buffer camera the sensor makes of a render's intrinsics."""
    from tofjax._sensorbuffers import buffer_intrinsics

    return buffer_intrinsics(render.depth_m.shape, camera_intrinsics, render.intrinsics)
