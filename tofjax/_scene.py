"""Scenes for full frames: the camera's rays, geometry they hit, and the returns each pixel sees
(thesis §6.1.1 and §6.1.3, future work; docs/model.md, "Full frames").

Coordinates are the camera's: the lens centre at the origin, +z along the optical axis, +x right and
+y up in the scene. A pixel's ray runs from the lens centre through the pixel centre of a pinhole
camera whose focal length is the lens' (:func:`tofjax.optics.lens`); the principal point is the centre of
the array, so the pixel on the optical axis exists when both pixel counts are odd. Each pixel is
sampled by s x s rays (``frame.subpixel_samples``) at the centres of an s x s grid inside it.

A scene is a tuple of primitives (:class:`Plane`, :class:`Sphere`, :class:`Box`), each with its own
Lambertian reflectivity; a ray takes the nearest hit. Built-in scenes: :func:`wall`,
:func:`tilted_plane`, :func:`step_edge`, :func:`box_on_floor`, :func:`sphere`, :func:`corner`
(with patches for its two-bounce light). Any depth map becomes a :class:`Surface` with
:func:`surface_from_depth`.
"""

from __future__ import annotations

import abc

import functools
import inspect
from typing import ClassVar

import equinox as eqx
import jax.numpy as jnp
from jax import lax
import numpy as np
from jaxtyping import Array, Bool, Float

from ._optics import lens
from ._params import Optics
from ._schema import _is_tracer, checked_range

_INF = jnp.inf
#: The scene parameters' ranges: distances (m) and Lambertian reflectivities.
_DISTANCE = (0.01, 1e3)
_REFLECTIVITY = (0.0, 1.0)


def _f64(x):
    return jnp.asarray(x, dtype=float)


#: The most pixels a frame may have (2^24, 16.8 M: a 4K depth map twice over; today's ToF sensors
#: have at most about 1.2 M). More would overflow the frames' 32-bit counters of phase images.
MAX_PIXELS = 1 << 24


def resolution(camera: Optics) -> tuple[int, int]:
    """(rows, columns) of the pixel array: ``optical_area_m / pixel_pitch_m``, which must be whole
    numbers of pixels (within 1e-6 of one), at most :data:`MAX_PIXELS` of them (``ValueError``
    naming both keys otherwise)."""
    import numpy as np

    area, pitch = np.asarray(camera.optical_area_m, dtype=float), np.asarray(camera.pixel_pitch_m, dtype=float)
    counts = area / pitch
    rounded = np.rint(counts)
    if np.any(np.abs(counts - rounded) > 1e-6 * np.maximum(rounded, 1.0)) or np.any(rounded < 1):
        raise ValueError(f"camera.optical_area_m = {area.tolist()!r} is not a whole number of pixels of "
                         f"camera.pixel_pitch_m = {pitch.tolist()!r} ({counts[0]:.4g} x {counts[1]:.4g}): allowed "
                         "optical_area_m = [columns x pitch_x, rows x pitch_y]")
    if rounded[0] * rounded[1] > MAX_PIXELS:
        raise ValueError(f"camera.optical_area_m / camera.pixel_pitch_m = {rounded[0]:.4g} x {rounded[1]:.4g} = "
                         f"{rounded[0] * rounded[1]:.3g} pixels is out of range: allowed at most {MAX_PIXELS} "
                         f"(2^24) pixels")
    return int(rounded[1]), int(rounded[0])


class Rays(eqx.Module):
    """Unit ray directions of every pixel.

    **Fields:** ``centre`` ``(rows, cols, 3)``: through each pixel centre; ``samples``
    ``(rows, cols, s*s, 3)``: the sub-pixel rays; ``image_height`` ``(rows, cols)``: the pixel
    centre's distance from the principal point over the half diagonal of the array (1 at a corner).
    """

    centre: Float[Array, "rows cols 3"]
    samples: Float[Array, "rows cols sub 3"]
    image_height: Float[Array, "rows cols"]

    @property
    def cos_field_angle(self) -> Float[Array, "rows cols"]:
        """cos of the angle between each pixel's centre ray and the optical axis."""
        return self.centre[..., 2]


class PixelField(eqx.Module):
    """Where each pixel centre lies in the field, what the camera equation's relative illumination
    reads (:func:`tofjax.optics.pixel_etendue_m2_sr`), without the rays' vectors.

    **Fields:** ``cos_field_angle`` ``(rows, cols)``: cos of the angle between the pixel's centre
    ray and the optical axis, f / sqrt(x^2 + y^2 + f^2); ``image_height`` ``(rows, cols)``: the pixel
    centre's distance from the principal point over the half diagonal of the array.
    """

    cos_field_angle: Float[Array, "rows cols"]
    image_height: Float[Array, "rows cols"]


def _grid(shape: tuple[int, int]) -> tuple[Array, Array]:
    """Pixel centres from the principal point, in pitches: columns ``(cols,)`` (+x, right) and rows
    ``(rows,)`` (+y, up: row 0 at the top)."""
    rows, cols = shape
    return jnp.arange(cols, dtype=float) - 0.5 * (cols - 1), 0.5 * (rows - 1) - jnp.arange(rows, dtype=float)


def _centres_m(camera: Optics, shape: tuple[int, int]) -> tuple[Array, Array]:
    """Pixel centres on the array from the principal point, m: x ``(1, cols)``, y ``(rows, 1)``."""
    col, row = _grid(shape)
    return col[None, :] * camera.pixel_pitch_m[0], row[:, None] * camera.pixel_pitch_m[1]


def _image_height(camera: Optics, shape: tuple[int, int], x: Array, y: Array) -> Array:
    rows, cols = shape
    return jnp.hypot(x, y) / (0.5 * jnp.hypot(cols * camera.pixel_pitch_m[0], rows * camera.pixel_pitch_m[1]))


def _inverse_ray_length(x: Array, y: Array, f: Array) -> Array:
    """1 / |(x, y, f)|, elementwise (no norm reduced over a stacked axis: XLA's CPU runs that as a
    small single-threaded reduction)."""
    return 1.0 / jnp.sqrt(x * x + y * y + f * f)


def pixel_field(camera: Optics, shape: tuple[int, int]) -> PixelField:
    """Each pixel's :class:`PixelField`, in closed form per pixel (the numbers of :func:`pixel_rays`'
    ``cos_field_angle`` and ``image_height``, without its unit vectors)."""
    f = lens(camera).focal_length_m
    x, y = _centres_m(camera, shape)
    return PixelField(f * _inverse_ray_length(x, y, f), _image_height(camera, shape, x, y))


def _unit_rays(x: Array, y: Array, f: Array) -> Float[Array, "... 3"]:
    """Unit vectors along (x, y, f): rays from the lens centre through points (x, y) of the array."""
    x, y = jnp.broadcast_arrays(x, y)
    inv = _inverse_ray_length(x, y, f)
    return jnp.stack([x * inv, y * inv, f * inv], axis=-1)


def _seen(x: Array, y: Array, f: Array, distortion: Array | None) -> tuple[Array, Array]:
    """Where on an ideal (pinhole) array the point ``(x, y)`` of the real array looks, m: the point
    itself without ``distortion`` (OpenCV's ``(k1, k2, p1, p2, k3)``), else its undistorted position
    (:func:`tofjax._distortion.undistort`; OpenCV's y runs down, ours up). The Newton steps run only
    when a coefficient is non-zero (``lax.cond``), and add exactly 0 when all are."""
    if distortion is None:
        return x, y
    from ._distortion import undistort

    x, y = jnp.broadcast_arrays(x, y)
    xd, yd = x / f, -y / f

    def offsets():
        return undistort(xd, yd, distortion)

    def none():
        return jnp.zeros_like(xd), jnp.zeros_like(yd)

    dx, dy = lax.cond(jnp.any(distortion != 0.0), offsets, none)
    return x + f * dx, y - f * dy


def pixel_directions(camera: Optics, shape: tuple[int, int], distortion: Array | None = None
                     ) -> Float[Array, "rows cols 3"]:
    """Unit rays through the pixel centres, ``(rows, cols, 3)`` (:func:`pixel_rays`' ``centre``)."""
    f = lens(camera).focal_length_m
    return _unit_rays(*_seen(*_centres_m(camera, shape), f, distortion), f)


def pixel_rays(camera: Optics, shape: tuple[int, int], subpixel_samples: int = 1, distortion: Array | None = None
               ) -> Rays:
    """The rays of a ``shape = (rows, cols)`` array with ``subpixel_samples`` rays per pixel and axis,
    through a lens with ``distortion`` (OpenCV's ``(k1, k2, p1, p2, k3)``; ``None``: a pinhole). Each
    ray is the one the lens maps onto its point of the array. ``image_height`` stays where the pixel
    lies on the array (the relative illumination is the image side's)."""
    rows, cols = shape
    f = lens(camera).focal_length_m
    px, py = camera.pixel_pitch_m[0], camera.pixel_pitch_m[1]
    s = subpixel_samples
    sub = (jnp.arange(s, dtype=float) + 0.5) / s - 0.5  # offsets inside a pixel, in pitches
    col, row = _grid(shape)
    xs = (col[None, :, None, None] + sub[None, None, None, :]) * px  # (1, cols, 1, s)
    ys = (row[:, None, None, None] - sub[None, None, :, None]) * py  # (rows, 1, s, 1)
    samples = _unit_rays(*_seen(xs, ys, f, distortion), f).reshape(rows, cols, s * s, 3)
    x, y = _centres_m(camera, shape)
    return Rays(_unit_rays(*_seen(x, y, f, distortion), f), samples, _image_height(camera, shape, x, y))


class Hit(eqx.Module):
    """Where rays from the lens centre meet a surface: ``t`` the distance along the unit ray (inf: no
    hit), the unit ``normal`` facing the ray, and the ``reflectivity`` there."""

    t: Float[Array, "*r"]
    normal: Float[Array, "*r 3"]
    reflectivity: Float[Array, "*r"]


def dot3(a: Float[Array, "*a 3"], b: Float[Array, "*b 3"]) -> Float[Array, "..."]:
    """a . b over a last axis of 3 (either side may be one vector), written out by components. On a
    CPU, XLA runs a sum or a matrix product over an axis of 3 as a reduction or a dot of its own, which
    its fusion cannot join with the elementwise work around it (docs/model.md, "Performance",
    measurement 4)."""
    return a[..., 0] * b[..., 0] + a[..., 1] * b[..., 1] + a[..., 2] * b[..., 2]


def _facing(normal, d):
    """Flip normals to face the incoming ray (a surface is seen from the side the ray comes from)."""
    sign = jnp.where(dot3(normal, d) > 0.0, -1.0, 1.0)
    return normal * sign[..., None]


def _concrete(x) -> np.ndarray | None:
    return None if _is_tracer(x) else np.asarray(x, dtype=float)


def _nonzero(v, what: str) -> None:
    """A direction must have a length (concrete values; a traced one is the caller's to check)."""
    a = _concrete(v)
    if a is not None and not np.any(a != 0.0):
        raise ValueError(f"{what} = {a.tolist()} is not a direction: allowed three finite numbers, not all 0")


def _ordered(lo, hi, what: str) -> None:
    """Clip bounds: no NaN, ``lo <= hi`` on every axis (infinite bounds allowed: unbounded)."""
    a, b = _concrete(lo), _concrete(hi)
    if a is None or b is None:
        return
    if np.any(np.isnan(a)) or np.any(np.isnan(b)) or np.any(a > b):
        raise ValueError(f"{what}: lo = {a.tolist()} and hi = {b.tolist()} are not bounds: allowed lo <= hi on every "
                         "axis, no NaN")


def _inside(p, lo, hi):
    inside = (p[..., 0] >= lo[0]) & (p[..., 0] <= hi[0])
    for k in (1, 2):
        inside = inside & (p[..., k] >= lo[k]) & (p[..., k] <= hi[k])
    return inside


class AbstractPrimitive(eqx.Module):
    """A surface of a scene: a new kind is one subclass with :meth:`intersect` (its parameters as
    fields, range-checked in ``__check_init__``); :class:`SceneGeometry` takes any of them."""

    #: The fields that are positions (m), which a translation moves (:meth:`translated`).
    positions: ClassVar[tuple[str, ...]] = ()
    #: The positions that bound the surface to an axis-aligned box (per axis; inf = unbounded): a
    #: translation moves them, a rotation cannot turn them (:meth:`rotation_problem`).
    bounds: ClassVar[tuple[str, ...]] = ()
    #: The fields that are directions (normals), which a rotation turns and a translation leaves.
    directions: ClassVar[tuple[str, ...]] = ()

    @abc.abstractmethod
    def intersect(self, d: Float[Array, "*r 3"]) -> Hit:
        """Where the rays ``d`` (unit directions from the lens centre) first meet this surface
        (:class:`Hit`; ``t`` inf where they miss it), its normal facing them, its reflectivity."""

    def translated(self, offset_m: Float[Array, "3"]):
        """This surface moved by ``offset_m`` (every field named in :attr:`positions`)."""
        if not self.positions:
            raise NotImplementedError(f"{type(self).__name__} names no positions (AbstractPrimitive.positions): it "
                                      "cannot move")
        return eqx.tree_at(lambda p: tuple(getattr(p, f) for f in self.positions), self,
                           tuple(getattr(self, f) + offset_m for f in self.positions))

    def rotation_problem(self) -> str | None:
        """Why this surface cannot turn rigidly (``None``: it can): it names no positions, or its
        concrete :attr:`bounds` are finite (an axis-aligned box cannot turn and stay one)."""
        name = type(self).__name__
        if not self.positions:
            return f"{name} names no positions (AbstractPrimitive.positions)"
        finite = [f for f in self.bounds if not _is_tracer(getattr(self, f)) and np.any(np.isfinite(getattr(self, f)))]
        if finite:
            return (f"{name} is bounded by an axis-aligned box ({', '.join(finite)} finite), which cannot turn and "
                    "stay axis-aligned")
        return None

    def turned(self, rotation: Float[Array, "3 3"], pivot_m: Float[Array, "3"], offset_m: Float[Array, "3"]):
        """This surface turned by ``rotation`` about ``pivot_m``, then moved by ``offset_m``: positions
        p -> pivot + R (p - pivot) + offset, directions n -> R n, :attr:`bounds` (unbounded, as
        :meth:`rotation_problem` requires) moved only."""
        fields = (*self.positions, *self.directions)

        def new(f):
            x = getattr(self, f)
            if f in self.directions:
                return rotation @ x
            if f in self.bounds:
                return x + offset_m
            return pivot_m + rotation @ (x - pivot_m) + offset_m

        return eqx.tree_at(lambda p: tuple(getattr(p, f) for f in fields), self, tuple(new(f) for f in fields))


class Plane(AbstractPrimitive):
    """The plane through ``point`` with ``normal``, clipped to the box ``[lo, hi]`` (per axis; inf =
    unbounded)."""

    point: Float[Array, "3"] = eqx.field(converter=_f64)
    normal: Float[Array, "3"] = eqx.field(converter=_f64)
    reflectivity: Float[Array, ""] = eqx.field(converter=_f64)
    lo: Float[Array, "3"] = eqx.field(converter=_f64, default=(-_INF, -_INF, -_INF))
    hi: Float[Array, "3"] = eqx.field(converter=_f64, default=(_INF, _INF, _INF))
    positions: ClassVar[tuple[str, ...]] = ("point", "lo", "hi")
    bounds: ClassVar[tuple[str, ...]] = ("lo", "hi")
    directions: ClassVar[tuple[str, ...]] = ("normal",)

    def __check_init__(self):
        checked_range(self.point, "tofjax.scenes.Plane: point", unit="m")
        checked_range(self.normal, "tofjax.scenes.Plane: normal")
        _nonzero(self.normal, "tofjax.scenes.Plane: normal")
        checked_range(self.reflectivity, "tofjax.scenes.Plane: reflectivity", *_REFLECTIVITY)
        _ordered(self.lo, self.hi, "tofjax.scenes.Plane")

    def intersect(self, d: Float[Array, "*r 3"]) -> Hit:
        n = self.normal / jnp.linalg.norm(self.normal)
        denom = dot3(d, n)
        ok_denom = jnp.abs(denom) > 1e-12
        t = jnp.sum(self.point * n) / jnp.where(ok_denom, denom, 1.0)
        p = t[..., None] * d
        ok = ok_denom & (t > 0.0) & _inside(p, self.lo, self.hi)
        normal = _facing(jnp.broadcast_to(n, d.shape), d)
        return Hit(jnp.where(ok, t, _INF), normal, jnp.broadcast_to(self.reflectivity, t.shape))


class Sphere(AbstractPrimitive):
    """A sphere of ``radius`` around ``centre``."""

    centre: Float[Array, "3"] = eqx.field(converter=_f64)
    radius: Float[Array, ""] = eqx.field(converter=_f64)
    reflectivity: Float[Array, ""] = eqx.field(converter=_f64)
    positions: ClassVar[tuple[str, ...]] = ("centre",)

    def __check_init__(self):
        checked_range(self.centre, "tofjax.scenes.Sphere: centre", unit="m")
        checked_range(self.radius, "tofjax.scenes.Sphere: radius", 0.0, lo_open=True, unit="m")
        checked_range(self.reflectivity, "tofjax.scenes.Sphere: reflectivity", *_REFLECTIVITY)

    def intersect(self, d: Float[Array, "*r 3"]) -> Hit:
        b = dot3(d, self.centre)
        disc = b * b - (jnp.sum(self.centre**2) - self.radius**2)
        root = jnp.sqrt(jnp.maximum(disc, 0.0))
        t0, t1 = b - root, b + root
        t = jnp.where(t0 > 0.0, t0, t1)
        ok = (disc > 0.0) & (t > 0.0)
        t = jnp.where(ok, t, _INF)
        p = jnp.where(ok, t, 1.0)[..., None] * d
        normal = _facing((p - jnp.broadcast_to(self.centre, p.shape)) / self.radius, d)
        return Hit(t, normal, jnp.broadcast_to(self.reflectivity, t.shape))


class Box(AbstractPrimitive):
    """An axis-aligned box ``[lo, hi]`` (slab method; the face the ray enters by)."""

    lo: Float[Array, "3"] = eqx.field(converter=_f64)
    hi: Float[Array, "3"] = eqx.field(converter=_f64)
    reflectivity: Float[Array, ""] = eqx.field(converter=_f64)
    positions: ClassVar[tuple[str, ...]] = ("lo", "hi")
    bounds: ClassVar[tuple[str, ...]] = ("lo", "hi")

    def __check_init__(self):
        _ordered(self.lo, self.hi, "tofjax.scenes.Box")
        checked_range(self.reflectivity, "tofjax.scenes.Box: reflectivity", *_REFLECTIVITY)

    def intersect(self, d: Float[Array, "*r 3"]) -> Hit:
        near, far = [], []
        for k in range(3):  # per axis, elementwise (no reductions over an axis of 3)
            dk = d[..., k]
            safe = jnp.where(jnp.abs(dk) > 1e-15, dk, 1e-15)
            t_lo, t_hi = self.lo[k] / safe, self.hi[k] / safe
            near.append(jnp.minimum(t_lo, t_hi))
            far.append(jnp.maximum(t_lo, t_hi))
        t_in = jnp.maximum(jnp.maximum(near[0], near[1]), near[2])
        t_out = jnp.minimum(jnp.minimum(far[0], far[1]), far[2])
        ok = (t_in <= t_out) & (t_in > 0.0)
        # The face entered through: the axis of the largest near distance (the first of equal ones).
        x_face = (near[0] >= near[1]) & (near[0] >= near[2])
        y_face = ~x_face & (near[1] >= near[2])
        axis = jnp.stack([x_face, y_face, ~x_face & ~y_face], axis=-1).astype(float)
        return Hit(jnp.where(ok, t_in, _INF), _facing(axis, d), jnp.broadcast_to(self.reflectivity, t_in.shape))


class Patches(eqx.Module):
    """Small flat patches of the scene's surfaces that relight each other (two-bounce light):
    centres, unit normals (facing the camera's side), areas and reflectivities, ``(patches, ...)``."""

    centre: Float[Array, "m 3"]
    normal: Float[Array, "m 3"]
    area_m2: Float[Array, " m"]
    reflectivity: Float[Array, " m"]

    def __check_init__(self):
        checked_range(self.centre, "tofjax.scenes.Patches: centre", unit="m")
        checked_range(self.area_m2, "tofjax.scenes.Patches: area_m2", 0.0, unit="m^2")
        checked_range(self.reflectivity, "tofjax.scenes.Patches: reflectivity", *_REFLECTIVITY)


class SceneGeometry(eqx.Module):
    """A scene: ``primitives`` (the nearest hit counts), an optional ``patches`` set for two-bounce
    light (:func:`corner`), and its ``name``."""

    primitives: tuple[AbstractPrimitive, ...]
    patches: Patches | None = None
    name: str = eqx.field(static=True, default="scene")

    def __check_init__(self):
        if not isinstance(self.primitives, tuple) or not self.primitives:
            raise TypeError(f"tofjax.scenes.SceneGeometry: primitives must be a non-empty tuple of primitives, got "
                            f"{type(self.primitives).__name__}")
        for i, p in enumerate(self.primitives):
            if not isinstance(p, AbstractPrimitive):
                raise TypeError(f"tofjax.scenes.SceneGeometry: primitives[{i}] is a {type(p).__name__}, not a "
                                "primitive (tofjax.scenes.Plane, Sphere, Box, or a subclass of AbstractPrimitive)")

    def translated(self, offset_m: Float[Array, "3"]) -> SceneGeometry:
        """The scene moved rigidly by ``offset_m`` (its primitives and patches)."""
        patches = None if self.patches is None else eqx.tree_at(lambda p: p.centre, self.patches,
                                                                  self.patches.centre + offset_m)
        return SceneGeometry(tuple(p.translated(offset_m) for p in self.primitives), patches, self.name)

    def rotation_problem(self) -> str | None:
        """Why the scene cannot turn rigidly (its first primitive that cannot), or ``None``."""
        for i, p in enumerate(self.primitives):
            problem = p.rotation_problem()
            if problem:
                return f"primitives[{i}]: {problem}"
        return None

    def turned(self, rotation: Float[Array, "3 3"], pivot_m: Float[Array, "3"],
               offset_m: Float[Array, "3"]) -> SceneGeometry:
        """The scene turned rigidly by ``rotation`` about ``pivot_m``, then moved by ``offset_m`` (its
        primitives, :meth:`AbstractPrimitive.turned`, and its patches' centres and normals)."""
        patches = self.patches
        if patches is not None:
            patches = eqx.tree_at(lambda p: (p.centre, p.normal), patches,
                                  (pivot_m + (patches.centre - pivot_m) @ rotation.T + offset_m,
                                   patches.normal @ rotation.T))
        return SceneGeometry(tuple(p.turned(rotation, pivot_m, offset_m) for p in self.primitives), patches, self.name)

    def cast(self, d: Float[Array, "*r 3"]) -> Hit:
        """The nearest hit of every ray ``d`` (unit directions from the lens centre); of equally near
        ones, the first primitive's. Compared primitive by primitive, elementwise (no gathers)."""
        hits = [p.intersect(d) for p in self.primitives]
        best = hits[0]
        for h in hits[1:]:
            nearer = h.t < best.t
            best = Hit(jnp.where(nearer, h.t, best.t), jnp.where(nearer[..., None], h.normal, best.normal),
                       jnp.where(nearer, h.reflectivity, best.reflectivity))
        return best


class Surface(eqx.Module):
    """What every sub-pixel ray of a frame sees: hit distance ``t_m`` (inf: nothing), the surface
    normal, reflectivity and the ambient factor (the background illuminance on that surface over the
    configured one), ``(rows, cols, sub)``; and what each pixel's centre ray sees, ``centre_*``
    ``(rows, cols[, 3])``."""

    t_m: Float[Array, "rows cols sub"]
    normal: Float[Array, "rows cols sub 3"]
    reflectivity: Float[Array, "rows cols sub"]
    ambient: Float[Array, "rows cols sub"]
    centre_t_m: Float[Array, "rows cols"]
    centre_normal: Float[Array, "rows cols 3"]
    centre_reflectivity: Float[Array, "rows cols"]

    @property
    def hit(self) -> Bool[Array, "rows cols sub"]:
        return jnp.isfinite(self.t_m)

    @property
    def radial_m(self) -> Float[Array, "rows cols"]:
        """The true distance along each pixel's centre ray (inf: nothing)."""
        return self.centre_t_m


def unit_vector(v) -> Float[Array, "3"]:
    """``v`` over its length, scaled by its largest component first so that no finite non-zero
    vector under- or overflows (``(1e-200, 1e-200, 0)`` is the unit vector along its diagonal)."""
    v = _f64(v)
    scaled = v / jnp.max(jnp.abs(v))
    return scaled / jnp.sqrt(dot3(scaled, scaled))


def surface(geometry: SceneGeometry, rays: Rays, sun_direction=None) -> Surface:
    """Cast every ray of ``rays`` into ``geometry``. ``sun_direction``: a direction the background
    light travels along (e.g. ``(0, -1, 1)``: from above and behind the camera); each surface then
    gets the configured illuminance times the cosine of its incidence (0 in its own shade, no
    occlusion), else (``None``) the configured illuminance everywhere, as the thesis' single pixel."""
    hit = geometry.cast(rays.samples)
    centre = geometry.cast(rays.centre)
    if sun_direction is None:
        ambient = jnp.ones_like(hit.t)
    else:
        s = unit_vector(sun_direction)
        ambient = jnp.maximum(-dot3(hit.normal, s), 0.0)
    return Surface(hit.t, hit.normal, hit.reflectivity, ambient, centre.t, centre.normal, centre.reflectivity)


def surface_from_depth(depth_m, reflectivity, rays: Rays, radial: bool = False) -> Surface:
    """A surface from a depth map ``(rows, cols)``: Z depth (``radial=False``) or radial distance
    along each pixel's ray, and a reflectivity map (or a number). One ray per pixel; normals from
    the map's finite differences (central inside, one-sided at the border), facing the camera; along
    an axis of one pixel (a map of one row, column or pixel) the surface is taken as facing the
    optical axis there; non-finite or non-positive depths are misses."""
    depth = _f64(depth_m)
    d = rays.centre
    t = depth if radial else depth / d[..., 2]
    ok = jnp.isfinite(t) & (t > 0.0)
    t = jnp.where(ok, t, _INF)
    p = jnp.where(ok, t, 0.0)[..., None] * d
    # The map's derivatives; along an axis of one pixel none exists: a frontal surface's (x, resp. y).
    du = jnp.gradient(p, axis=1) if p.shape[1] > 1 else jnp.broadcast_to(jnp.array([1.0, 0.0, 0.0]), p.shape)
    dv = jnp.gradient(p, axis=0) if p.shape[0] > 1 else jnp.broadcast_to(jnp.array([0.0, 1.0, 0.0]), p.shape)
    n = jnp.cross(du, dv)
    n = n / jnp.maximum(jnp.sqrt(dot3(n, n)), 1e-300)[..., None]
    n = _facing(n, d)
    rho = jnp.broadcast_to(_f64(reflectivity), t.shape)
    return Surface(t[..., None], n[..., None, :], rho[..., None], jnp.ones_like(t)[..., None], t, n, rho)


# --- built-in scenes (distances in m, angles in degrees) ---------------------------------------------


def _parameters(**ranges):
    """Check a scene builder's arguments against ``ranges`` (name -> (lowest, highest), both
    allowed) when it is called: a concrete value out of range raises ``ValueError`` naming the
    builder, the argument, the value and the range; a traced one is wrapped in ``equinox.error_if``
    (:func:`tofjax._schema.checked_range`). ``builder.ranges`` lists them (the command line's
    ``NAME:key=value`` takes these)."""

    def decorate(builder):
        signature = inspect.signature(builder)

        @functools.wraps(builder)
        def checked(*args, **kwargs):
            bound = signature.bind(*args, **kwargs)
            for name, (lo, hi) in ranges.items():
                if name in bound.arguments:
                    bound.arguments[name] = checked_range(bound.arguments[name], f"tofjax.scenes.{builder.__name__}: "
                                                          f"{name}", lo, hi)
            return builder(*bound.args, **bound.kwargs)

        checked.ranges = ranges
        return checked

    return decorate


@_parameters(distance_m=_DISTANCE, reflectivity=_REFLECTIVITY)
def wall(distance_m=1.0, reflectivity=0.9) -> SceneGeometry:
    """A flat wall perpendicular to the optical axis at ``distance_m``."""
    return SceneGeometry((Plane((0.0, 0.0, distance_m), (0.0, 0.0, 1.0), reflectivity),), name="wall")


@_parameters(distance_m=_DISTANCE, angle_deg=(-80.0, 80.0), reflectivity=_REFLECTIVITY)
def tilted_plane(distance_m=1.0, angle_deg=30.0, reflectivity=0.9) -> SceneGeometry:
    """A wall through (0, 0, ``distance_m``) turned by ``angle_deg`` about the vertical axis (its
    right side farther away for a positive angle)."""
    a = jnp.deg2rad(_f64(angle_deg))
    normal = jnp.stack([-jnp.sin(a), jnp.zeros_like(a), jnp.cos(a)])
    return SceneGeometry((Plane(jnp.stack([0.0 * a, 0.0 * a, _f64(distance_m)]), normal, reflectivity),),
                         name="tilted_plane")


@_parameters(near_m=_DISTANCE, far_m=_DISTANCE, edge_x_m=(-1e3, 1e3), reflectivity=_REFLECTIVITY)
def step_edge(near_m=1.0, far_m=2.0, edge_x_m=0.0, reflectivity=0.9) -> SceneGeometry:
    """A board at ``near_m`` covering everything left of x = ``edge_x_m`` in front of a wall at
    ``far_m``: a vertical depth edge (flying pixels along it)."""
    board = Plane((0.0, 0.0, near_m), (0.0, 0.0, 1.0), reflectivity, lo=(-_INF, -_INF, -_INF),
                  hi=(edge_x_m, _INF, _INF))
    back = Plane((0.0, 0.0, far_m), (0.0, 0.0, 1.0), reflectivity)
    return SceneGeometry((board, back), name="step_edge")


@_parameters(camera_height_m=(0.01, 100.0), wall_m=_DISTANCE, box_m=_DISTANCE, box_size_m=(0.001, 100.0),
             reflectivity=_REFLECTIVITY, floor_reflectivity=_REFLECTIVITY)
def box_on_floor(camera_height_m=1.0, wall_m=3.0, box_m=1.8, box_size_m=0.5, reflectivity=0.9,
                 floor_reflectivity=0.3) -> SceneGeometry:
    """A cube of ``box_size_m`` on the floor ``camera_height_m`` below the camera, its front face at
    ``box_m``, in front of a wall at ``wall_m``."""
    h, s = _f64(camera_height_m), _f64(box_size_m)
    floor = Plane(jnp.stack([0.0 * h, -h, 0.0 * h]), (0.0, 1.0, 0.0), floor_reflectivity)
    back = Plane((0.0, 0.0, wall_m), (0.0, 0.0, 1.0), reflectivity)
    cube = Box(jnp.stack([-0.5 * s, -h, _f64(box_m)]), jnp.stack([0.5 * s, -h + s, _f64(box_m) + s]), reflectivity)
    return SceneGeometry((floor, back, cube), name="box_on_floor")


@_parameters(distance_m=_DISTANCE, radius_m=(0.001, 100.0), wall_m=_DISTANCE, reflectivity=_REFLECTIVITY)
def sphere(distance_m=1.5, radius_m=0.3, wall_m=2.5, reflectivity=0.9) -> SceneGeometry:
    """A sphere whose nearest point is at ``distance_m`` on the axis, in front of a wall at ``wall_m``."""
    r = _f64(radius_m)
    ball = Sphere(jnp.stack([0.0 * r, 0.0 * r, _f64(distance_m) + r]), r, reflectivity)
    back = Plane((0.0, 0.0, wall_m), (0.0, 0.0, 1.0), reflectivity)
    return SceneGeometry((ball, back), name="sphere")


@_parameters(distance_m=_DISTANCE, half_angle_deg=(10.0, 80.0), height_m=(0.01, 100.0), reflectivity=_REFLECTIVITY)
def corner(distance_m=2.0, half_angle_deg=45.0, height_m=3.0, reflectivity=0.9, patches_per_side=24,
           depth_m=None) -> SceneGeometry:
    """Two walls meeting in a vertical concave corner on the optical axis at ``distance_m``, each
    at ``half_angle_deg`` to the axis (45: a right-angle corner), ``height_m`` tall, each wall
    ``depth_m`` deep along its own surface (default: reaching the camera plane), with
    ``patches_per_side`` x ``patches_per_side`` patches per wall (an integer, 1 to 256) for their
    two-bounce light."""
    if isinstance(patches_per_side, bool) or not isinstance(patches_per_side, int | np.integer) \
            or not 1 <= patches_per_side <= 256:
        raise ValueError(f"tofjax.scenes.corner: patches_per_side = {patches_per_side!r} is out of range: allowed "
                         "integer 1 <= value <= 256")
    if depth_m is not None:
        depth_m = checked_range(depth_m, "tofjax.scenes.corner: depth_m", *_DISTANCE)
    a = jnp.deg2rad(_f64(half_angle_deg))
    d = _f64(distance_m)
    apex = jnp.stack([0.0 * d, 0.0 * d, d])
    length = d / jnp.cos(a) if depth_m is None else _f64(depth_m)  # along the wall from the corner
    prims, cs, ns, areas = [], [], [], []
    k = patches_per_side
    u = (jnp.arange(k, dtype=float) + 0.5) / k
    for side in (-1.0, 1.0):
        along = jnp.stack([side * jnp.sin(a), 0.0 * a, -jnp.cos(a)])  # from the apex towards the camera
        normal = jnp.stack([-side * jnp.cos(a), 0.0 * a, -jnp.sin(a)])  # facing the camera's side
        end = apex + length * along
        lo = jnp.minimum(apex, end) - jnp.stack([0.0, 0.5 * height_m, 0.0])
        hi = jnp.maximum(apex, end) + jnp.stack([0.0, 0.5 * height_m, 0.0])
        prims.append(Plane(apex, normal, reflectivity, lo=lo - 1e-9, hi=hi + 1e-9))
        centres = (apex[None, None] + (u[:, None, None] * length) * along[None, None]
                   + ((u[None, :, None] - 0.5) * height_m) * jnp.array([0.0, 1.0, 0.0])[None, None])
        cs.append(centres.reshape(-1, 3))
        ns.append(jnp.broadcast_to(normal, (k * k, 3)))
        areas.append(jnp.full((k * k,), 1.0) * length * height_m / k**2)
    patches = Patches(jnp.concatenate(cs), jnp.concatenate(ns), jnp.concatenate(areas),
                      jnp.full((2 * k * k,), 1.0) * _f64(reflectivity))
    return SceneGeometry(tuple(prims), patches, name="corner")


#: Built-in scenes by name: the function and its parameters' allowed ranges (for the command line).
BUILTIN_SCENES = {builder.__name__: (builder, builder.ranges)
                  for builder in (wall, tilted_plane, step_edge, box_on_floor, sphere, corner)}
