"""The light each pixel of a frame receives: returns of (optical path, radiance), from the scene's
direct light, its two-bounce light, or a transient renderer (docs/model.md, "Full frames").

A **return** is light that left the illumination and reached a pixel along one path: its optical
path length ``path_m`` (illumination -> scene -> ... -> lens; twice the distance for a direct return
from a camera with no baseline) and the radiance the pixel sees from it, per watt of the
illumination's peak power, ``radiance_per_w`` (W m^-2 sr^-1 per W). A pixel's returns add as
phasors in the mixer; a pixel straddling a depth edge has the returns of both surfaces (flying
pixels), a pixel in a corner the direct and the two-bounce ones (multipath). The NPZ format of
:func:`save_returns` / :func:`load_returns` is this, so a transient renderer's output can be fed in.

Direct light (thesis §3.1.1, Eqs 3.1-3.2 generalised off axis). The illumination's radiant intensity
per watt is I(theta) = cos^n(theta) / (cos^3(theta) S), so that on a plane perpendicular to its axis
the irradiance falls as cos^n(theta) (n = ``frame.illumination_falloff_exponent``; n = 0 is the
thesis' flat spot) and the FoV holds the whole power (S = the integral of cos^n over the FoV's
footprint on the plane at 1 m). A Lambertian surface at range r from the illumination, tilted by
beta to it, has irradiance E = P I cos(beta) / r^2 and radiance L = rho E / pi.

Two-bounce light. Each patch of the scene (:class:`tofjax._scene.Patches`) is lit directly and
relights the surface a pixel sees: dE = L_patch cos(theta_patch) cos(theta_pixel) A_patch / s^2
(s >= half the patch size; no occlusion between the patches and the surface, which holds in a concave
corner). The patches' contributions to one pixel are binned by path length (``bins`` per pixel,
radiance-weighted mean path per bin) to a few returns.
"""

from __future__ import annotations

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from ._params import Illumination
from ._scene import Patches, Rays, Surface, dot3


class Returns(eqx.Module):
    """Every return of every pixel (module docstring), plus what the frame's truth and background need.

    **Fields:**
    - ``path_m`` ``(rows, cols, returns)``: optical path illumination -> scene -> lens, m.
    - ``radiance_per_w`` ``(rows, cols, returns)``: the radiance the pixel sees along that path
      (its average over the pixel), W m^-2 sr^-1 per W of peak illumination power; 0 = no return.
    - ``ambient_reflectivity`` ``(rows, cols)``: the pixel's average of reflectivity x ambient
      factor: the background radiance is this x (background irradiance) / pi.
    - ``radial_m`` ``(rows, cols)``: the true distance along the pixel's centre ray to the first
      surface (inf: none).
    - ``phase_image`` (static): ``None``, every return lit every phase image (a static scene); or
      one number per return, the phase image it belongs to (0, 1, ...; -1: every one), so that a
      scene that moves during a frame is its returns at each phase image's instants (docs/model.md,
      "A camera in time: motion").
    - ``source`` (static): ``None``, every return this camera's own light; or one number per return,
      0 for this camera's light and 1 for an interfering camera's (docs/model.md, "Interference"; its
      radiance is per watt of that camera's peak power).
    """

    path_m: Float[Array, "rows cols returns"]
    radiance_per_w: Float[Array, "rows cols returns"]
    ambient_reflectivity: Float[Array, "rows cols"]
    radial_m: Float[Array, "rows cols"]
    phase_image: tuple[int, ...] | None = eqx.field(static=True, default=None)
    source: tuple[int, ...] | None = eqx.field(static=True, default=None)

    def __check_init__(self):
        """Shapes always; values (:data:`RETURNS_RANGES`) when concrete: a NaN path or a negative
        radiance is refused where it is made, naming the array and the element."""
        p, r = self.path_m, self.radiance_per_w
        if p.ndim != 3 or p.shape != r.shape or p.shape[-1] < 1:
            raise ValueError(f"tofjax.Returns: path_m has shape {p.shape} and radiance_per_w {r.shape}: allowed "
                             "equal shapes (rows, cols, returns) with at least one return per pixel (a pixel without "
                             "light: one return of radiance 0)")
        tags = self.phase_image
        if tags is not None and (len(tags) != p.shape[-1] or not all(isinstance(j, int) and j >= -1 for j in tags)):
            raise ValueError(f"tofjax.Returns: phase_image = {tags!r}: allowed one phase image (0, 1, ...; -1: every one) "
                             f"for each of the {p.shape[-1]} returns")
        if self.source is not None and (len(self.source) != p.shape[-1] or not set(self.source) <= {0, 1}):
            raise ValueError(f"tofjax.Returns: source = {self.source!r}: allowed 0 (this camera's light) or 1 (an "
                             f"interfering camera's) for each of the {p.shape[-1]} returns")
        for key in ("ambient_reflectivity", "radial_m"):
            if getattr(self, key).shape != p.shape[:2]:
                raise ValueError(f"tofjax.Returns: {key} has shape {getattr(self, key).shape}: allowed {p.shape[:2]} "
                                 "(rows, cols of path_m)")
        from ._schema import _is_tracer

        for key in RETURNS_RANGES:
            if not _is_tracer(getattr(self, key)):  # traced ones: checked()
                check_values("tofjax.Returns", key, getattr(self, key))

    @property
    def shape(self) -> tuple[int, int]:
        return tuple(self.radial_m.shape)

    def checked(self) -> Returns:
        """These returns, their values checked where they are traced (inside a caller's ``jit``,
        ``vmap`` or ``grad``, where construction could not): ``equinox.error_if`` on each array,
        raising when the program runs (concrete ones were checked when made)."""
        from ._schema import _is_tracer

        if not any(_is_tracer(getattr(self, key)) for key in RETURNS_RANGES):
            return self
        return Returns(**{key: check_values("tofjax.Returns", key, getattr(self, key)) for key in RETURNS_RANGES},
                       phase_image=self.phase_image, source=self.source)

    def __add__(self, other: Returns) -> Returns:
        """Both sets of returns (the background and truth of ``self``)."""
        def merged(name, untagged):
            mine, theirs = getattr(self, name), getattr(other, name)
            if mine is None and theirs is None:
                return None
            return tuple(mine or (untagged,) * self.path_m.shape[-1]) + tuple(theirs or (untagged,) * other.path_m.shape[-1])

        return Returns(jnp.concatenate([self.path_m, other.path_m], axis=-1),
                       jnp.concatenate([self.radiance_per_w, other.radiance_per_w], axis=-1),
                       self.ambient_reflectivity, self.radial_m, merged("phase_image", -1), merged("source", 0))

    def own_light(self) -> np.ndarray | None:
        """``(returns,)``: 1 for this camera's own light, 0 for an interfering camera's
        (:attr:`source`); ``None`` when every return is its own."""
        return None if self.source is None else (np.asarray(self.source) == 0).astype(float)

    def phase_mask(self, n_phases: int) -> np.ndarray | None:
        """``(returns, phases)``: 1 where a return lights a phase image (:attr:`phase_image`), ``None``
        for a static scene's returns (each lights every one). ``ValueError`` for a phase image the
        camera does not have."""
        if self.phase_image is None:
            return None
        tags = np.asarray(self.phase_image)
        if tags.max(initial=-1) >= n_phases:
            raise ValueError(f"tofjax.Returns: phase_image names phase image {int(tags.max())}: the camera has "
                             f"{n_phases} (0-{n_phases - 1}; -1: every one)")
        return ((tags[:, None] == -1) | (tags[:, None] == np.arange(n_phases)[None, :])).astype(float)


# Gauss-Legendre nodes for the rectangular FoV's normalisation (smooth integrand; 48 nodes per axis are
# exact to rounding for the exponents allowed).
_GL_X, _GL_W = np.polynomial.legendre.leggauss(48)


def _tan_half(fov_deg: Array) -> Array:
    return jnp.tan(jnp.deg2rad(fov_deg) / 2.0)


def footprint_integral(illumination: Illumination, falloff_exponent) -> Array:
    """S = the integral of cos^n(theta) over the FoV's footprint on a plane at 1 m, m^2 (n = 0:
    pi tan^2(FoV/2) or 4 tan(h/2) tan(v/2), the thesis' spot area at 1 m, Eq 3.1)."""
    n = _real(falloff_exponent)
    t = _tan_half(illumination.fov_deg)
    if illumination.fov_deg.shape == ():
        # integral over the disc of radius T of (1 + rho^2)^(-n/2) 2 pi rho d rho, in closed form
        u = jnp.log1p(t * t)
        m = 1.0 - 0.5 * n
        small = jnp.abs(m) < 1e-8
        m_safe = jnp.where(small, 1.0, m)
        return jnp.pi * jnp.where(small, u, jnp.expm1(m_safe * u) / m_safe)
    x = jnp.asarray(_GL_X, t.dtype) * t[0]
    y = jnp.asarray(_GL_X, t.dtype) * t[1]
    w = jnp.asarray(_GL_W, t.dtype)
    f = (1.0 + x[:, None] ** 2 + y[None, :] ** 2) ** (-0.5 * n)
    return t[0] * t[1] * jnp.sum(w[:, None] * w[None, :] * f)


def intensity_per_w(illumination: Illumination, falloff_exponent, v: Float[Array, "*r 3"]) -> Float[Array, "*r"]:
    """Radiant intensity of the illumination towards ``v`` (vectors from it, its axis +z), per watt of
    peak power, W/sr/W: cos^n / (cos^3 S) inside the FoV, 0 outside (module docstring)."""
    vz = v[..., 2]
    ahead = vz > 0.0
    vz_safe = jnp.where(ahead, vz, 1.0)
    tx, ty = v[..., 0] / vz_safe, v[..., 1] / vz_safe
    t = _tan_half(illumination.fov_deg)
    if illumination.fov_deg.shape == ():
        inside = tx * tx + ty * ty <= t * t
    else:
        inside = (jnp.abs(tx) <= t[0]) & (jnp.abs(ty) <= t[1])
    n = _real(falloff_exponent)
    # cos^(n - 3) = (1 + tan^2)^((3 - n) / 2), as exp and log1p: XLA's CPU pow of a traced exponent
    # costs several times as much, per sub-pixel ray.
    value = jnp.exp((1.5 - 0.5 * n) * jnp.log1p(tx * tx + ty * ty)) / footprint_integral(illumination, n)
    return jnp.where(ahead & inside, value, 0.0)


def axis_return(illumination: Illumination, falloff_exponent, reflectivity: Array,
                distance_m: Float[Array, "*b"]) -> tuple[Float[Array, "*b"], Float[Array, "*b"]]:
    """The one return of the pixel on the optical axis looking at a wall that faces the camera at
    ``distance_m``, the illumination at the lens (the thesis' centre pixel, §3.1): ``(radiance_per_w,
    path_m)``, what :func:`direct_returns` computes for that ray without a baseline: the
    illumination's intensity along its axis (evaluated once) over pi d^2, and the path 2 d."""
    d = jnp.asarray(distance_m, dtype=float)
    on_axis = intensity_per_w(illumination, falloff_exponent, jnp.array([0.0, 0.0, 1.0]))
    return reflectivity * on_axis / (jnp.pi * d * d), d + d


def _illuminator(baseline_m) -> Array:
    b = _real(baseline_m)
    return jnp.stack([b[0], b[1], jnp.zeros_like(b[0])])


def _real(x) -> Array:
    """``x`` as a floating-point array in its own precision (a float32 camera's stays float32, an
    integer or a Python number becomes float64)."""
    x = jnp.asarray(x)
    return x if jnp.issubdtype(x.dtype, jnp.floating) else x.astype(float)


def direct_returns(illumination: Illumination, falloff_exponent, baseline_m, surface: Surface,
                   rays: Rays) -> Returns:
    """The direct return of every sub-pixel ray (module docstring); one return per ray."""
    d = rays.samples
    hit = surface.hit
    t = jnp.where(hit, surface.t_m, 1.0)
    v = t[..., None] * d - jnp.broadcast_to(_illuminator(baseline_m), d.shape)
    r2 = dot3(v, v)
    r = jnp.sqrt(r2)
    cos_beta = jnp.maximum(-dot3(surface.normal, v) / r, 0.0)  # lit side = the side the camera sees
    radiance = surface.reflectivity * intensity_per_w(illumination, falloff_exponent, v) * cos_beta / (jnp.pi * r2)
    sub = d.shape[-2]
    radiance = jnp.where(hit, radiance, 0.0) / sub
    ambient = jnp.mean(jnp.where(hit, surface.reflectivity * surface.ambient, 0.0), axis=-1)
    return Returns(jnp.where(hit, r + t, 0.0), radiance, ambient, surface.radial_m)


def two_bounce_returns(illumination: Illumination, falloff_exponent, baseline_m, surface: Surface, rays: Rays,
                       patches: Patches, bins: int = 32) -> Returns:
    """Light that reaches each pixel's surface via one patch (module docstring), binned into ``bins``
    returns per pixel by path length. Evaluated at the pixel's centre ray, one image row at a time."""
    source = _illuminator(baseline_m)
    v = patches.centre - source[None]
    r_y2 = dot3(v, v)
    r_y = jnp.sqrt(r_y2)
    cos_beta = jnp.maximum(-dot3(patches.normal, v) / r_y, 0.0)
    patch_radiance = patches.reflectivity * intensity_per_w(illumination, falloff_exponent, v) * cos_beta \
        / (jnp.pi * r_y2)  # W m^-2 sr^-1 per W
    min_s = 0.5 * jnp.sqrt(patches.area_m2)

    def row(args):
        t, normal, rho, d = args  # (cols,), (cols, 3), (cols,), (cols, 3)
        hit = jnp.isfinite(t)
        x = jnp.where(hit, t, 1.0)[:, None] * d
        w = x[:, None, :] - patches.centre[None]  # patch -> surface point, (cols, m, 3)
        s = jnp.maximum(jnp.sqrt(dot3(w, w)), min_s[None])
        cos_patch = jnp.maximum(dot3(patches.normal[None], w) / s, 0.0)
        cos_pixel = jnp.maximum(-dot3(normal[:, None, :], w) / s, 0.0)
        irradiance = patch_radiance[None] * cos_patch * cos_pixel * patches.area_m2[None] / (s * s)
        radiance = jnp.where(hit[:, None], rho[:, None] * irradiance / jnp.pi, 0.0)
        path = r_y[None] + s + jnp.where(hit, t, 0.0)[:, None]
        lit = radiance > 0.0
        lo = jnp.min(jnp.where(lit, path, jnp.inf), axis=-1, keepdims=True)
        hi = jnp.max(jnp.where(lit, path, -jnp.inf), axis=-1, keepdims=True)
        lo = jnp.where(jnp.isfinite(lo), lo, 0.0)
        width = jnp.maximum(jnp.where(jnp.isfinite(hi), hi, 0.0) - lo, 1e-9)
        index = jnp.clip(jnp.floor((path - lo) / width * bins), 0, bins - 1).astype(jnp.int32)
        # Each patch's light into its bin: a scatter-add over the row's (column, bin) cells, one add
        # per patch (a one-hot product did `bins` times as many multiply-adds; docs/model.md).
        cell = (index + bins * jnp.arange(index.shape[0], dtype=jnp.int32)[:, None]).reshape(-1)
        cells = index.shape[0] * bins
        total = jax.ops.segment_sum(radiance.reshape(-1), cell, cells).reshape(-1, bins)
        weighted = jax.ops.segment_sum((radiance * path).reshape(-1), cell, cells).reshape(-1, bins)
        mean_path = weighted / jnp.where(total > 0.0, total, 1.0)
        return jnp.where(total > 0.0, mean_path, 0.0), total

    path, radiance = jax.lax.map(row, (surface.centre_t_m, surface.centre_normal, surface.centre_reflectivity,
                                       rays.centre))
    return Returns(path, radiance, jnp.zeros(surface.radial_m.shape), surface.radial_m)


def save_returns(path, returns: Returns) -> None:
    """Write ``returns`` as NPZ (atomically, :mod:`tofjax.outputs`): arrays ``path_m``,
    ``radiance_per_w`` (rows, cols, returns), ``ambient_reflectivity`` and ``radial_m`` (rows,
    cols), and ``format = "tofjax-returns/1"``."""
    from .outputs import write_npz

    if returns.phase_image is not None or returns.source is not None:
        raise ValueError("save_returns: these returns belong to phase images of a moving scene (Returns.phase_image) "
                         "or include another camera's light (Returns.source); the tofjax-returns/1 file holds one "
                         "camera's light of a static scene: save each instant's returns without interference instead")
    write_npz(path, {"format": np.array("tofjax-returns/1"), "path_m": np.asarray(returns.path_m),
                     "radiance_per_w": np.asarray(returns.radiance_per_w),
                     "ambient_reflectivity": np.asarray(returns.ambient_reflectivity),
                     "radial_m": np.asarray(returns.radial_m)})


#: The arrays of a returns file and their allowed values: (lowest, highest, infinity allowed, unit).
#: Paths: a direct return travels twice the distance (scene.distance_m <= 1000 m), a multi-bounce
#: one farther; radiance: the brightest direct return, a white wall at 1 mm, is about 1e5 per W.
RETURNS_RANGES = {
    "path_m": (0.0, 1e4, False, "m"),
    "radiance_per_w": (0.0, 1e9, False, "W m^-2 sr^-1 per W"),
    "ambient_reflectivity": (0.0, 1.0, False, "1"),
    "radial_m": (0.0, 1e3, True, "m (inf: no surface)"),
}


def check_values(name: str, key: str, value):
    """``value`` if it lies in its array's range of :data:`RETURNS_RANGES`
    (:func:`tofjax._schema.checked_range`: ``ValueError`` naming ``name``, the array and the first
    bad element; traced: ``equinox.error_if``)."""
    from ._schema import checked_range

    lo, hi, allow_inf, unit = RETURNS_RANGES[key]
    return checked_range(value, f"{name}: {key}", lo, hi, allow_inf=allow_inf, unit=unit)


def load_returns(path, shape: tuple[int, int] | None = None, *, max_bytes: int | None = None) -> Returns:
    """Read an NPZ of returns (:func:`save_returns`'s arrays; ``ambient_reflectivity`` defaults to 0
    and ``radial_m`` to half the path of each pixel's strongest return, inf where it has none).
    Raises ``ValueError`` with one line naming the file (and the array) for a file that is not an
    NPZ file or is damaged, a missing array, an array that is not numbers, a wrong shape, or a value
    outside :data:`RETURNS_RANGES`; ``shape``: the frame's (rows, cols) the file must match;
    ``max_bytes``: the most memory its arrays may take (checked from their headers before any is
    read; default: what this process has available)."""
    from ._limits import available_memory_bytes
    from ._npz import npz_arrays

    name = str(path)
    arrays = npz_arrays(path, tuple(RETURNS_RANGES), max_bytes=available_memory_bytes() // 2 if max_bytes is None
                        else max_bytes)
    for key in ("path_m", "radiance_per_w"):
        if key not in arrays:
            raise ValueError(f"{name}: array {key!r} is missing: a returns file holds path_m and radiance_per_w "
                             "(rows, cols, returns), optionally ambient_reflectivity and radial_m (rows, cols)")
    p, rad = arrays["path_m"].astype(float), arrays["radiance_per_w"].astype(float)
    if p.ndim == 2:
        p, rad = p[..., None], rad[..., None]
    if p.ndim != 3 or p.shape != rad.shape or p.shape[-1] < 1:
        raise ValueError(f"{name}: path_m has shape {p.shape} and radiance_per_w {rad.shape}: allowed equal shapes "
                         "(rows, cols, returns) with at least one return per pixel")
    if shape is not None and p.shape[:2] != tuple(shape):
        raise ValueError(f"{name}: path_m has {p.shape[0]} x {p.shape[1]} pixels, the camera {shape[0]} x {shape[1]} "
                         "(rows x cols; camera.optical_area_m / camera.pixel_pitch_m)")
    rows, cols = p.shape[:2]
    check_values(name, "path_m", p)
    check_values(name, "radiance_per_w", rad)
    ambient = arrays["ambient_reflectivity"].astype(float) if "ambient_reflectivity" in arrays else np.zeros((rows, cols))
    if "radial_m" in arrays:
        radial = arrays["radial_m"].astype(float)
    else:  # half the strongest return's path: the distance of a direct return without baseline
        strongest = np.take_along_axis(p, np.argmax(rad, axis=-1)[..., None], axis=-1)[..., 0]
        radial = np.where(np.max(rad, axis=-1) > 0.0, 0.5 * strongest, np.inf)
    for key, value in (("ambient_reflectivity", ambient), ("radial_m", radial)):
        if value.shape != (rows, cols):
            raise ValueError(f"{name}: {key} has shape {value.shape}: allowed ({rows}, {cols})")
        check_values(name, key, value)
    return Returns(jnp.asarray(p), jnp.asarray(rad), jnp.asarray(ambient), jnp.asarray(radial))
