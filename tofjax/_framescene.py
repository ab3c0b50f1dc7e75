"""A frame's scene named in words: a built-in scene with its parameters (``wall:distance_m=1.5``) or an
NPZ file (a depth map or a renderer's returns), checked and made into returns with one line per
mistake; what ``tofjax render --scene`` and the explorer's Frame tab read."""

from __future__ import annotations

import contextlib
import math
from pathlib import Path


def parse_scene(text: str, option: str = "--scene"):
    """``NAME`` or ``NAME:key=value,...`` -> (builder, name, keyword arguments), or a path to an NPZ
    file -> (None, path, {}). Raises ``ValueError`` with one line naming the ``option``, scene, key
    and range."""
    from ._schema import suggest
    from ._scene import BUILTIN_SCENES

    if text.lower().endswith(".npz"):
        path = Path(text)
        if not path.is_file():
            raise ValueError(f"{option} {text}: no such file")
        return None, text, {}
    name, _, rest = text.partition(":")
    if name not in BUILTIN_SCENES:
        raise ValueError(f"{option} {name!r} is not a built-in scene: allowed {', '.join(BUILTIN_SCENES)} or a "
                         "FILE.npz" + suggest(name, BUILTIN_SCENES))
    builder, ranges = BUILTIN_SCENES[name]
    kwargs = {}
    for item in filter(None, rest.split(",")):
        key, eq, value = item.partition("=")
        key = key.strip()
        if key not in ranges:
            raise ValueError(f"{option} {name}: {key!r} is not a parameter of {name}: allowed "
                             + ", ".join(ranges) + suggest(key, ranges))
        try:
            x = float(value) if eq else float("nan")
        except ValueError:
            x = float("nan")
        lo, hi = ranges[key]
        if not (math.isfinite(x) and lo <= x <= hi):
            raise ValueError(f"{option} {name}: {key} = {value.strip() or '(empty)'!s} is out of range: allowed "
                             f"{lo:g} <= value <= {hi:g}")
        kwargs[key] = x
    return builder, name, kwargs


_DEPTH_ARRAYS = ("z_m", "radial_m", "reflectivity")


@contextlib.contextmanager
def _scene_option(option: str):
    """Messages about the scene file name the option: ``--scene FILE.npz: ...``."""
    try:
        yield
    except ValueError as err:
        if str(err).startswith(option):
            raise
        raise ValueError(f"{option} {err}") from None


def npz_scene_kind(path: str, option: str = "--scene") -> tuple[str, int]:
    """What an NPZ scene holds, from its arrays' headers only: ``("returns", returns per pixel)`` or
    ``("depth", 1)``; ``ValueError`` naming the file for anything else."""
    from ._npz import npz_shapes

    with _scene_option(option):
        shapes = npz_shapes(path)
    if "path_m" in shapes:
        return "returns", shapes["path_m"][-1] if len(shapes["path_m"]) == 3 else 1
    if "z_m" in shapes or "radial_m" in shapes:
        return "depth", 1
    raise ValueError(f"{option} {path}: holds neither returns (path_m, radiance_per_w) nor a depth map (z_m or "
                     f"radial_m); found {', '.join(sorted(shapes)) or 'no arrays'}")


def load_npz_scene(path: str, params, settings, max_bytes: int, option: str = "--scene"):
    """The returns of an NPZ scene (returns, or a depth map with an optional reflectivity map) on the
    camera of ``params`` and ``settings``; ``ValueError`` naming ``option``, the file and the array."""
    import numpy as np

    import tofjax as tj

    from ._framegeometry import check_depth
    from ._npz import npz_arrays

    shape = tj.optics.frame_shape(params)
    kind, _ = npz_scene_kind(path, option)
    with _scene_option(option):
        if kind == "returns":
            return tj.frameio.load_returns(path, shape, max_bytes=max_bytes)
        arrays = npz_arrays(path, _DEPTH_ARRAYS, max_bytes=max_bytes)
    key = "z_m" if "z_m" in arrays else "radial_m"
    depth = arrays[key].astype(float)
    rho = arrays.get("reflectivity", np.asarray(float(params.scene.reflectivity))).astype(float)
    if depth.shape != shape:
        raise ValueError(f"{option} {path}: {key} has shape {depth.shape}, the camera {shape} (rows, cols)")
    check_depth(depth, f"{option} {path}: {key}")
    if rho.shape not in ((), shape) or not np.all(np.isfinite(rho) & (rho >= 0) & (rho <= 1)):
        raise ValueError(f"{option} {path}: reflectivity must be a number or a {shape} map with 0 <= value <= 1")
    return tj.Camera(params, settings).returns(depth, reflectivity=rho, radial=key == "radial_m")


def check_size(name: str, geometry, settings, shape, *, mesh: bool = False) -> int:
    """Refuse a frame whose run would not fit this process's memory (before any work, naming the
    resolution); returns the bytes an NPZ scene's arrays may take. ``mesh``: ``name`` is a mesh
    file, cast along every sub-pixel ray (one return each)."""
    from ._limits import available_memory_bytes, frame_memory_bytes, size_text

    rows, cols = shape
    s = settings.subpixel_samples
    available = available_memory_bytes()
    if mesh:
        per_pixel, patches = s * s, 0
    elif geometry is None:
        kind, per_pixel = npz_scene_kind(name)
        s = 1 if kind == "depth" else s
        patches = 0
    else:
        patches = 0 if geometry.patches is None else int(geometry.patches.area_m2.shape[0])
        per_pixel = s * s + (32 if patches else 0)
    need = frame_memory_bytes(rows * cols, s, per_pixel, patches, cols)
    if need > available:
        raise ValueError(f"the camera's {rows} x {cols} pixels (camera.optical_area_m / camera.pixel_pitch_m) with "
                         f"{s}^2 rays and {per_pixel} returns per pixel need about {size_text(need)} to render, more "
                         f"than the {size_text(available)} this process can use: choose fewer pixels or fewer "
                         "frame.subpixel_samples")
    return max(available - need, 0) // 2
