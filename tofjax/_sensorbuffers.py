"""A renderer's buffers on a ToF camera's pixel rays (issue 51; docs/simulators.md, "Resampling"): the
depth, normal, reflectivity and velocity images of a simulator's camera, at its own resolution and
intrinsics, become what each of the ToF camera's rays sees.

**The buffer's camera.** A pinhole (or an OpenCV Brown-Conrady lens) at the ToF camera's optical
centre, looking along the same axis: its intrinsics in OpenCV's convention (pixel centres at whole
numbers, (0, 0) the top-left pixel's, y down), as :func:`buffer_intrinsics` reads them from a
``tofjax-intrinsics/1`` dictionary (:func:`tofjax.optics.intrinsics`, a
:class:`tofjax.renderers.Render`'s), ``(fx, fy, cx, cy)`` or a field of view.

**The resampling** (:class:`Plan`, made once per buffer camera). Each ToF ray (through the ToF lens'
distortion) is projected into the buffer's image. Depth is interpolated as *inverse planar depth*
1/Z, which is affine in the image coordinates on any plane, so that bilinear interpolation is exact
on planes: bilinear where the four neighbouring buffer pixels *agree* (:func:`continuity`: all four
hold a surface, the same segmentation id where one is given, and every edge of the cell is
continuous), else the nearest buffer pixel's depth, so that no ray sees a blend of two surfaces
across a depth edge (a flying pixel the buffer does not contain). Normals, reflectivity,
segmentation and velocity are taken from the nearest buffer pixel. A ray at most half a pixel beyond
the outermost buffer pixel centres takes the border's values; a buffer that does not cover every
ray is refused (:func:`make_plan`). The ray's distance is then Z / d_z, d its unit direction: the
buffer's depth along the very same line. A buffer at the camera's own intrinsics is read pixel for
pixel (the plan's weights are snapped to 0 and 1: exact).

**Continuity.** Two neighbouring buffer pixels a, b (inverse depths w_a, w_b) lie on one surface
when the jump is small, |w_a - w_b| <= ``edge_fraction`` max(w_a, w_b), or when the pair continues a
straight line of inverse depth on either side (the second difference w_{a-1} - 2 w_a + w_b, or w_a -
2 w_b + w_{b+1}, within ``planar_tolerance`` w_a): a plane seen at a grazing angle has large jumps and
zero second differences; a depth edge has a large jump and large second differences on both sides.

**Normals from the depth** where the buffer has none: the cross product of the surface's derivatives
along the buffer's rows and columns, each a central difference where both neighbours are continuous,
one-sided where one is, and facing the camera where neither is (an isolated pixel).
"""

from __future__ import annotations

import math

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

#: How closely a buffer's intrinsics must agree with the camera's to be read pixel for pixel
#: (relative; :data:`tofjax.renderers._render.INTRINSICS_RTOL`, a renderer's float32 projection).
SAME_RTOL = 1e-6
#: Weights this close to 0 or 1 are snapped (a buffer at the camera's intrinsics reads pixel for pixel).
SNAP = 1e-9
#: The continuity tests' defaults (module docstring).
EDGE_FRACTION = 0.01
PLANAR_TOLERANCE = 1e-3


def buffer_intrinsics(shape: tuple[int, int], camera: dict, intrinsics=None, fov_deg=None) -> dict:
    """The intrinsics of a buffer of ``shape = (rows, cols)``: ``intrinsics`` (a dictionary in
    :func:`tofjax.optics.intrinsics`' layout, or ``(fx, fy, cx, cy)`` in pixels), or ``fov_deg`` (the
    horizontal field of view in degrees, square pixels; or ``(horizontal, vertical)``) with the
    principal point at the image's centre, ((cols - 1)/2, (rows - 1)/2); neither: the ``camera``'s
    (the buffer must then have its resolution). ``ValueError`` in one line otherwise."""
    rows, cols = shape
    if intrinsics is not None and fov_deg is not None:
        raise ValueError("give the buffer's intrinsics or its fov_deg, not both")
    if intrinsics is None and fov_deg is None:
        if (rows, cols) != (camera["height"], camera["width"]):
            raise ValueError(f"the depth buffer is {cols} x {rows} pixels, the camera {camera['width']} x "
                             f"{camera['height']}: give the renderer's intrinsics= (fx, fy, cx, cy) or fov_deg= so "
                             "that the buffer can be resampled onto the camera's rays")
        return dict(camera)
    if fov_deg is not None:
        fov = np.atleast_1d(np.asarray(fov_deg, dtype=float))
        if fov.shape not in ((1,), (2,)) or not np.all(np.isfinite(fov)) or np.any(fov <= 0.0) or np.any(fov >= 180.0):
            raise ValueError(f"fov_deg = {fov_deg!r}: allowed the horizontal field of view in degrees (0, 180), or "
                             "(horizontal, vertical)")
        fx = 0.5 * cols / math.tan(math.radians(float(fov[0])) / 2.0)
        fy = fx if fov.size == 1 else 0.5 * rows / math.tan(math.radians(float(fov[1])) / 2.0)
        values, dist = (fx, fy, 0.5 * (cols - 1), 0.5 * (rows - 1)), [0.0] * 5
    elif isinstance(intrinsics, dict):
        try:
            values = tuple(float(intrinsics[k]) for k in ("fx", "fy", "cx", "cy"))
        except KeyError as err:
            raise ValueError(f"intrinsics lack {err.args[0]!r}: allowed a dictionary with fx, fy, cx, cy (pixels; "
                             "tofjax.optics.intrinsics' layout) or (fx, fy, cx, cy)") from None
        if "width" in intrinsics and (int(intrinsics["width"]), int(intrinsics["height"])) != (cols, rows):
            raise ValueError(f"the intrinsics are of a {intrinsics['width']} x {intrinsics['height']} image, the "
                             f"depth buffer is {cols} x {rows}")
        dist = [float(x) for x in intrinsics.get("dist_coeffs", [0.0] * 5)]
        if len(dist) != 5:
            raise ValueError(f"intrinsics' dist_coeffs = {dist}: allowed OpenCV's five (k1, k2, p1, p2, k3)")
    else:
        flat = np.asarray(intrinsics, dtype=float).reshape(-1)
        if flat.shape != (4,):
            raise ValueError(f"intrinsics = {intrinsics!r}: allowed (fx, fy, cx, cy) in pixels or a dictionary")
        values, dist = tuple(float(x) for x in flat), [0.0] * 5
    fx, fy, cx, cy = values
    if not all(math.isfinite(x) for x in (*values, *dist)) or fx <= 0.0 or fy <= 0.0:
        raise ValueError(f"intrinsics fx = {fx}, fy = {fy}, cx = {cx}, cy = {cy}: allowed finite numbers, fx, fy > 0")
    return {"width": cols, "height": rows, "fx": fx, "fy": fy, "cx": cx, "cy": cy, "dist_coeffs": dist}


def same_camera(buffer: dict, camera: dict) -> bool:
    """Whether the buffer's intrinsics are the camera's (resolution; fx, fy, cx, cy to
    :data:`SAME_RTOL`; distortion to 1e-12)."""
    if (buffer["width"], buffer["height"]) != (camera["width"], camera["height"]):
        return False
    return (all(abs(buffer[k] - camera[k]) <= SAME_RTOL * max(abs(camera[k]), 1.0) for k in ("fx", "fy", "cx", "cy"))
            and np.allclose(buffer["dist_coeffs"], camera["dist_coeffs"], rtol=0.0, atol=1e-12))


def _distort(x, y, k):
    k1, k2, p1, p2, k3 = k
    r2 = x * x + y * y
    radial = 1.0 + k1 * r2 + k2 * r2 * r2 + k3 * r2 * r2 * r2
    return x * radial + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x), y * radial + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y


def buffer_rays(intrinsics: dict) -> np.ndarray:
    """Unit rays through the buffer's pixel centres, ``(rows, cols, 3)``, in tofjax's camera frame (x
    right, y up, z along the axis), through its distortion where it has one."""
    from ._distortion import undistort

    u = np.arange(intrinsics["width"], dtype=float)[None, :]
    v = np.arange(intrinsics["height"], dtype=float)[:, None]
    xd = np.broadcast_to((u - intrinsics["cx"]) / intrinsics["fx"], (v.size, u.size))
    yd = np.broadcast_to((v - intrinsics["cy"]) / intrinsics["fy"], (v.size, u.size))
    k = np.asarray(intrinsics["dist_coeffs"], dtype=float)
    if np.any(k != 0.0):
        dx, dy = (np.asarray(a) for a in undistort(jnp.asarray(xd), jnp.asarray(yd), jnp.asarray(k)))
        xd, yd = xd + dx, yd + dy
    d = np.stack([xd, -yd, np.ones_like(xd)], axis=-1)
    return d / np.linalg.norm(d, axis=-1, keepdims=True)


class Plan(eqx.Module):
    """Where each of a camera's rays reads a buffer (module docstring), made by :func:`make_plan`.

    **Fields** (``rays``: the rays' shape, e.g. ``(rows, cols, k)``): ``corner`` ``(*rays,)`` int32,
    the flat index of the top-left buffer pixel of the cell a ray falls in; ``fu``, ``fv`` its
    position in the cell (0..1 along a row and down a column); ``nearest`` the flat index of the
    nearest buffer pixel; ``ray_z`` each camera ray's z component; ``buffer_ray_z`` ``(b_rows,
    b_cols)`` and ``buffer_rays`` ``(b_rows, b_cols, 3)``, the buffer's own unit rays; ``solid_angle_sr``
    ``(b_rows, b_cols)`` each buffer pixel's solid angle; ``cols`` (static) the buffer's width;
    ``identity`` (static): every ray is its own buffer pixel's centre ray (a buffer at the camera's
    intrinsics, one ray per pixel), which then reads its pixel without a gather."""

    corner: Array
    fu: Float[Array, "..."]
    fv: Float[Array, "..."]
    nearest: Array
    ray_z: Float[Array, "..."]
    buffer_ray_z: Float[Array, "b_rows b_cols"]
    buffer_rays: Float[Array, "b_rows b_cols 3"]
    solid_angle_sr: Float[Array, "b_rows b_cols"]
    cols: int = eqx.field(static=True)
    identity: bool = eqx.field(static=True, default=False)

    def at_rays(self, image: Array) -> Array:
        """``image`` ``(b_rows, b_cols, ...)`` at each ray's nearest buffer pixel, ``(*rays, ...)``."""
        return image[:, :, None] if self.identity else gather(image, self.nearest)


def _half_field(d: np.ndarray, axis: int) -> float:
    """The largest angle of rays ``d`` from the optical axis in the plane of ``axis`` (0: x, 1: y), degrees."""
    return float(np.degrees(np.max(np.abs(np.arctan2(d[..., axis], d[..., 2])))))


def make_plan(directions: np.ndarray, intrinsics: dict, *, what: str = "the depth buffer") -> Plan:
    """The :class:`Plan` of camera rays ``directions`` ``(*rays, 3)`` (unit, tofjax's frame) in a
    buffer of ``intrinsics`` (:func:`buffer_intrinsics`). ``ValueError`` naming how many rays fall
    outside the buffer (more than half a pixel beyond its outermost pixel centres, or behind it)."""
    d = np.asarray(directions, dtype=float)
    rows, cols = intrinsics["height"], intrinsics["width"]
    if rows < 2 or cols < 2:
        raise ValueError(f"{what} is {cols} x {rows} pixels: allowed at least 2 x 2")
    ahead = d[..., 2] > 0.0
    z = np.where(ahead, d[..., 2], 1.0)
    x, y = _distort(d[..., 0] / z, -d[..., 1] / z, np.asarray(intrinsics["dist_coeffs"], dtype=float))
    u = intrinsics["fx"] * x + intrinsics["cx"]
    v = intrinsics["fy"] * y + intrinsics["cy"]
    inside = ahead & (u >= -0.5) & (u <= cols - 0.5) & (v >= -0.5) & (v <= rows - 0.5)
    if not np.all(inside):
        outside = int(np.size(inside) - np.count_nonzero(inside))
        raise ValueError(f"{what} does not cover the camera's field of view: {outside} of its {inside.size} rays fall "
                         f"outside its {cols} x {rows} pixels (fx = {intrinsics['fx']:.6g}, fy = {intrinsics['fy']:.6g}, "
                         f"cx = {intrinsics['cx']:.6g}, cy = {intrinsics['cy']:.6g}); the camera's rays reach "
                         f"{_half_field(d, 0):.4g} deg to either side and {_half_field(d, 1):.4g} deg up or down of the "
                         "axis: render a wider field of view")
    uc, vc = np.clip(u, 0.0, cols - 1.0), np.clip(v, 0.0, rows - 1.0)
    i0 = np.minimum(np.floor(uc), cols - 2).astype(np.int64)
    j0 = np.minimum(np.floor(vc), rows - 2).astype(np.int64)
    fu, fv = uc - i0, vc - j0
    for f in (fu, fv):  # a ray on a pixel centre reads that pixel exactly
        f[np.abs(f) < SNAP] = 0.0
        f[np.abs(f - 1.0) < SNAP] = 1.0
    near = np.rint(vc).astype(np.int64) * cols + np.rint(uc).astype(np.int64)
    rays = buffer_rays(intrinsics)
    # A pinhole buffer pixel's solid angle, d_z^3 / (fx fy); a distorted buffer's from its rays.
    if np.any(np.asarray(intrinsics["dist_coeffs"]) != 0.0):
        du = np.gradient(rays / rays[..., 2:], axis=1)
        dv = np.gradient(rays / rays[..., 2:], axis=0)
        omega = np.linalg.norm(np.cross(du, dv), axis=-1) * rays[..., 2] ** 3
    else:
        omega = rays[..., 2] ** 3 / (intrinsics["fx"] * intrinsics["fy"])
    # Every ray on its own pixel's centre: the weights all snapped to 0 or 1 (1 in the last row and
    # column, whose cell is the one before), the nearest pixel its own.
    on_centres = np.all((fu == 0.0) | (fu == 1.0)) and np.all((fv == 0.0) | (fv == 1.0))
    identity = (d.ndim == 4 and d.shape[:2] == (rows, cols) and d.shape[2] == 1 and bool(on_centres)
                and np.array_equal(near.reshape(rows, cols), np.arange(rows * cols).reshape(rows, cols)))
    return Plan(jnp.asarray(j0 * cols + i0, dtype=jnp.int32), jnp.asarray(fu), jnp.asarray(fv),
                jnp.asarray(near, dtype=jnp.int32), jnp.asarray(d[..., 2]), jnp.asarray(rays[..., 2]),
                jnp.asarray(rays), jnp.asarray(omega), cols, bool(identity))


def planar_depth(depth: Array, radial: bool, buffer_ray_z: Array, max_range_m) -> tuple[Array, Array]:
    """A buffer's planar depth Z and where it holds a surface: finite, > 0 and within
    ``max_range_m`` (the buffer's own values, radial or planar)."""
    surface = jnp.isfinite(depth) & (depth > 0.0) & (depth <= max_range_m)
    z = depth * buffer_ray_z if radial else depth
    return jnp.where(surface, z, 1.0), surface


def continuity(w: Array, surface: Array, segmentation: Array | None, edge_fraction, planar_tolerance
               ) -> tuple[Array, Array]:
    """Whether neighbouring buffer pixels lie on one surface (module docstring), along the rows
    ``(rows, cols - 1)`` (pixel (r, c) and (r, c + 1)) and the columns ``(rows - 1, cols)``."""

    def along(w, s, seg):  # pairs (i, i + 1) along the last axis
        both = s[..., :-1] & s[..., 1:]
        small = jnp.abs(w[..., :-1] - w[..., 1:]) <= edge_fraction * jnp.maximum(w[..., :-1], w[..., 1:])
        # The second difference centred at pixel k + 1 (pixels k, k + 1, k + 2 on a surface), small:
        # pair i continues a line on its left (centred at i) or on its right (centred at i + 1).
        second = jnp.abs(w[..., :-2] - 2.0 * w[..., 1:-1] + w[..., 2:])
        line = s[..., :-2] & s[..., 1:-1] & s[..., 2:] & (second <= planar_tolerance * w[..., 1:-1])
        false = jnp.zeros(line.shape[:-1] + (1,), bool)
        ok = both & (small | jnp.concatenate([false, line], axis=-1) | jnp.concatenate([line, false], axis=-1))
        if seg is not None:
            ok = ok & (seg[..., :-1] == seg[..., 1:])
        return ok

    rows = along(w, surface, segmentation)
    cols = along(w.T, surface.T, None if segmentation is None else segmentation.T).T
    return rows, cols


def depth_normals(points: Array, along_rows: Array, along_cols: Array, rays: Array) -> Array:
    """Unit normals of the buffer's surface from its points ``(rows, cols, 3)`` (module docstring),
    facing the camera. Differences by slices and the cross product by components: elementwise work
    XLA fuses (gathers along an axis and a stacked cross product took 16 ms at 640 x 480)."""
    from ._scene import _facing

    def derivative(axis):  # per component: central, one-sided or 0, as the pairs' continuity allows
        ok = along_rows if axis == 1 else along_cols
        false = jnp.zeros_like(jnp.take(ok, jnp.array([0]), axis=axis))
        right = jnp.concatenate([ok, false], axis=axis)  # pixel i and i + 1 continuous
        left = jnp.concatenate([false, ok], axis=axis)  # pixel i - 1 and i continuous
        out = []
        for k in range(3):
            p = points[..., k]
            n = p.shape[axis]
            step = (jax.lax.slice_in_dim(p, 1, n, axis=axis) - jax.lax.slice_in_dim(p, 0, n - 1, axis=axis))
            zero = jnp.zeros_like(jax.lax.slice_in_dim(p, 0, 1, axis=axis))
            forward = jnp.concatenate([step, zero], axis=axis)
            backward = jnp.concatenate([zero, step], axis=axis)
            out.append(jnp.where(left & right, 0.5 * (forward + backward),
                                 jnp.where(right, forward, jnp.where(left, backward, 0.0))))
        return out

    ux, uy, uz = derivative(1)
    vx, vy, vz = derivative(0)
    nx, ny, nz = uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx
    length = jnp.sqrt(nx * nx + ny * ny + nz * nz)
    ok = length > 0.0
    inv = 1.0 / jnp.where(ok, length, 1.0)
    n = jnp.stack([nx * inv, ny * inv, nz * inv], axis=-1)
    return _facing(jnp.where(ok[..., None], n, -rays), rays)


def gather(image: Array, index: Array) -> Array:
    """``image`` ``(rows, cols, ...)`` at flat pixel indices ``index`` (any shape)."""
    flat = image.reshape((-1,) + image.shape[2:])
    return flat[index]


def interpolated_inverse_depth(plan: Plan, w: Array, surface: Array, along_rows: Array, along_cols: Array
                               ) -> tuple[Array, Array]:
    """Each ray's inverse planar depth and whether it meets a surface (module docstring): bilinear
    where its cell's four pixels agree, else the nearest pixel's."""
    if plan.identity:  # every ray on its own pixel's centre: its pixel's value
        return w[:, :, None], surface[:, :, None]
    c = plan.cols
    i00, i01, i10, i11 = plan.corner, plan.corner + 1, plan.corner + c, plan.corner + c + 1
    cell = (along_rows[:-1, :] & along_rows[1:, :] & along_cols[:, :-1] & along_cols[:, 1:])  # (rows-1, cols-1)
    r0, c0 = plan.corner // c, plan.corner % c
    agree = cell[r0, c0]
    fu, fv = plan.fu, plan.fv
    wf = w.reshape(-1)
    bilinear = ((1.0 - fv) * ((1.0 - fu) * wf[i00] + fu * wf[i01]) + fv * ((1.0 - fu) * wf[i10] + fu * wf[i11]))
    near = wf[plan.nearest]
    near_ok = surface.reshape(-1)[plan.nearest]
    return jnp.where(agree, bilinear, near), agree | near_ok
