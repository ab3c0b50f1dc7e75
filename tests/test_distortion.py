"""Lens distortion and intrinsics (tofjax._distortion, docs/model.md "Lens distortion and
intrinsics"): the rays are the ones OpenCV's projection maps onto each pixel, written here
independently of the model (and with cv2 itself where it is installed); no distortion is the pinhole
to the bit; a folding distortion is refused; the rays have gradients in the coefficients."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import tofjax as tj
from tofjax._distortion import undistort

from helpers import COLS, ROWS, opencv_project, small, to_opencv

#: A wide-angle lens with every term: barrel, a little mustache, decentring.
LENS = dict(distortion_k1=-0.28, distortion_k2=0.09, distortion_p1=0.002, distortion_p2=-0.0015, distortion_k3=-0.01)


@pytest.mark.parametrize("k", [[-0.35, 0.12, 1e-3, -2e-3, -0.02], [0.4, -0.2, 0.01, 0.01, 0.05]])
def test_undistort_inverts_opencv_distortion(k):
    """Points across a 100-degree field, distorted by the formula above, come back to 1e-13."""
    rng = np.random.default_rng(0)
    x, y = rng.uniform(-1.2, 1.2, 5000), rng.uniform(-0.9, 0.9, 5000)
    u = opencv_project(np.stack([x, y, np.ones_like(x)], -1), np.eye(3), k)
    dx, dy = undistort(jnp.asarray(u[:, 0]), jnp.asarray(u[:, 1]), jnp.asarray(k))
    np.testing.assert_allclose(u[:, 0] + np.asarray(dx), x, atol=1e-13)
    np.testing.assert_allclose(u[:, 1] + np.asarray(dy), y, atol=1e-13)


def test_every_ray_lands_on_its_pixel_under_opencvs_projection():
    """Each pixel centre's ray and each sub-pixel ray, projected with the intrinsics the model
    reports, lands where it starts on the array (to 1e-9 pixel); with cv2 too where installed."""
    params, settings = small(), tj.FrameSettings(subpixel_samples=2, **LENS)
    cam = tj.optics.intrinsics(params, settings)
    assert (cam["width"], cam["height"]) == (COLS, ROWS) and cam["dist_coeffs"] == [-0.28, 0.09, 0.002, -0.0015, -0.01]
    rays = tj.optics.frame_rays(params, settings)
    uv = opencv_project(to_opencv(np.asarray(rays.centre)), cam["camera_matrix"], cam["dist_coeffs"])
    rows, cols = np.mgrid[0:ROWS, 0:COLS]
    np.testing.assert_allclose(uv[..., 0], cols, atol=1e-9)
    np.testing.assert_allclose(uv[..., 1], rows, atol=1e-9)
    sub = opencv_project(to_opencv(np.asarray(rays.samples)), cam["camera_matrix"], cam["dist_coeffs"])
    offsets = np.array([-0.25, 0.25])  # 2 x 2 rays per pixel at the centres of its quarters, row-major
    np.testing.assert_allclose(sub[..., 0], cols[..., None] + np.tile(offsets, 2), atol=1e-9)
    np.testing.assert_allclose(sub[..., 1], rows[..., None] + np.repeat(offsets, 2), atol=1e-9)
    # Barrel distortion widens the field: the corner pixel looks further out than the pinhole's.
    pinhole = np.asarray(tj.optics.frame_rays(params, tj.FrameSettings(subpixel_samples=2)).centre)
    assert np.asarray(rays.centre)[0, 0, 2] < pinhole[0, 0, 2] - 0.01
    try:
        import cv2
    except ImportError:  # not a test dependency: the NumPy formula above is the check
        return
    projected, _ = cv2.projectPoints(to_opencv(np.asarray(rays.centre)).reshape(-1, 1, 3), np.zeros(3), np.zeros(3),
                                     np.asarray(cam["camera_matrix"]), np.asarray(cam["dist_coeffs"]))
    np.testing.assert_allclose(projected.reshape(ROWS, COLS, 2), np.stack([cols, rows], -1), atol=1e-6)


def test_no_distortion_is_the_pinhole_to_the_bit():
    """Coefficients of 0 (the default) add exactly nothing to the rays (both compiled, as frame_rays
    is: an eager computation rounds differently in the last bit)."""
    from tofjax._scene import pixel_rays

    params = small()
    rays = tj.optics.frame_rays(params, tj.FrameSettings(subpixel_samples=2))
    pinhole = jax.jit(pixel_rays, static_argnums=(1, 2))(params.camera, (ROWS, COLS), 2)
    np.testing.assert_array_equal(rays.samples, pinhole.samples)
    np.testing.assert_array_equal(rays.centre, pinhole.centre)


def test_a_distortion_that_folds_the_image_is_refused():
    with pytest.raises(ValueError, match=r"frame.distortion_\(k1, k2, p1, p2, k3\) = \[-2.0, 0.0, 0.0, 0.0, 0.0\] folds "
                                         "the image inside the array's field"):
        tj.Camera(small(), tj.FrameSettings(distortion_k1=-2.0))


def test_the_rays_have_gradients_in_the_coefficients():
    """d(corner ray's x) / d k1 against a central difference of the rays (rel. 1e-6)."""
    params = small()

    def corner_x(k1):
        settings = tj.FrameSettings(subpixel_samples=1, **{**LENS, "distortion_k1": k1})
        return tj.optics.frame_rays(params, settings).centre[0, 0, 0]

    h = 1e-6
    fd = (corner_x(-0.28 + h) - corner_x(-0.28 - h)) / (2 * h)
    np.testing.assert_allclose(jax.grad(corner_x)(-0.28), fd, rtol=1e-6)
