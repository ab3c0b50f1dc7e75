"""Lens distortion of the frame's rays: the Brown-Conrady model in OpenCV's convention (docs/model.md,
"Lens distortion and intrinsics").

OpenCV (``cv2.projectPoints``, ``cv2.calibrateCamera``) maps a point's normalised image coordinates
(x, y) = (X/Z, Y/Z), camera frame x right, **y down**, to its distorted ones

    r^2 = x^2 + y^2,  R = 1 + k1 r^2 + k2 r^4 + k3 r^6
    x_d = x R + 2 p1 x y + p2 (r^2 + 2 x^2)
    y_d = y R + p1 (r^2 + 2 y^2) + 2 p2 x y

and the pixel (u, v) = (fx x_d + cx, fy y_d + cy) (D. C. Brown, "Decentering distortion of lenses",
Photogrammetric Engineering 32, 1966; OpenCV's "Camera Calibration and 3D Reconstruction"). The
coefficients come in OpenCV's order ``(k1, k2, p1, p2, k3)``. A pixel sees along the ray whose
*undistorted* coordinates map onto its position: :func:`undistort` inverts the map by Newton's
method with the closed-form Jacobian, a fixed number of steps (quadratic convergence: within 1e-15
after a few steps where the map is one-to-one, which :func:`check_one_to_one` makes sure of).
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

#: Newton steps of :func:`undistort`: from the distorted point, 8 reach rounding for any one-to-one
#: distortion of the schema's range over a field up to 150 degrees (tests/test_distortion.py).
NEWTON_STEPS = 8
#: The residual (normalised image units, ~ pixels / 1000 at f = 1000 px) that counts as converged.
TOLERANCE = 1e-10


def distort(x, y, coefficients):
    """OpenCV's distortion of normalised coordinates ``(x, y)`` (y down; module docstring):
    ``(x_d, y_d)``. ``coefficients``: ``(k1, k2, p1, p2, k3)``."""
    k1, k2, p1, p2, k3 = (coefficients[i] for i in range(5))
    r2 = x * x + y * y
    radial = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3))
    return (x * radial + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x),
            y * radial + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y)


def _jacobian(x, y, coefficients):
    """d(x_d, y_d) / d(x, y): ``(a, b, c)`` with J = [[a, b], [b, c]] (it is symmetric)."""
    k1, k2, p1, p2, k3 = (coefficients[i] for i in range(5))
    r2 = x * x + y * y
    radial = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3))
    slope = k1 + r2 * (2.0 * k2 + 3.0 * r2 * k3)  # dR / d(r^2)
    a = radial + 2.0 * x * x * slope + 2.0 * p1 * y + 6.0 * p2 * x
    b = 2.0 * x * y * slope + 2.0 * p1 * x + 2.0 * p2 * y
    c = radial + 2.0 * y * y * slope + 6.0 * p1 * y + 2.0 * p2 * x
    return a, b, c


def undistort(xd: Float[Array, "..."], yd: Float[Array, "..."], coefficients: Float[Array, "5"]
              ) -> tuple[Float[Array, "..."], Float[Array, "..."]]:
    """The offsets ``(x - x_d, y - y_d)`` of the undistorted coordinates whose :func:`distort` is
    ``(xd, yd)``: :data:`NEWTON_STEPS` Newton steps from ``(xd, yd)``. Offsets, so that a camera
    without distortion adds exactly 0 to its rays (every coefficient 0: each step is exactly 0)."""
    def step(_, offset):
        dx, dy = offset
        x, y = xd + dx, yd + dy
        fx, fy = distort(x, y, coefficients)
        rx, ry = fx - xd, fy - yd
        a, b, c = _jacobian(x, y, coefficients)
        det = a * c - b * b
        return dx - (c * rx - b * ry) / det, dy - (a * ry - b * rx) / det

    zero = jnp.zeros_like(xd + yd)
    return jax.lax.fori_loop(0, NEWTON_STEPS, step, (zero, zero))


def check_one_to_one(coefficients, half_extent: tuple[float, float], what: str) -> None:
    """``ValueError`` naming ``what`` unless the distortion is one-to-one over the array: on a 65 x 65
    grid of the array's normalised extent (``half_extent``: its half width and height over the focal
    length, edges included) the inverse converges and the Jacobian's determinant stays positive
    there and along the diagonals out to the corners. Concrete coefficients only (skipped when traced)."""
    from ._schema import _is_tracer

    if _is_tracer(coefficients):
        return
    k = np.asarray(coefficients, dtype=float)
    if not np.any(k):
        return
    hx, hy = half_extent
    grid = np.linspace(-1.0, 1.0, 65)
    xd, yd = np.meshgrid(grid * hx, grid * hy)
    dx, dy = (np.asarray(v) for v in undistort(jnp.asarray(xd), jnp.asarray(yd), jnp.asarray(k)))
    x, y = xd + dx, yd + dy
    fx, fy = (np.asarray(v) for v in distort(x, y, k))
    residual = np.hypot(fx - xd, fy - yd)
    a, b, c = _jacobian(x, y, k)
    t = np.linspace(0.0, 1.0, 257)[:, None]  # the undistorted rays out to each corner's
    corners = np.stack([x[[0, 0, -1, -1], [0, -1, 0, -1]], y[[0, 0, -1, -1], [0, -1, 0, -1]]])
    ca, cb, cc = _jacobian(t * corners[0], t * corners[1], k)
    ok = np.isfinite(residual) & (residual < TOLERANCE) & (a * c - b * b > 0.0) & (a > 0.0)
    if not (ok.all() and np.all(ca * cc - cb * cb > 0.0) and np.all(ca > 0.0)):
        raise ValueError(f"{what} = {k.tolist()} folds the image inside the array's field "
                         f"(normalised half extent {hx:.4g} x {hy:.4g}): allowed coefficients whose distortion is "
                         "one-to-one over the field (OpenCV's convention)")
