"""float32 frames (issue 35 item 4, tofjax.Camera.astype): the noise image and the noisy frames of the
built-in scenes in float32 against float64, with the bounds docs/model.md states ("float32 frames"). The
same key draws the same normals in both precisions (the generator's own are float32), so the frames
compare pixel by pixel."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import tofjax as tj
from tofjax import scenes

PITCH = 17.5e-6
ROWS, COLS = 24, 32  # small: the programs, not the pixels, cost the time here


@pytest.fixture(scope="module")
def cameras():
    params = tj.Params()
    params = params.__class__(**{**vars(params), "camera": params.camera.__class__(
        **{**vars(params.camera), "optical_area_m": jnp.array([COLS * PITCH, ROWS * PITCH])})})
    cam = tj.Camera(params, tj.FrameSettings())
    return cam, cam.astype("float32")


@pytest.mark.parametrize("scene", [scenes.tilted_plane(1.2, 30.0), scenes.step_edge(1.0, 1.6), scenes.corner(1.5)],
                         ids=["tilted_plane", "step_edge", "corner"])
def test_float32_frames_are_float64s_within_the_stated_bounds(cameras, scene):
    cam, cam32 = cameras
    e64, e32 = cam.expose(scene), cam32.expose(scene)
    n64, n32 = np.asarray(e64.noise_image()), e32.noise_image()
    assert n32.dtype == jnp.float32 and e32.chain.dtype == jnp.float32
    assert np.array_equal(np.isfinite(n64), np.isfinite(np.asarray(n32)))
    np.testing.assert_allclose(np.asarray(n32, dtype=float), n64, rtol=5e-5)  # measured: <= 1e-5
    f64, f32 = e64.sample(jax.random.key(1), 64), e32.sample(jax.random.key(1), 64)
    assert f32.radial_m.dtype == jnp.float32
    np.testing.assert_array_equal(np.asarray(f32.valid), np.asarray(f64.valid))
    period = float(e64.chain.unambiguity_range_m)
    d = np.abs(np.asarray(f32.radial_m, dtype=float) - np.asarray(f64.radial_m))
    d = np.minimum(d, period - d)  # a pixel at the wrap may land on the other side of it
    assert np.nanpercentile(d, 99.9) < 1e-6 and np.nanmax(d) < 2e-2  # measured: 1.8e-7 and 6.5e-3 m
    std64, std32 = np.nanstd(np.asarray(f64.radial_m), axis=0), np.nanstd(np.asarray(f32.radial_m, dtype=float), axis=0)
    np.testing.assert_allclose(std32, std64, rtol=2e-2)  # measured: 0.5 %


def test_float32_is_a_frame_option_and_says_so(cameras):
    cam, cam32 = cameras
    assert cam.astype("float64") == cam and cam32.precision == "float32"
    with pytest.raises(ValueError, match=r"a sweep runs in float64: this camera computes its frames in precision = "
                                         r"'float32' \(Camera.astype\).*camera.astype\('float64'\)"):
        tj.predict(cam32, tj.Sweep("distance", [1.0]))
    with pytest.raises(ValueError, match=r"Camera: precision = 'float16' is not allowed: expected one of 'float64', "
                                         "'float32'"):
        cam.astype("float16")


def test_a_float32_camera_refuses_what_it_does_not_run_in_float32(cameras):
    _, cam32 = cameras
    moving = scenes.moving(scenes.wall(1.2), [0.0, 0.0, 1.0], substeps=1)
    with pytest.raises(ValueError, match=r"a float32 camera \(Camera.astype\) runs a static scene of its own light; "
                                         r"these returns are a moving scene's"):
        cam32.expose(moving)
