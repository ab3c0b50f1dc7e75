"""Pixel-to-pixel (fixed-pattern) effects of a frame (thesis §6.1.2, future work; docs/model.md, "Full
frames"): one reproducible sample of a camera's pixels, drawn once from a seed.

- Photo-response non-uniformity (PRNU): each pixel's responsivity times a log-normal gain of mean 1
  and relative sigma ``frame.prnu_sigma`` (positive for any sigma).
- Dark-signal non-uniformity (DSNU): each tap's dark slope from the gamma population of the centre
  pixel (``pixel.dark_slope_mean_v_per_s``, ``pixel.dark_slope_sigma_v_per_s``).
- Fixed-pattern phase offset: each pixel's demodulation phase shifted by a normal of sigma
  ``frame.phase_offset_sigma_rad`` (clock skew across the array, phase-shifter error).
- Tap asymmetry: tap A collects 1 + e and tap B 1 - e of the pixel's photo charge, e normal of sigma
  ``frame.tap_asymmetry_sigma``.
- Threshold deviation: each pixel's SBI threshold and full well times 1 + a normal of sigma
  ``frame.threshold_sigma``.

The normals are truncated at 5 sigma (the schema's sigma limits then keep 1 - e and the full-well
factor above 0.25; the truncation changes a sigma by 1.5e-5 of itself).
"""

from __future__ import annotations

import equinox as eqx
import jax
import jax.numpy as jnp
import jax.random as jr
from jaxtyping import Array, Float, PRNGKeyArray

from . import _jit
from ._params import Params


def pixel_dark_slopes(params: Params, key: PRNGKeyArray, pixels: tuple[int, ...] = ()) -> Array:
    """Dark slopes (V/s) of taps A and B, ``(2, *pixels)``, drawn from the population: a gamma
    distribution (positive) with the configured mean and pixel-to-pixel sigma (the dark-signal
    non-uniformity); ``pixels``: the shape of an array of pixels (``()``: one pixel)."""
    mean, sigma = params.pixel.dark_slope_mean_v_per_s, params.pixel.dark_slope_sigma_v_per_s
    ok = (mean > 0) & (sigma > 0)
    shape = jnp.where(ok, mean**2 / jnp.where(ok, sigma, 1.0) ** 2, 1.0)
    draw = jr.gamma(key, shape, (2, *pixels)) * jnp.where(ok, sigma**2 / jnp.where(ok, mean, 1.0), 0.0)
    return jnp.where(ok, draw, mean)


class PixelPattern(eqx.Module):
    """Per-pixel parameters of one camera sample, each ``(rows, cols)`` (module docstring)."""

    gain: Float[Array, "rows cols"]
    dark_slope_a_v_per_s: Float[Array, "rows cols"]
    dark_slope_b_v_per_s: Float[Array, "rows cols"]
    phase_offset_rad: Float[Array, "rows cols"]
    tap_asymmetry: Float[Array, "rows cols"]
    full_well_scale: Float[Array, "rows cols"]


def one_pixel(pattern: PixelPattern | None) -> PixelPattern | None:
    """A pattern of one pixel (``(1, 1)``, ``(1,)`` or scalars) as scalars: the swept pixel's own
    parameters (the centre pixel's sample); ``None`` stays ``None``. Refuses a pattern of several
    pixels in one line."""
    if pattern is None:
        return None
    if not isinstance(pattern, PixelPattern):
        raise TypeError(f"pattern must be a tofjax.PixelPattern or None, got {type(pattern).__name__}")
    size = jnp.size(pattern.gain)
    if size != 1:
        raise ValueError(f"a sweep's pixel sample is a pattern of one pixel, got {jnp.shape(pattern.gain)}: draw it "
                         "with tj.draw_pattern(params, settings, (1, 1))")
    return jax.tree_util.tree_map(lambda x: jnp.reshape(x, ()), pattern)


def mean_pattern(params: Params, shape: tuple[int, int]) -> PixelPattern:
    """Every pixel the mean pixel (the thesis' centre pixel)."""
    ones, zeros = jnp.ones(shape), jnp.zeros(shape)
    slope = params.pixel.dark_slope_mean_v_per_s * ones
    return PixelPattern(ones, slope, slope, zeros, zeros, ones)


def draw_pattern(params: Params, settings, shape: tuple[int, int], key: PRNGKeyArray | None = None) -> PixelPattern:
    """A camera sample of ``shape = (rows, cols)`` pixels with the sigmas of ``settings``
    (:class:`tofjax.FrameSettings`); ``key`` defaults to ``jax.random.key(settings.seed)``, so the
    same seed gives the same camera."""
    key = jr.key(settings.seed) if key is None else key
    return _draw(params, settings, shape, key)


@_jit.jit
def _draw(params: Params, settings, shape: tuple[int, int], key: PRNGKeyArray) -> PixelPattern:
    """:func:`draw_pattern`'s sample, one program per shape (eagerly, its draws were a program each)."""
    k_gain, k_dark, k_phase, k_tap, k_well = jr.split(key, 5)
    normal = lambda k: jr.truncated_normal(k, -5.0, 5.0, shape, dtype=float)  # noqa: E731
    s2 = jnp.log1p(settings.prnu_sigma**2)  # log-normal with mean 1 and relative sigma prnu_sigma
    gain = jnp.exp(jnp.sqrt(s2) * jr.normal(k_gain, shape, dtype=float) - 0.5 * s2)
    slopes = pixel_dark_slopes(params, k_dark, shape)
    return PixelPattern(gain, slopes[0], slopes[1], settings.phase_offset_sigma_rad * normal(k_phase),
                        settings.tap_asymmetry_sigma * normal(k_tap), 1.0 + settings.threshold_sigma * normal(k_well))
