"""MuJoCo's renderer behind a ToF camera (issue 51 item 3; docs/renderers.md, "MuJoCo"):
``mujoco.Renderer``'s depth and segmentation of a named camera, headless.

What MuJoCo gives: after ``enable_depth_rendering()``, ``Renderer.render()`` returns the depth
buffer converted to metres, the **planar (Z) depth** along the camera's optical axis (the OpenGL
projection undone: ``d / (z_ndc + c)`` with the model's ``znear``, ``zfar`` times its extent), as
float32: 2-3 float32 steps of error (tested: 0.65 um at 3 m, 1.4 um at 7 m). Pixels that see nothing
read the far plane; here they are ``inf`` (the segmentation says which). MuJoCo gives no normals.
Its camera looks along its frame's -z with +y up; tofjax's camera frame has +z forward, so a point
(x, y, z) of tofjax's frame is (x, y, -z) in the MuJoCo camera's frame.

Its intrinsics: a camera of ``fovy`` (degrees, the full vertical field) rendered at width x height
pixels is a pinhole with fy = fx = height / (2 tan(fovy / 2)) and the principal point at the image
centre, (cx, cy) = ((width - 1) / 2, (height - 1) / 2) in OpenCV's convention (pixel centres at whole
numbers); a camera with ``sensorsize`` / ``focal`` / ``principal`` has the intrinsics of the frustum
MuJoCo computes for it (:func:`frustum_intrinsics`). For a :class:`tofjax.Camera` the frustum is
set to that camera's own intrinsics (its resolution, focal length in pixels, principal point), so
the depth map is pixel for pixel the camera's: ``render.to_returns(camera)``.

Headless rendering needs ``MUJOCO_GL=egl`` (Mesa's EGL; on a machine without a GPU its llvmpipe) or
``MUJOCO_GL=osmesa``, set before MuJoCo is first imported; this module sets neither.
"""

from __future__ import annotations

import math

import numpy as np

from ._render import Render, camera_intrinsics, pinhole_directions, pinhole_intrinsics, require

mujoco = require("mujoco", "mujoco", "tofjax.renderers.mujoco")

__all__ = ["DepthCamera", "frustum_intrinsics", "render"]


def frustum_intrinsics(frustum: tuple[float, float, float, float, float], width: int, height: int) -> dict:
    """The pinhole intrinsics of an OpenGL frustum ``(left, right, bottom, top, near)`` (view space,
    at the near plane) rendered at ``width`` x ``height`` pixels, in OpenCV's convention: a point at
    depth Z and height X lands at the window's u = width (near X / Z - left) / (right - left) from
    its left edge, so fx = width near / (right - left) and cx = -width left / (right - left) - 1/2
    (the centre of pixel 0 at u = 1/2); rows run down from the top, so fy = height near / (top -
    bottom) and cy = height top / (top - bottom) - 1/2."""
    left, right, bottom, top, near = (float(x) for x in frustum)
    return pinhole_intrinsics(width, height, width * near / (right - left), height * near / (top - bottom),
                              -width * left / (right - left) - 0.5, height * top / (top - bottom) - 0.5)


def _frustum_of(intrinsics: dict, near: float) -> tuple[float, float, float, float]:
    """The frustum ``(centre, half width, bottom, top)`` at ``near`` of pinhole ``intrinsics``
    (:func:`frustum_intrinsics` inverted)."""
    w, h = intrinsics["width"], intrinsics["height"]
    left = -(intrinsics["cx"] + 0.5) * near / intrinsics["fx"]
    right = left + w * near / intrinsics["fx"]
    top = (intrinsics["cy"] + 0.5) * near / intrinsics["fy"]
    return 0.5 * (left + right), 0.5 * (right - left), top - h * near / intrinsics["fy"], top


def _camera_id(model, camera) -> int:
    if isinstance(camera, str):
        cid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_CAMERA, camera)
        if cid < 0:
            names = [model.camera(i).name for i in range(model.ncam)]
            raise ValueError(f"the MuJoCo model has no camera {camera!r}: it has {', '.join(map(repr, names)) or 'none'}")
        return cid
    if isinstance(camera, bool) or not isinstance(camera, int | np.integer) or not 0 <= camera < model.ncam:
        raise ValueError(f"camera = {camera!r}: allowed a camera's name or its id, 0 <= id < {model.ncam}")
    return int(camera)


def _sensor_size(model, camera_id: int):
    """The camera's ``sensorsize`` (0, 0: none, a camera of ``fovy``)."""
    sizes = getattr(model, "cam_sensorsize", None)
    return (0.0, 0.0) if sizes is None else sizes[camera_id]


class DepthCamera:
    """A MuJoCo camera that renders depth and segmentation, frame after frame (one OpenGL context,
    kept): ``DepthCamera(model, "tof")``, then ``.render(data)`` after each ``mj_step``.

    ``camera``: the camera's name or id. ``tofjax_camera``: a :class:`tofjax.Camera` whose
    resolution and intrinsics the depth map takes (its pose is the MuJoCo camera's; it must have no
    lens distortion: MuJoCo renders a pinhole, and :mod:`tofjax.renderers.open3d` casts along a
    distorted lens' rays). Without it, ``width`` and ``height`` (default: the camera's
    ``resolution`` in the model, where it names one) and the MuJoCo camera's own intrinsics. The
    model's offscreen buffer (``visual/global offwidth, offheight``) is enlarged when it is smaller
    than the image.
    """

    def __init__(self, model, camera, *, tofjax_camera=None, width: int | None = None, height: int | None = None):
        self.model = model
        self.camera_id = _camera_id(model, camera)
        # Orthographic cameras: cam_projection (newer MuJoCo), cam_orthographic (older), none (3.1).
        flags = [getattr(model, name, None) for name in ("cam_projection", "cam_orthographic")]
        orthographic = any(f is not None and f[self.camera_id] != 0 for f in flags)
        if orthographic:
            raise ValueError(f"MuJoCo camera {camera!r} is orthographic: a ToF camera is a perspective one")
        self._override = None
        if tofjax_camera is not None:
            if width is not None or height is not None:
                raise ValueError("give tofjax_camera or width and height, not both: the tofjax camera has its resolution")
            intrinsics = camera_intrinsics(tofjax_camera)
            if any(intrinsics["dist_coeffs"]):
                raise ValueError("MuJoCo renders a pinhole and this camera's lens has distortion (frame.distortion_*): "
                                 "cast along its own rays with tofjax.renderers.open3d, or render without distortion")
            width, height = intrinsics["width"], intrinsics["height"]
            self._override = intrinsics
        elif width is None and height is None and _sensor_size(model, self.camera_id)[1] > 0:
            width, height = (int(x) for x in model.cam_resolution[self.camera_id])
        if width is None or height is None:
            raise ValueError("give width and height (pixels), or tofjax_camera")
        for name, n in (("width", width), ("height", height)):
            if isinstance(n, bool) or not isinstance(n, int | np.integer) or not 1 <= n <= 16384:
                raise ValueError(f"{name} = {n!r}: allowed an integer of pixels, 1 <= value <= 16384")
        self.width, self.height = int(width), int(height)
        buffer = model.vis.global_
        buffer.offwidth, buffer.offheight = max(buffer.offwidth, self.width), max(buffer.offheight, self.height)
        try:
            self._renderer = mujoco.Renderer(model, self.height, self.width)
        except Exception as err:  # no OpenGL context: say how to get one, in one line
            import os

            first = (str(err).strip().splitlines() or [type(err).__name__])[0]
            raise RuntimeError(f"MuJoCo could not render (MUJOCO_GL={os.environ.get('MUJOCO_GL', '')!r}): {first}; "
                               "headless: MUJOCO_GL=egl or osmesa before MuJoCo is imported (docs/renderers.md lists "
                               "the system libraries)") from None

    def close(self) -> None:
        """Free the OpenGL context."""
        self._renderer.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def _update(self, data) -> dict:
        """Place the scene's camera; returns the intrinsics it renders with."""
        r = self._renderer
        r.update_scene(data, camera=self.camera_id)
        cams = [r.scene.camera[0], r.scene.camera[1]]  # the two eyes; mono renders their average
        near = float(cams[0].frustum_near)
        if self._override is not None:
            centre, half, bottom, top = _frustum_of(self._override, near)
            for c in cams:
                c.frustum_center, c.frustum_width, c.frustum_bottom, c.frustum_top = centre, half, bottom, top
            return self._override
        c = cams[0]
        half = float(getattr(c, "frustum_width", 0.0))
        if half == 0.0:  # a fovy camera: the half width follows the image's aspect (MuJoCo's rule)
            fy = self.height / (2.0 * math.tan(math.radians(float(self.model.cam_fovy[self.camera_id])) / 2.0))
            return pinhole_intrinsics(self.width, self.height, fy, fy, 0.5 * (self.width - 1), 0.5 * (self.height - 1))
        left, right = float(c.frustum_center) - half, float(c.frustum_center) + half
        return frustum_intrinsics((left, right, float(c.frustum_bottom), float(c.frustum_top), near), self.width,
                                  self.height)

    def render(self, data) -> Render:
        """The camera's view of ``data`` (an ``MjData`` after ``mj_forward`` or ``mj_step``): planar
        depth (``depth_type="z"``, float64 of MuJoCo's float32 metres, ``inf`` where nothing), geom
        ids (``segmentation``; -1 where the pixel sees no geom) and the object types
        (``extra["object_type"]``, mjtObj), no normals."""
        r = self._renderer
        intrinsics = self._update(data)
        r.enable_segmentation_rendering()
        seg = r.render()
        r.enable_depth_rendering()
        depth = r.render().astype(float)
        r.disable_depth_rendering()
        objid, objtype = seg[..., 0], seg[..., 1]
        depth[objid < 0] = np.inf
        segmentation = np.where(objtype == int(mujoco.mjtObj.mjOBJ_GEOM), objid, -1).astype(np.int32)
        return Render(depth, "z", intrinsics, segmentation, None, pinhole_directions(intrinsics), "mujoco",
                      {"object_type": objtype.astype(np.int32)})


def render(model, data, camera, *, tofjax_camera=None, width: int | None = None, height: int | None = None) -> Render:
    """One view of ``data`` through the MuJoCo camera ``camera`` (:class:`DepthCamera`, made and closed
    for this call; keep a :class:`DepthCamera` for a stream of frames)."""
    with DepthCamera(model, camera, tofjax_camera=tofjax_camera, width=width, height=height) as cam:
        return cam.render(data)
