"""The pixel array's geometry for full frames (thesis §6.1.1, future work; docs/model.md, "Full
frames"): the ``[frame]`` settings, the array's shape and rays, the camera equation's etendue per
pixel, and the returns each pixel sees from a scene or a depth map (:mod:`tofjax._returns`).
Nothing here runs the signal chain: :mod:`tofjax._frame` does, with what this module computes.

The camera equation (Eqs 3.5-3.11, generalised off axis): a pixel collects the flux

    flux = L x pi A_pixel FF k_lens cos^m(phi) (1 - v h^2) / (4 N^2)

(L the radiance it sees, phi its field angle, m = ``frame.relative_illumination_exponent``, h its
image height over the half diagonal, v = ``frame.vignetting``, N the f-number); on the axis and with
L = rho E / pi this is the thesis' rho E FF A k_lens / (4 N^2).
"""

from __future__ import annotations

import equinox as eqx
import jax.numpy as jnp
from jaxtyping import Array, Float

from . import _jit
from ._executor import programs
from ._optics import lens
from ._params import Params, _check, _float, _static
from ._returns import Returns, direct_returns, two_bounce_returns
from ._scene import (PixelField, Rays, SceneGeometry, Surface, _nonzero, pixel_field, pixel_rays, resolution,
                     surface, surface_from_depth)
from ._schema import checked_range


class FrameSettings(eqx.Module):
    """The ``[frame]`` section: the array's optics and its fixed-pattern sigmas (schema docs).

    ``subpixel_samples`` and ``seed`` are static; the rest are traced float leaves (a gradient
    reaches them).
    """

    subpixel_samples: int = _static("frame", "subpixel_samples")
    illumination_falloff_exponent: Float[Array, ""] = _float("frame", "illumination_falloff_exponent")
    baseline_m: Float[Array, "2"] = _float("frame", "baseline_m")
    relative_illumination_exponent: Float[Array, ""] = _float("frame", "relative_illumination_exponent")
    vignetting: Float[Array, ""] = _float("frame", "vignetting")
    distortion_k1: Float[Array, ""] = _float("frame", "distortion_k1")
    distortion_k2: Float[Array, ""] = _float("frame", "distortion_k2")
    distortion_p1: Float[Array, ""] = _float("frame", "distortion_p1")
    distortion_p2: Float[Array, ""] = _float("frame", "distortion_p2")
    distortion_k3: Float[Array, ""] = _float("frame", "distortion_k3")
    prnu_sigma: Float[Array, ""] = _float("frame", "prnu_sigma")
    phase_offset_sigma_rad: Float[Array, ""] = _float("frame", "phase_offset_sigma_rad")
    tap_asymmetry_sigma: Float[Array, ""] = _float("frame", "tap_asymmetry_sigma")
    threshold_sigma: Float[Array, ""] = _float("frame", "threshold_sigma")
    seed: int = _static("frame", "seed")
    max_phase_noise_rad: Float[Array, ""] = _float("frame", "max_phase_noise_rad")
    min_amplitude_lsb: Float[Array, ""] = _float("frame", "min_amplitude_lsb")
    mixed_spread_fraction: Float[Array, ""] = _float("frame", "mixed_spread_fraction")

    def __check_init__(self):
        _check(self, "frame")

    @property
    def distortion_terms(self) -> tuple[Float[Array, ""], ...]:
        """The lens distortion's five leaves in OpenCV's order ``(k1, k2, p1, p2, k3)``."""
        return self.distortion_k1, self.distortion_k2, self.distortion_p1, self.distortion_p2, self.distortion_k3

    @property
    def distortion(self) -> Float[Array, "5"]:
        """The lens distortion in OpenCV's order ``(k1, k2, p1, p2, k3)`` (:mod:`tofjax._distortion`)."""
        return jnp.stack(self.distortion_terms)


def frame_settings(values) -> FrameSettings:
    """The :class:`FrameSettings` of a configuration's ``[frame]`` values (a mapping)."""
    return FrameSettings(**{k: (tuple(v) if isinstance(v, list) else v) for k, v in values.items()})


def check_lens(params: Params, settings: FrameSettings) -> None:
    """``ValueError`` unless the settings' lens distortion is one-to-one over the camera's array
    (:func:`tofjax._distortion.check_one_to_one`; concrete values only)."""
    from ._distortion import check_one_to_one
    from ._schema import _is_tracer

    k = lens_distortion(settings)
    if k is None or _is_tracer(k):  # a pinhole, or not known until the program runs
        return
    cam = params.camera
    f = float(lens(cam).focal_length_m)
    half = (0.5 * float(cam.optical_area_m[0]) / f, 0.5 * float(cam.optical_area_m[1]) / f)
    check_one_to_one(k, half, "frame.distortion_(k1, k2, p1, p2, k3)")


#: What an intrinsics file's ``convention`` says (:func:`intrinsics`).
INTRINSICS_CONVENTION = (
    "OpenCV's pinhole model with Brown-Conrady distortion: a point (X, Y, Z) in OpenCV's camera frame (x right, "
    "y down, z along the optical axis) has x = X/Z, y = Y/Z, r^2 = x^2 + y^2, R = 1 + k1 r^2 + k2 r^4 + k3 r^6, "
    "x_d = x R + 2 p1 x y + p2 (r^2 + 2 x^2), y_d = y R + p1 (r^2 + 2 y^2) + 2 p2 x y, pixel (u, v) = "
    "(fx x_d + cx, fy y_d + cy) with (0, 0) the centre of the top-left pixel, u along a row. dist_coeffs are "
    "OpenCV's (k1, k2, p1, p2, k3). tofjax's points (frame.npz direction, points.ply) have y up: OpenCV's "
    "(X, Y, Z) is tofjax's (x, -y, z). depth_mm.png holds Z, so undistort it (cv2.undistort) before a pinhole "
    "back-projection (Open3D's PinholeCameraIntrinsic(width, height, fx, fy, cx, cy)).")


def intrinsics(params: Params, settings: FrameSettings) -> dict:
    """The frame camera's intrinsics in OpenCV's convention (:data:`INTRINSICS_CONVENTION`), as plain
    numbers: ``width``, ``height`` (pixels), ``fx``, ``fy`` (the focal length in pixel pitches),
    ``cx``, ``cy`` (the principal point: the array's centre), ``camera_matrix`` (3 x 3),
    ``dist_coeffs`` (``frame.distortion_k1, k2, p1, p2, k3``), ``format`` and ``convention``. What
    ``tofjax render`` writes as ``intrinsics.json`` and into ``frame.npz``. Concrete values only."""
    rows, cols = frame_shape(params)
    cam = params.camera
    f = float(lens(cam).focal_length_m)
    fx, fy = f / float(cam.pixel_pitch_m[0]), f / float(cam.pixel_pitch_m[1])
    cx, cy = 0.5 * (cols - 1), 0.5 * (rows - 1)  # pixel centres at whole numbers (OpenCV); ours: _scene._grid
    return {"format": "tofjax-intrinsics/1", "width": cols, "height": rows, "fx": fx, "fy": fy, "cx": cx, "cy": cy,
            "camera_matrix": [[fx, 0.0, cx], [0.0, fy, cy], [0.0, 0.0, 1.0]],
            "dist_coeffs": [float(x) for x in settings.distortion], "convention": INTRINSICS_CONVENTION}


def frame_shape(params: Params) -> tuple[int, int]:
    """(rows, cols) of the pixel array (``camera.optical_area_m / camera.pixel_pitch_m``)."""
    return resolution(params.camera)


def frame_rays(params: Params, settings: FrameSettings, subpixel_samples: int | None = None,
               shape: tuple[int, int] | None = None) -> Rays:
    """The rays of every pixel of the camera (``subpixel_samples``: per axis, default the settings';
    ``shape``: (rows, cols), default the camera's, which needs concrete camera values)."""
    s = settings.subpixel_samples if subpixel_samples is None else subpixel_samples
    check_lens(params, settings)
    return _pixel_rays(params.camera, frame_shape(params) if shape is None else shape, s, lens_distortion(settings))


# One program per camera shape and sampling (called eagerly, pixel_rays' few dozen operations were as
# many programs of their own).
_pixel_rays = _jit.jit(pixel_rays)


def lens_distortion(settings: FrameSettings) -> Float[Array, "5"] | None:
    """The coefficients a program of rays takes (OpenCV's order): ``None`` when every one is concrete
    and 0, so that the pinhole's program has no Newton steps at all (a ``lax.cond`` around them
    still cost a ray cast 5 %: it writes its result to memory); the coefficients otherwise. The
    entry points decide it outside their programs and pass it in."""
    from ._schema import _is_tracer

    k = settings.distortion_terms
    if not any(_is_tracer(x) for x in k) and not any(float(x) for x in k):
        return None
    return settings.distortion


def _rays_and_surface(params, settings, geometry, sun_direction, shape, distortion):
    rays = pixel_rays(params.camera, shape, settings.subpixel_samples, distortion)
    return rays, surface(geometry, rays, sun_direction)


def _returns_of(params, settings, geometry, surf, rays, bins):
    out = direct_returns(params.illumination, settings.illumination_falloff_exponent, settings.baseline_m, surf, rays)
    if geometry.patches is not None:
        out = out + two_bounce_returns(params.illumination, settings.illumination_falloff_exponent,
                                       settings.baseline_m, surf, rays, geometry.patches, bins)
    return _with_interference(params, settings, surf, rays, out)


def _with_interference(params, settings, surf, rays, out: Returns) -> Returns:
    """``out`` and, with ``interference.enabled``, the interfering camera's direct light on the same
    surfaces, from its position, tagged as its (:attr:`tofjax.Returns.source`; docs/model.md,
    "Interference": its two-bounce light is left out)."""
    if not params.interference.enabled:
        return out
    other = direct_returns(params.illumination, settings.illumination_falloff_exponent,
                           params.interference.baseline_m, surf, rays)
    k = other.path_m.shape[-1]
    return out + Returns(other.path_m, other.radiance_per_w, out.ambient_reflectivity, out.radial_m, None, (1,) * k)


@_jit.jit
def _scene_returns(params, settings, geometry, sun_direction, bins, shape, distortion):
    rays, surf = _rays_and_surface(params, settings, geometry, sun_direction, shape, distortion)
    return _returns_of(params, settings, geometry, surf, rays, bins)


@_jit.jit
def surface_returns(params: Params, settings: FrameSettings, surf: Surface, rays: Rays) -> Returns:
    """Every pixel's direct returns from what its rays ``rays`` see, ``surf`` (a renderer's hits:
    :mod:`tofjax.renderers.open3d`), as :func:`scene_returns` makes them from a scene without
    patches (the interfering camera's light included)."""
    out = direct_returns(params.illumination, settings.illumination_falloff_exponent, settings.baseline_m, surf, rays)
    return _with_interference(params, settings, surf, rays, out)


_rays_and_surface_jit = _jit.jit(_rays_and_surface)
_returns_of_jit = _jit.jit(_returns_of)


def scene_returns(params: Params, settings: FrameSettings, geometry: SceneGeometry, *, sun_direction=None,
                  bins: int = 32) -> Returns:
    """Every pixel's returns from a scene: the direct return of each sub-pixel ray and, for a scene
    with patches (:func:`tofjax.scenes.corner`), its two-bounce light in ``bins`` returns.
    ``sun_direction``: the background light's direction (:func:`tofjax._scene.surface`).

    A scene of several primitives runs as two programs, the rays and what they hit, then the
    returns: its nearest hit is a chain of selects, which XLA on a CPU evaluates again in every
    fusion that reads it when both are one program; a single plane is faster as one (docs/model.md,
    "Performance", measurement 17). Inside a transformation of the caller's, everything is one
    program anyway (:func:`tofjax._executor.programs`)."""
    if isinstance(bins, bool) or not isinstance(bins, int) or not 1 <= bins <= 4096:
        raise ValueError(f"bins = {bins!r} is out of range: allowed integer 1 <= value <= 4096 (returns per pixel of "
                         "the two-bounce light)")
    sun = None
    if sun_direction is not None:
        sun = jnp.asarray(checked_range(sun_direction, "sun_direction"), dtype=float)
        if sun.shape != (3,):
            raise ValueError(f"sun_direction has shape {sun.shape}: allowed three numbers (dx, dy, dz)")
        _nonzero(sun, "sun_direction")
    shape = frame_shape(params)
    args = (params, settings, geometry, sun, bins, shape, lens_distortion(settings))
    if len(geometry.primitives) > 1:
        return programs(_scene_returns_in_two, _scene_returns, args)
    return _scene_returns(*args)


def _scene_returns_in_two(params, settings, geometry, sun, bins, shape, distortion):
    """:func:`_scene_returns` as two programs: the rays and what they hit, then the returns."""
    rays, surf = _rays_and_surface_jit(params, settings, geometry, sun, shape, distortion)
    return _returns_of_jit(params, settings, geometry, surf, rays, bins)


def depth_returns(params: Params, settings: FrameSettings, depth_m, reflectivity, *, radial: bool = False) -> Returns:
    """Every pixel's direct return from a depth map ``(rows, cols)`` (Z depth, or the radial
    distance with ``radial=True``) and a reflectivity map or number; one ray per pixel."""
    shape = frame_shape(params)
    depth = jnp.asarray(depth_m, dtype=float)
    if depth.shape != shape:
        raise ValueError(f"depth map has shape {depth.shape}, the camera {shape} (rows, cols; "
                         "camera.optical_area_m / camera.pixel_pitch_m)")
    rho = jnp.asarray(checked_range(reflectivity, "reflectivity", 0.0, 1.0), dtype=float)
    if rho.shape not in ((), shape):
        raise ValueError(f"reflectivity has shape {rho.shape}: allowed a number or the camera's {shape}")
    return _depth_returns(params, settings, check_depth(depth, "depth_m"), rho, radial, depth.shape,
                          lens_distortion(settings))


#: A depth map's allowed depths, m; a non-finite or non-positive depth is a miss (no surface there).
DEPTH_RANGE_M = (1e-3, 1e3)


def check_depth(depth, what: str):
    """``depth`` if every surface in it (finite and > 0) lies within :data:`DEPTH_RANGE_M`
    (:func:`tofjax._schema.checked_range`: ``ValueError`` naming ``what`` and the first bad
    element; traced: ``equinox.error_if``)."""
    return checked_range(depth, what, *DEPTH_RANGE_M, unit="m", note="inf, NaN or <= 0: no surface",
                         exempt=lambda x, xp: ~(xp.isfinite(x) & (x > 0.0)))


@_jit.jit
def _depth_returns(params, settings, depth, reflectivity, radial, shape, distortion):
    rays = pixel_rays(params.camera, shape, 1, distortion)
    surf = surface_from_depth(depth, reflectivity, rays, radial)
    out = direct_returns(params.illumination, settings.illumination_falloff_exponent, settings.baseline_m, surf, rays)
    return _with_interference(params, settings, surf, rays, out)


def pixel_etendue_m2_sr(params: Params, settings: FrameSettings, rays: Rays | PixelField | None = None
                        ) -> Float[Array, "rows cols"]:
    """pi A_pixel FF k_lens cos^m(phi) (1 - v h^2) / (4 N^2): the flux on a pixel per unit radiance
    of what it sees (module docstring), m^2 sr. ``rays``: the pixels' :class:`Rays` or
    :class:`~tofjax._scene.PixelField` (default: the camera's, in closed form)."""
    cam = params.camera
    if rays is None:
        rays = pixel_field(cam, frame_shape(params))
    area = cam.pixel_pitch_m[0] * cam.pixel_pitch_m[1] * cam.fill_factor
    relative = rays.cos_field_angle ** settings.relative_illumination_exponent
    vignette = 1.0 - settings.vignetting * rays.image_height**2
    return jnp.pi * area * cam.k_lens * relative * vignette / (4.0 * cam.f_number**2)
