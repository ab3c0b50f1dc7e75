"""What every renderer returns (:class:`Render`), pinhole intrinsics in tofjax's layout, and the
one-line refusal of a missing extra. NumPy only: importing this imports no renderer."""

from __future__ import annotations

import dataclasses
import importlib

import numpy as np

#: A depth map's two conventions: ``"z"``, the planar depth along the optical axis (what an OpenGL
#: depth buffer and a depth camera's depth image hold); ``"radial"``, the distance along each pixel's
#: ray from the lens centre (what a ToF pixel measures, tofjax's ``radial_m``).
DEPTH_TYPES = ("z", "radial")


class MissingExtra(ImportError):
    """A renderer's package is not installed; the message is one line naming it and the extra."""


def require(module: str, extra: str, what: str):
    """``module`` imported, or :class:`MissingExtra` in one line: naming what needs it and the extra
    that installs it (as :func:`tofjax.cli.require` does for the commands), or, where the package is
    there but will not load (a system library missing), its own first line."""
    try:
        return importlib.import_module(module)
    except ModuleNotFoundError as err:
        if err.name is None or err.name.split(".")[0] != module.split(".")[0]:
            raise
        raise MissingExtra(f'{what} needs {module}, which is not installed: pip install "tofjax[{extra}]"') from None
    except ImportError as err:
        first = (str(err).strip().splitlines() or [type(err).__name__])[0]
        raise MissingExtra(f"{what} needs {module}, which is installed but does not load: {first} (docs/renderers.md "
                           "lists the system libraries)") from None


def pinhole_intrinsics(width: int, height: int, fx: float, fy: float, cx: float, cy: float) -> dict:
    """A pinhole camera's intrinsics in the layout of :func:`tofjax.optics.intrinsics` (OpenCV's
    convention: pixel centres at whole numbers, (0, 0) the top-left pixel's; no distortion)."""
    from .._framegeometry import INTRINSICS_CONVENTION

    fx, fy, cx, cy = float(fx), float(fy), float(cx), float(cy)
    return {"format": "tofjax-intrinsics/1", "width": int(width), "height": int(height), "fx": fx, "fy": fy,
            "cx": cx, "cy": cy, "camera_matrix": [[fx, 0.0, cx], [0.0, fy, cy], [0.0, 0.0, 1.0]],
            "dist_coeffs": [0.0] * 5, "convention": INTRINSICS_CONVENTION}


def pinhole_directions(intrinsics: dict) -> np.ndarray:
    """Unit rays through a pinhole camera's pixel centres, ``(height, width, 3)``, in tofjax's camera
    frame (x right, y up, z along the optical axis; OpenCV's y runs down)."""
    u = np.arange(intrinsics["width"], dtype=float)
    v = np.arange(intrinsics["height"], dtype=float)
    x = np.broadcast_to(((u - intrinsics["cx"]) / intrinsics["fx"])[None, :], (v.size, u.size))
    y = np.broadcast_to((-(v - intrinsics["cy"]) / intrinsics["fy"])[:, None], (v.size, u.size))
    d = np.stack([x, y, np.ones_like(x)], axis=-1)
    return d / np.linalg.norm(d, axis=-1, keepdims=True)


def camera_intrinsics(camera) -> dict:
    """A :class:`tofjax.Camera`'s intrinsics (:func:`tofjax.optics.intrinsics`)."""
    import tofjax as tj

    return tj.optics.intrinsics(camera.params, camera.settings)


#: How closely a render's intrinsics must agree with a camera's (relative): a renderer's projection
#: is float32 (MuJoCo's frustum), about 6e-8.
INTRINSICS_RTOL = 1e-6


def intrinsics_mismatch(render: dict, camera: dict) -> str | None:
    """What differs between a render's and a camera's intrinsics (``None``: they agree)."""
    if (render["width"], render["height"]) != (camera["width"], camera["height"]):
        return (f"the render is {render['width']} x {render['height']} pixels, the camera {camera['width']} x "
                f"{camera['height']}")
    for key in ("fx", "fy", "cx", "cy"):
        if abs(render[key] - camera[key]) > INTRINSICS_RTOL * max(abs(camera[key]), 1.0):
            return f"the render's {key} = {render[key]:.9g} pixels, the camera's {camera[key]:.9g}"
    if not np.allclose(render["dist_coeffs"], camera["dist_coeffs"], rtol=0.0, atol=1e-12):
        return f"the render's distortion is {render['dist_coeffs']}, the camera's {camera['dist_coeffs']}"
    return None


@dataclasses.dataclass(frozen=True, eq=False)
class Render:
    """One rendered view, in what a ToF camera takes (docs/renderers.md).

    **Fields:**
    - ``depth_m`` ``(rows, cols)``, float64, m: the depth in the convention ``depth_type`` names;
      ``inf`` where the pixel's ray meets nothing.
    - ``depth_type``: ``"z"`` (planar depth along the optical axis) or ``"radial"`` (distance along
      the pixel's ray), :data:`DEPTH_TYPES`.
    - ``intrinsics``: the camera the depth belongs to, in :func:`tofjax.optics.intrinsics`' layout
      (``width``, ``height``, ``fx``, ``fy``, ``cx``, ``cy`` in pixels, OpenCV's convention,
      ``camera_matrix``, ``dist_coeffs``).
    - ``segmentation`` ``(rows, cols)``, int32: what each pixel sees, the renderer's id (MuJoCo's geom
      id, Open3D's geometry id); -1 nothing.
    - ``normals`` ``(rows, cols, 3)`` or ``None``: the unit surface normal at each pixel, in tofjax's
      camera frame (x right, y up, z along the optical axis), facing the camera; ``None`` where the
      renderer gives none (MuJoCo), NaN where the pixel sees nothing.
    - ``directions`` ``(rows, cols, 3)``: each pixel's unit centre ray in the same frame (through the
      lens' distortion where the camera has one), what converts one depth convention to the other.
    - ``renderer``: ``"mujoco"`` or ``"open3d"``.
    - ``extra``: the backend's own per-pixel arrays (MuJoCo: ``object_type``, the mjtObj of what the
      pixel sees; Open3D: ``primitive_ids``, the triangle).
    """

    depth_m: np.ndarray
    depth_type: str
    intrinsics: dict
    segmentation: np.ndarray
    normals: np.ndarray | None
    directions: np.ndarray
    renderer: str
    extra: dict = dataclasses.field(default_factory=dict)

    def __post_init__(self):
        if self.depth_type not in DEPTH_TYPES:
            raise ValueError(f"depth_type = {self.depth_type!r}: allowed {', '.join(map(repr, DEPTH_TYPES))}")
        shape = (self.intrinsics["height"], self.intrinsics["width"])
        if self.depth_m.shape != shape or self.segmentation.shape != shape or self.directions.shape != (*shape, 3):
            raise ValueError(f"a render's depth {self.depth_m.shape}, segmentation {self.segmentation.shape} and "
                             f"directions {self.directions.shape} must be its intrinsics' {shape} (rows, cols[, 3])")

    @property
    def z_m(self) -> np.ndarray:
        """The planar depth along the optical axis, m (``inf``: nothing)."""
        return self.depth_m if self.depth_type == "z" else self.depth_m * self.directions[..., 2]

    @property
    def radial_m(self) -> np.ndarray:
        """The distance along each pixel's centre ray, m (``inf``: nothing)."""
        return self.depth_m if self.depth_type == "radial" else self.depth_m / self.directions[..., 2]

    def step_arguments(self) -> dict:
        """The render as keyword arguments of a stepped sensor: ``depth``, ``intrinsics``,
        ``depth_type``, ``normals``, ``segmentation``."""
        return {"depth": self.depth_m, "intrinsics": self.intrinsics, "depth_type": self.depth_type,
                "normals": self.normals, "segmentation": self.segmentation}

    def reflectivity(self, default: float = 0.9, table=None) -> np.ndarray:
        """Each pixel's Lambertian reflectivity: ``table[id]`` (a mapping from segmentation id to
        reflectivity) for the ids it names, ``default`` for the rest."""
        rho = np.full(self.depth_m.shape, float(default))
        for key, value in (table or {}).items():
            rho[self.segmentation == key] = float(value)
        return rho

    def to_returns(self, camera, *, reflectivity: float = 0.9, reflectivity_table=None):
        """Every pixel's direct return on ``camera`` (a :class:`tofjax.Camera`; one ray per pixel, as
        ``camera.returns`` makes them from a depth map), with :meth:`reflectivity`. The render must
        be at the camera's intrinsics (``ValueError`` naming what differs): render for the camera
        (``tofjax_camera=`` in MuJoCo, ``camera=`` in Open3D)."""
        problem = intrinsics_mismatch(self.intrinsics, camera_intrinsics(camera))
        if problem:
            raise ValueError(f"this {self.renderer} render is not at the camera's intrinsics: {problem} (render it for "
                             "the camera)")
        return camera.returns(self.depth_m, reflectivity=self.reflectivity(reflectivity, reflectivity_table),
                              radial=self.depth_type == "radial")
