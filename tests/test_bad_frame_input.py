"""Hostile inputs to render and the frame API: every size is bounded or refused before any work,
every NPZ file is checked from its headers before its data is read, and every refusal is one line
naming the option, file or array, the value and the allowed range (exit status 2)."""

import io
import zipfile

import numpy as np
import pytest

from tofjax.cli import main

SHAPE = (172, 224)  # the default camera, rows x cols


def _refused(args, capsys) -> str:
    try:
        code = main([str(a) for a in args])
    except SystemExit as exc:  # argparse's own errors
        code = exc.code
    err = capsys.readouterr().err
    assert code == 2, err
    assert "Traceback" not in err
    line = err.strip().splitlines()[-1]
    assert line.startswith("tofjax: error: ") and len(line) < 400, err
    return line


def _npz_claiming(path, shape) -> None:
    """A 200-byte NPZ whose header claims an array of ``shape`` (float64)."""
    header = io.BytesIO()
    np.lib.format.write_array_header_1_0(header, {"descr": "<f8", "fortran_order": False, "shape": shape})
    with zipfile.ZipFile(path, "w") as archive:
        archive.writestr("z_m.npy", header.getvalue())


def _files(tmp_path):
    """name -> (file, what the refusal must say)."""
    d = tmp_path
    np.save(d / "bare.npy", np.ones(SHAPE))
    (d / "bare.npy").rename(d / "bare.npz")
    (d / "empty.npz").write_bytes(b"")
    np.savez(d / "good.npz", z_m=np.full(SHAPE, 1.5))
    good = (d / "good.npz").read_bytes()
    (d / "truncated.npz").write_bytes(good[: len(good) // 2])
    corrupt = bytearray(good)
    corrupt[200] ^= 0xFF
    (d / "crc.npz").write_bytes(bytes(corrupt))
    three = SHAPE + (1,)
    np.savez(d / "no_returns.npz", path_m=np.zeros((*SHAPE, 0)), radiance_per_w=np.zeros((*SHAPE, 0)),
             radial_m=np.ones(SHAPE))
    np.savez(d / "dates.npz", z_m=np.zeros(SHAPE, dtype="datetime64[ns]"))
    np.savez(d / "records.npz", z_m=np.zeros(SHAPE, dtype=[("a", "f8")]))
    np.savez(d / "text.npz", z_m=np.full(SHAPE, "x"))
    np.savez(d / "far.npz", z_m=np.full(SHAPE, 1e300))
    np.savez(d / "near.npz", z_m=np.full(SHAPE, 1e-300))
    np.savez(d / "long_path.npz", path_m=np.full(three, 3e300), radiance_per_w=np.ones(three))
    np.savez(d / "bright.npz", path_m=np.full(three, 2.0), radiance_per_w=np.full(three, np.inf))
    (d / "plain.npz").write_text("distance,value\n1,2\n")
    _npz_claiming(d / "liar.npz", (100_000, 100_000))
    return {
        "bare": "is a single NumPy array (.npy), not an NPZ archive",
        "empty": "is empty",
        "truncated": "is damaged (truncated or corrupt",
        "crc": "array 'z_m' is damaged (truncated or corrupt: Bad CRC-32",
        "no_returns": "with at least one return per pixel",
        "dates": "array 'z_m' has dtype datetime64[ns]: allowed numbers",
        "records": "array 'z_m' has dtype [('a', '<f8')]: allowed numbers",
        "text": "array 'z_m' has dtype <U1: allowed numbers",
        "far": "z_m[0, 0] = 1e+300 is out of range: allowed 0.001 <= value <= 1000 [m]",
        "near": "z_m[0, 0] = 1e-300 is out of range: allowed 0.001 <= value <= 1000 [m]",
        "long_path": "path_m[0, 0, 0] = 3e+300 is out of range: allowed 0 <= value <= 10000 [m]",
        "bright": "radiance_per_w[0, 0, 0] = inf is out of range",
        "plain": "is not an NPZ file (it starts with 'distance,value",
        "liar": "its arrays (z_m (100000, 100000)) would take 80.0 GB in memory",
    }


def test_every_bad_npz_file_is_one_line_naming_file_and_array_even_with_check(tmp_path, capsys):
    for name, says in _files(tmp_path).items():
        path = tmp_path / f"{name}.npz"
        for check in ([], ["--check"]):  # --check validates what the run would read
            line = _refused(["render", "--scene", path, "--frames", "2", "--out", tmp_path / "out", *check], capsys)
            assert line.startswith(f"tofjax: error: --scene {path}: ") and says in line, (name, line)
    assert not (tmp_path / "out").exists()


def test_load_returns_raises_the_value_error_it_promises(tmp_path):
    import tofjax as tj

    _files(tmp_path)
    for name in ("plain", "crc", "no_returns", "long_path", "bright"):
        with pytest.raises(ValueError, match=str(tmp_path / name)):
            tj.frameio.load_returns(tmp_path / f"{name}.npz")
    # An empty pixel's true distance is inf (no surface), not half of its empty path; with
    # radial_m given, no default is computed at all.
    path = np.zeros((2, 3, 2))
    radiance = np.zeros((2, 3, 2))
    path[0, 0], radiance[0, 0] = (3.0, 5.0), (0.1, 0.4)  # the strongest return is the second
    np.savez(tmp_path / "r.npz", path_m=path, radiance_per_w=radiance)
    radial = np.asarray(tj.frameio.load_returns(tmp_path / "r.npz").radial_m)
    assert radial[0, 0] == 2.5 and np.all(np.isposinf(radial.reshape(-1)[1:]))


def test_sizes_are_refused_before_any_work_naming_the_cause(tmp_path, capsys, monkeypatch):
    out = tmp_path / "out"
    for frames in ("99999999999999999999", "9223372036854775807", "0"):
        line = _refused(["render", "--scene", "wall", "--frames", frames, "--out", out], capsys)
        assert "argument --frames" in line and "allowed integer 1 <= value <= 10000000" in line
    huge = tmp_path / "huge.toml"
    huge.write_text("[camera]\noptical_area_m = [0.1, 0.1]\npixel_pitch_m = [1e-6, 1e-6]\n")
    line = _refused(["render", "--scene", "wall", "--config", huge, "--out", out], capsys)
    assert "1e+10 pixels is out of range: allowed at most 16777216 (2^24) pixels" in line
    # A 2000 x 2000 camera inside every documented range, with 4 GB of memory to use: the message
    # names the resolution and the need, not a --keep-frames the user never passed.
    import tofjax._limits as limits

    monkeypatch.setattr(limits, "available_memory_bytes", lambda: 4_000_000_000)
    monkeypatch.setattr(limits, "device_memory_bytes", lambda: 4 << 30)  # 1 GiB of frames returned
    big = tmp_path / "big.toml"
    big.write_text("[camera]\noptical_area_m = [0.035, 0.035]\n")
    line = _refused(["render", "--scene", "wall", "--config", big, "--out", out], capsys)
    assert "the camera's 2000 x 2000 pixels (camera.optical_area_m / camera.pixel_pitch_m)" in line
    assert "need about 10.6 GB to render, more than the 4.0 GB this process can use" in line
    _npz_claiming(tmp_path / "claims.npz", (172, 224, 500_000))  # a returns-sized lie, as depth
    line = _refused(["render", "--scene", tmp_path / "claims.npz", "--out", out], capsys)
    assert "would take 154.1 GB in memory" in line
    line = _refused(["simulate", "--sweep", "distance", "--samples", "10000000", "--iterations", "10000000",
                     "--out", tmp_path / "s.csv"], capsys)
    assert "--samples = 10000000 is out of range: allowed integer 1 <= value <= 1e+06, as scene.samples" in line
    line = _refused(["render", "--scene", "wall", "--keep-frames", "2000", "--frames", "3000", "--out", out], capsys)
    assert ("--keep-frames = 2000 is out of range for 172 x 224 pixels: allowed 0 <= value <= 428 (frames returned "
            "take at most a quarter of this device's 4.3 GB; the statistics use every frame)") in line
    assert not out.exists()


def test_render_refuses_what_it_would_not_simulate(tmp_path, capsys):
    dual = tmp_path / "dual.toml"
    dual.write_text("[illumination_waveform]\nextra_modulation_frequencies_hz = [60.24e6]\n")
    line = _refused(["render", "--scene", "wall", "--config", dual, "--raw", "--out", tmp_path / "o"], capsys)
    assert "--raw writes one frequency's raw phase images" in line and "extra_modulation_frequencies_hz" in line
    folder = tmp_path / "o2"
    (folder / "frame.npz").mkdir(parents=True)  # D/frame.npz a directory: refused before rendering
    line = _refused(["render", "--scene", "wall", "--out", folder, "--overwrite"], capsys)
    assert "holds files tofjax did not write (frame.npz)" in line


def test_the_frame_api_refuses_what_the_command_line_refuses(tmp_path):
    """Values that used to return NaN frames: each a ValueError naming the argument, value and range."""
    import jax
    import jax.numpy as jnp

    import tofjax as tj

    params, settings = tj.Params(), tj.FrameSettings(subpixel_samples=1)
    wall = tj.Camera(params, settings).returns(tj.scenes.wall())
    nan = float("nan")
    cases = [
        (lambda: tj.scenes.wall(nan), "tofjax.scenes.wall: distance_m = nan is out of range: allowed 0.01 <= value"),
        (lambda: tj.scenes.wall(1.0, -0.5), "tofjax.scenes.wall: reflectivity = -0.5 is out of range"),
        (lambda: tj.scenes.wall(1.0, 2), "tofjax.scenes.wall: reflectivity = 2.0 is out of range"),
        (lambda: tj.scenes.wall(1.0, nan), "tofjax.scenes.wall: reflectivity = nan is out of range"),
        (lambda: tj.scenes.sphere(radius_m=-1.0), "tofjax.scenes.sphere: radius_m = -1.0 is out of range"),
        (lambda: tj.scenes.corner(patches_per_side=0), "patches_per_side = 0 is out of range: allowed integer 1"),
        (lambda: tj.scenes.Plane((0, 0, 1), (0, 0, 0), 0.5), "Plane: normal = [0.0, 0.0, 0.0] is not a direction"),
        (lambda: tj.Camera(params, settings).returns(tj.scenes.wall(), sun_direction=(0, 0, 0)),
         "sun_direction = [0.0, 0.0, 0.0] is not a direction"),
        (lambda: tj.Camera(params, settings).returns(tj.scenes.wall(), bins=0), "bins = 0 is out of range"),
        (lambda: tj.Camera(params, settings).returns(np.full(SHAPE, 1e300), reflectivity=0.5),
         "depth_m[0, 0] = 1e+300 is out of range: allowed 0.001 <= value <= 1000 [m]"),
        (lambda: tj.Camera(params, settings).returns(np.full(SHAPE, 1.0), reflectivity=5.0), "reflectivity = 5.0 is out of range"),
        (lambda: tj.Returns(jnp.full((*SHAPE, 1), nan), wall.radiance_per_w, wall.ambient_reflectivity,
                            wall.radial_m), "tofjax.Returns: path_m[0, 0, 0] = nan is out of range"),
        (lambda: tj.Returns(wall.path_m, -wall.radiance_per_w, wall.ambient_reflectivity, wall.radial_m),
         "tofjax.Returns: radiance_per_w[0, 0, 0] = -"),
        (lambda: tj.Returns(wall.path_m, wall.radiance_per_w[:, :-1], wall.ambient_reflectivity, wall.radial_m),
         "path_m has shape (172, 224, 1) and radiance_per_w (172, 223, 1): allowed equal shapes"),
        (lambda: tj.simulate(tj.Camera(params, settings), wall, jax.random.key(0), 0),
         "frames = 0 is out of range: allowed integer >= 1"),
        # No return per pixel (was: TypeError, reduce() of empty iterable), a camera sample of another
        # shape (was: a broadcasting TypeError), a preset name that is not a string (was: AttributeError).
        (lambda: tj.Camera(params, settings).returns(tj.Returns(wall.path_m[..., :0], wall.radiance_per_w[..., :0],
                                                                wall.ambient_reflectivity, wall.radial_m)),
         "path_m has shape (172, 224, 0) and radiance_per_w (172, 224, 0): allowed equal shapes (rows, cols, returns) "
         "with at least one return per pixel"),
        (lambda: tj.predict(tj.Camera(params, settings, pattern=tj.draw_pattern(params, settings, (10, 12))), wall),
         "pattern.gain has shape (10, 12), the camera 172 x 224 pixels: allowed a pattern of the camera's shape"),
        (lambda: tj.preset_config(None), "preset = None is not known: allowed 'thesis', "),
        (lambda: tj.preset_config(5), "preset = 5 is not known: allowed 'thesis', "),
    ]
    for make, says in cases:
        with pytest.raises(ValueError) as err:
            make()
        assert says in str(err.value) and "\n" not in str(err.value), str(err.value)
    # A length-2 sun direction is a direction; one whose length underflows too.
    for sun in ((0.0, -2.0, 0.0), (1e-200, 1e-200, 0.0)):
        assert np.all(np.isfinite(np.asarray(tj.Camera(params, settings).returns(tj.scenes.wall(), sun_direction=sun)
                                             .ambient_reflectivity)))
    # Traced values are checked when the program runs; a pixel that sees nothing (radial inf) passes.
    with pytest.raises(Exception, match="tofjax.scenes.wall: distance_m is out of range"):
        jax.jit(lambda d: tj.scenes.wall(d).primitives[0].point)(nan).block_until_ready()
    depth = np.full(SHAPE, 1.5)
    depth[:, :10] = np.inf  # no surface there
    ball = tj.Camera(params, settings).returns(depth, reflectivity=0.5)
    assert np.isinf(np.asarray(ball.radial_m)).any()
    traced = jax.jit(lambda r: tj.predict(tj.Camera(params, settings), r).radial_true_m)(ball)  # reads radial_m
    np.testing.assert_array_equal(traced, ball.radial_m)
    with pytest.raises(Exception, match="tofjax.Returns: radiance_per_w is out of range"):
        jax.jit(lambda r: tj.Camera(params, settings).prepare().noise_image(tj.Returns(r.path_m, -r.radiance_per_w, r.ambient_reflectivity, r.radial_m)))(
            ball).block_until_ready()
