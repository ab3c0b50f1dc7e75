"""Two-bounce light from a renderer's buffers (issue 51 item 2; docs/simulators.md, "Multipath"): the
physics of tofjax's corner (:func:`tofjax._returns.two_bounce_returns`) with the patches taken from
what a depth buffer sees instead of from a scene's geometry.

**Patches.** The buffer's image is cut into a grid of blocks (``grid = (rows, cols)`` patches, each
block ceil(b_rows / rows) x ceil(b_cols / cols) buffer pixels). Each buffer pixel that holds a surface
is a flat piece of it: its point P = t r (r its unit ray, t the distance along it), its normal n (the
buffer's, or from the depth's derivatives), its reflectivity, and its area t^2 Omega / cos(i), Omega
the pixel's solid angle and i the angle between its ray and its normal (cos(i) at least
:data:`MIN_COS`: a surface seen edge-on is not infinitely large). A block's patch carries the sum of
its pixels' areas at their area-weighted centroid, with their area-weighted mean normal (unit) and
reflectivity. A block across a depth edge thus puts its light between the two surfaces; the blocks
are small against the scene (the tests' corner: 9 x 9 cm at 1.5 m).

**Light.** Each patch is lit directly by the illumination (its radiant intensity towards the patch,
the baseline, the patch's tilt: its radiance L = rho E / pi); the surface a camera pixel's centre ray
meets receives dE = L cos(theta_patch) cos(theta_pixel) A / s^2 from it, s at least half the patch's
size, no occlusion between the patches and the surface (exact in a concave scene, where every
surface sees every other): :func:`tofjax._returns.two_bounce_returns`' terms, evaluated here in
float32 (the paths to 1e-7 of themselves, 0.3 um at 3 m).

**Returns by path.** A pixel's two-bounce light becomes ``bins`` returns, each the radiance-weighted
mean path of a group of patches whose paths are close: the pixels are taken in tiles of 8 x 32, and
for each tile the patches are sorted by their path r + s to the tile's mean point and split into
``bins`` groups of equal count; every pixel then sums each group's light and its radiance-weighted
path exactly. The corner bins each pixel's paths into equal widths instead, which needs a scatter
per patch and pixel (8 ns on this project's CPU, against 2.5 ns for the whole of a pixel's work
here). A group spans the paths of neighbouring ranks plus at most twice the tile's radius
(triangle inequality): a few centimetres at 1.5 m, 0.1 rad at 80 MHz.

**Cost.** pixels x patches pairs: 224 x 172 pixels and 128 patches are 4.9 M pairs, 12-15 ms on this
project's 2-core CPU; the patches themselves cost one pass over the buffer.
"""

from __future__ import annotations

import math

import jax.numpy as jnp
from jax import lax
from jaxtyping import Array

from ._returns import Returns, _illuminator, intensity_per_w
from ._scene import dot3

#: The smallest cosine of a buffer pixel's incidence in its area (a surface seen edge-on).
MIN_COS = 0.05
#: The pixels' tiles (rows, cols) that share one order of the patches.
TILE = (8, 32)
#: The kernel's precision.
KERNEL_DTYPE = jnp.float32


def patch_grid(count: int, shape: tuple[int, int]) -> tuple[int, int]:
    """A grid of about ``count`` patches over a buffer of ``shape = (rows, cols)``, its blocks as
    square as the aspect allows (at least 1 x 1, at most one patch per pixel)."""
    rows, cols = shape
    gc = max(1, min(cols, round(math.sqrt(count * cols / rows))))
    gr = max(1, min(rows, round(count / gc)))
    return gr, gc


def buffer_patches(points: Array, normals: Array, reflectivity: Array, surface: Array, rays: Array,
                   solid_angle_sr: Array, grid: tuple[int, int]):
    """The patches of a buffer (module docstring): ``(centre (m, 3), normal (m, 3), area_m2 (m,),
    reflectivity (m,))``, m = grid rows x cols; a block without a surface has area 0."""
    rows, cols = surface.shape
    gr, gc = grid
    bh, bw = -(-rows // gr), -(-cols // gc)

    def blocks(x):  # (rows, cols, ...) -> (gr * gc, bh * bw, ...), padded with zeros
        pad = [(0, gr * bh - rows), (0, gc * bw - cols)] + [(0, 0)] * (x.ndim - 2)
        x = jnp.pad(x, pad)
        return x.reshape(gr, bh, gc, bw, *x.shape[2:]).swapaxes(1, 2).reshape(gr * gc, bh * bw, *x.shape[2:])

    t = jnp.sqrt(dot3(points, points))
    cos_i = jnp.maximum(-dot3(normals, rays), MIN_COS)
    area = jnp.where(surface, t * t * solid_angle_sr / cos_i, 0.0)
    a = blocks(area)
    total = jnp.sum(a, axis=1)
    w = a / jnp.where(total > 0.0, total, 1.0)[:, None]
    centre = jnp.sum(w[..., None] * blocks(jnp.where(surface[..., None], points, 0.0)), axis=1)
    normal = jnp.sum(w[..., None] * blocks(normals), axis=1)
    length = jnp.sqrt(dot3(normal, normal))
    empty = ~(total > 0.0) | ~(length > 0.0)
    normal = jnp.where(empty[:, None], jnp.array([0.0, 0.0, -1.0])[None, :],
                       normal / jnp.where(empty, 1.0, length)[:, None])
    centre = jnp.where(empty[:, None], jnp.array([0.0, 0.0, -1.0])[None, :], centre)  # behind the camera, dark
    rho = jnp.where(empty, 0.0, jnp.sum(w * blocks(jnp.where(surface, reflectivity, 0.0)), axis=1))
    return centre, normal, jnp.where(empty, 0.0, total), rho


def two_bounce(illumination, falloff_exponent, baseline_m, patches, t: Array, normal: Array, reflectivity: Array,
               rays: Array, bins: int) -> Returns:
    """Every camera pixel's two-bounce light from ``patches`` (:func:`buffer_patches`) as ``bins``
    returns (module docstring); ``t`` ``(rows, cols)`` the distance along each pixel's centre ray
    ``rays`` (inf: no surface), ``normal`` and ``reflectivity`` what it meets there."""
    centre, pnormal, area, prho = patches
    dtype = t.dtype
    source = _illuminator(baseline_m)
    v = centre - source[None, :]
    r2 = dot3(v, v)
    r = jnp.sqrt(r2)
    cos_beta = jnp.maximum(-dot3(pnormal, v) / r, 0.0)
    radiance = prho * intensity_per_w(illumination, falloff_exponent, v) * cos_beta / (jnp.pi * r2)
    la = radiance * area  # L_patch A_patch
    min_s2 = jnp.maximum(0.25 * area, 1e-12)
    m = centre.shape[0]
    per_group = -(-m // bins)
    pad = per_group * bins - m
    k = KERNEL_DTYPE

    def padded(x, fill):
        return jnp.concatenate([x, jnp.full((pad, *x.shape[1:]), fill, x.dtype)]) if pad else x

    centre_k = padded(centre, 0.0).astype(k).at[m:, 2].set(-1.0) if pad else centre.astype(k)
    pnormal_k, la_k = padded(pnormal, 0.0).astype(k), padded(la, 0.0).astype(k)
    r_k, s2_k = padded(r, 0.0).astype(k), padded(min_s2, 1.0).astype(k)

    rows, cols = t.shape
    th, tw = TILE
    hit = jnp.isfinite(t)
    x = jnp.where(hit, t, 0.0)[..., None] * rays
    n_t, n_c = -(-rows // th), -(-cols // tw)

    def tiles(a):
        pad_ = [(0, n_t * th - rows), (0, n_c * tw - cols)] + [(0, 0)] * (a.ndim - 2)
        a = jnp.pad(a, pad_)
        return a.reshape(n_t, th, n_c, tw, *a.shape[2:]).swapaxes(1, 2).reshape(n_t * n_c, th * tw, *a.shape[2:])

    def one(args):
        xt, nt, ht = args  # (T, 3), (T, 3), (T,)
        count = jnp.sum(ht.astype(k))
        mean = jnp.sum(jnp.where(ht[:, None], xt, 0.0), axis=0) / jnp.maximum(count, 1.0)
        d = mean[None, :] - centre_k
        order = jnp.argsort(r_k + jnp.sqrt(dot3(d, d)))
        c, pn, la_, rr, ms2 = (a[order].reshape(bins, per_group, *a.shape[1:])
                               for a in (centre_k, pnormal_k, la_k, r_k, s2_k))
        w0 = xt[:, 0, None, None] - c[None, :, :, 0]
        w1 = xt[:, 1, None, None] - c[None, :, :, 1]
        w2 = xt[:, 2, None, None] - c[None, :, :, 2]
        s2 = jnp.maximum(w0 * w0 + w1 * w1 + w2 * w2, ms2[None])
        inv = lax.rsqrt(s2)
        cos_patch = jnp.maximum(pn[None, :, :, 0] * w0 + pn[None, :, :, 1] * w1 + pn[None, :, :, 2] * w2, 0.0)
        cos_pixel = jnp.maximum(-(nt[:, 0, None, None] * w0 + nt[:, 1, None, None] * w1 + nt[:, 2, None, None] * w2),
                                0.0)
        inv2 = inv * inv
        e = la_[None] * cos_patch * cos_pixel * inv2 * inv2  # irradiance, (T, bins, per_group)
        path = rr[None] + s2 * inv
        return jnp.sum(e, axis=-1), jnp.sum(e * path, axis=-1)

    total, weighted = lax.map(one, (tiles(x).astype(k), tiles(normal).astype(k), tiles(hit)))

    def untile(a):  # (tiles, T, bins) -> (rows, cols, bins)
        a = a.reshape(n_t, n_c, th, tw, bins).swapaxes(1, 2).reshape(n_t * th, n_c * tw, bins)
        return a[:rows, :cols].astype(dtype)

    total, weighted = untile(total), untile(weighted)
    lit = (total > 0.0) & hit[..., None]
    radiance_px = jnp.where(lit, reflectivity[..., None] * total / jnp.pi, 0.0)
    path_px = jnp.where(lit, jnp.where(hit, t, 0.0)[..., None] + weighted / jnp.where(lit, total, 1.0), 0.0)
    return Returns(path_px, radiance_px, jnp.zeros(t.shape, dtype), t)


