"""Noisy frames of the chain and their reduction to per-point sums (docs/model.md, "Monte Carlo"); how
the chunks of a run are executed is :mod:`tofjax._executor`'s.

Random-number economy. A frame needs, per phase image, the noisy charge of each tap before the limit
and the noise added after it. Sources at one node are independent Gaussians, so one normal per tap
carries all sources before the limit, and one per phase image the sources after it (only the
differential A - B is read out, so per-tap draws there would be wasted). Where the limit cannot act
(:meth:`~tofjax._saturation.AbstractLimit.linear`: no tap within reach of saturation or an SBI floor,
and the SBI flag the same for every frame), the limit passes the differential unchanged, and the sum
of the three draws is one normal of the summed variance: one draw per phase image. "Within reach" is
:data:`~tofjax._random.MAX_ABS_NORMAL` standard deviations, the largest deviate the generator returns,
so this path is not an approximation: no frame of the three-draw path could have hit a limit there.
The path is chosen per operating point; a block of points that are all linear draws one normal per
phase image (a real branch, not a select), any other block both sets and keeps each point's own.

Sums. Each chunk of frames is reduced to per-point sums (valid frames, phase deviations and their
squares, amplitudes and squares, flags, codes) before the next is drawn (:mod:`tofjax._executor`).
Deviations are taken from the noise-free frame's phase and amplitude (a fixed centre close to the
mean), which keeps the sums of squares well conditioned and makes a noise-free run's standard
deviation exactly 0.
"""

from __future__ import annotations

import functools
import math

import equinox as eqx
import jax.numpy as jnp
from jax import lax
from jaxtyping import Array

from . import _depth
from ._chain import Chain
from ._charges import TapCharges
from ._processing import (Layout, any_of_groups, expand_patches, first_of_groups, frames_in, patch_size, process,
                          whole_frames)
from ._random import MAX_ABS_NORMAL, normals
from ._reduce import sum_by_slices

_TWO_PI = 2.0 * math.pi


class PointConstants(eqx.Module):
    """What the frames of one operating point need, phase axis first: ``(phases, points)``."""

    n_a: Array
    n_b: Array
    sd_a: Array  # before the limit, per tap
    sd_b: Array
    sd_after: Array  # after the limit, of the differential
    sd_after_a: Array  # after the limit, of tap A (tap B's: the rest of sd_after); the raw taps need it
    sd_fast: Array  # everything, of the differential (linear points)
    linear: Array  # (points,) the one-draw path is exact
    sbi_fixed: Array  # (points,) the SBI flag of every frame of a linear point
    ref_phase: Array  # (points,) phase of the noise-free frame
    ref_amp: Array  # (points,) amplitude of the noise-free frame
    index: Array  # (points,) uint32 counter word of the point
    full_well_e: Array | None = None  # (points,) each point's own full well (a frame's pixels), else the chain's
    lit: Array | None = None  # (points,) the pixel receives the camera's light (else no frame of it is valid)

    def constants(self, chain: Chain) -> PointConstants:
        """Itself (:class:`PointCharges` makes them)."""
        return self


class PointCharges(eqx.Module):
    """The points' expected charges, from which :func:`draw_frames` makes the :class:`PointConstants`
    inside the branch that draws (one chunk of a camera frame's frames): XLA then fuses them into
    the frame's own loop instead of writing eight ``(phases, points)`` arrays first and reading them
    back (docs/model.md, "Performance", measurement 1).

    **Fields:** ``exposed``: what makes the points' :class:`~tofjax._charges.TapCharges` with its
    ``charges()``, flattened ``(points, ...)``: the charges themselves, or a frame's
    :class:`~tofjax._charges.Exposure` (then the taps' charges, too, are made inside the branch,
    from the program's input, and nothing of them is written out); ``index``, ``full_well_e``: as
    :func:`point_constants`."""

    exposed: TapCharges | eqx.Module
    index: Array
    full_well_e: Array | None = None

    def constants(self, chain: Chain) -> PointConstants:
        return point_constants(chain, self.exposed.charges(), self.index, self.full_well_e)


def _limit(chain: Chain, full_well_e: Array | None, frames: bool, frames_first: bool = False) -> Chain:
    """The chain with each point's own full well ``(points,)`` where given, its limit shaped for
    charges ``(points, phases)`` or (``frames``) ``(phases, points, frames)`` (``frames_first``:
    ``(phases, frames, points)``)."""
    if full_well_e is None:
        return chain
    well = (full_well_e[None, None, :] if frames_first else full_well_e[None, :, None]) if frames else full_well_e[:, None]
    return chain.with_limit(eqx.tree_at(lambda lim: lim.full_well_e, chain.limit, well))


def point_constants(chain: Chain, charges: TapCharges, index: Array, full_well_e: Array | None = None) -> PointConstants:
    """Per-point constants of the frames from the expected charges (flattened points), the moments
    through the stages the draw covers (:meth:`tofjax.chain.Chain.drawn_moments`); ``full_well_e``
    ``(points,)``: each point's own full well (default: the chain's)."""
    chain = _limit(chain, full_well_e, frames=False)
    m = chain.drawn_moments(charges)
    n_a, n_b = charges.a, charges.b
    var_a, var_b, post_a, post_b = m.var_a, m.var_b, m.post_a, m.post_b
    sd_a, sd_b = jnp.sqrt(var_a), jnp.sqrt(var_b)
    linear, always = chain.limit.linear(n_a, n_b, MAX_ABS_NORMAL * sd_a, MAX_ABS_NORMAL * sd_b)
    t = lambda x: jnp.moveaxis(x, -1, 0)  # noqa: E731 - (points, phases) -> (phases, points)
    ref = chain.samples(t(m.diff))  # the noise-free frame (its phase as the camera's processing leaves it)
    return PointConstants(
        n_a=t(n_a), n_b=t(n_b), sd_a=t(sd_a), sd_b=t(sd_b), sd_after=t(jnp.sqrt(post_a + post_b)),
        sd_after_a=t(jnp.sqrt(jnp.broadcast_to(post_a, n_a.shape))),
        sd_fast=t(jnp.sqrt(var_a + var_b + post_a + post_b)), linear=jnp.all(linear, axis=-1),
        sbi_fixed=jnp.any(always, axis=-1), ref_phase=chain.reference_phase(ref.phase), ref_amp=ref.amplitude,
        index=index,
        full_well_e=full_well_e, lit=charges.signal_e > 0.0,
    )


class FrameBatch(eqx.Module):
    """Frames of a block of points: codes ``(phases, points, frames)``; the rest ``(points, frames)``;
    with ``taps``, each tap's electrons as read, ``(phases, points, frames)`` (:func:`draw_frames`)."""

    codes: Array
    phase: Array  # arg Z in (-pi, pi]
    amplitude: Array
    pixel_saturated: Array
    adc_saturated: Array
    sbi_engaged: Array
    tap_a_e: Array | None = None
    tap_b_e: Array | None = None
    valid: Array | None = None  # not saturated, lit, and (:func:`draw_delivered`) delivered by its processing


def draw_frames(chain: Chain, source: PointConstants | PointCharges, key: tuple[Array, Array], first_frame: Array,
                n_frames: int, stream=0, linear: Array | None = None, frames_first: bool = False,
                taps: bool = False) -> FrameBatch:
    """Frames ``first_frame .. first_frame + n_frames - 1`` of every point of ``source`` (module
    docstring): its :class:`PointConstants`, or the :class:`PointCharges` they are made from inside
    the branch that draws. ``stream`` separates the random streams of several chains (one per
    modulation frequency); ``linear`` (points,) overrides the constants' ``linear``, the points that
    take the one-draw path (pass it from outside a ``vmap`` so that the choice of path stays a
    branch). ``frames_first`` (static): the batch's axes are ``(phases, frames, points)`` and
    ``(frames, points)`` instead of points first; the same numbers (the draws are keyed by frame and
    point, not by position).

    ``taps`` (static): also each tap's electrons as read, A' = held A + E_A and B' = held B + E_B
    (the held charge plus its own noise after the limit), of which the codes digitise the
    difference A' - B' (the raw phase images' taps; docs/model.md, "Raw phase images"). They take
    up to three more normals w1, w2, w3 per phase image from a stream of their own, so the frames
    are the same with and without them. Each is a Gaussian conditional draw (for x, y jointly
    Gaussian, x | y has mean m_x + C_xy / V_y (y - m_y) and variance V_x - C_xy^2 / V_y):
    three-draw path, the differential's noise after the limit e = E_A - E_B splits as
    E_A = e p_A / (p_A + p_B) + sqrt(p_A p_B / (p_A + p_B)) w3 (p: the taps' variances after the
    limit); one-draw path (where the limit keeps the difference), the difference before the limit
    d0 = A - B is drawn given the drawn D (w1), the taps' sum A + B given d0 (w2), the limit applied
    to A = (sum + d0) / 2 and B = (sum - d0) / 2 (SBI removes their common mode), and e = D - d0
    split as on the other path (w3). Exact in distribution on both paths."""
    limited = _limit(chain, source.full_well_e, frames=True, frames_first=frames_first)
    limit, n_phases, real = limited.limit, chain.n_phases, chain.dtype  # real: the draws' precision
    frame = first_frame + jnp.arange(n_frames, dtype=jnp.uint32)
    if frames_first:
        frame, point = frame[:, None], source.index[None, :]
        col = lambda x: x[:, None, :]  # noqa: E731 - (phases, points) -> (phases, 1, points)
        per_point = lambda x: x[None, :]  # noqa: E731 - (points,) -> (1, points)
    else:
        frame, point = frame[None, :], source.index[:, None]
        col = lambda x: x[..., None]  # noqa: E731 - (phases, points) -> (phases, points, 1)
        per_point = lambda x: x[:, None]  # noqa: E731 - (points,) -> (points, 1)

    def tap_normals():  # the raw taps' own stream (4 stream + 2): w1, w2, w3 per phase image
        w = normals(key, frame, point, 4 * stream + 2, 3 * n_phases).astype(real)
        return w[:n_phases], w[n_phases:2 * n_phases], w[2 * n_phases:]

    def split_after(c, held_a, held_b, after, w3):
        """The taps as read, from the held charges and the differential's noise after the limit."""
        post_a = c.sd_after_a**2
        post_b = jnp.maximum(c.sd_after**2 - post_a, 0.0)  # not below 0 by rounding
        total = _nonzero(post_a + post_b)
        after_a = col(post_a / total) * after + col(jnp.sqrt(post_a * post_b / total)) * w3
        return held_a + after_a, held_b + after_a - after

    def one_draw(src):
        c = src.constants(chain)
        z = normals(key, frame, point, 4 * stream, n_phases).astype(real)
        mean_diff = col(c.n_a - c.n_b)
        diff = mean_diff + col(c.sd_fast) * z
        shape = diff.shape[1:]
        out = (diff, jnp.zeros(shape, dtype=bool), jnp.broadcast_to(per_point(c.sbi_fixed), shape))
        if not taps:
            return out
        w1, w2, w3 = tap_normals()
        var_a, var_b = c.sd_a**2, c.sd_b**2
        before, total = _nonzero(var_a + var_b), _nonzero(c.sd_fast**2)
        after_var = c.sd_after**2
        d0 = mean_diff + col((var_a + var_b) / total) * (diff - mean_diff) \
            + col(jnp.sqrt((var_a + var_b) * after_var / total)) * w1  # A - B before the limit, given D
        s0 = col(c.n_a + c.n_b) + col((var_a - var_b) / before) * (d0 - mean_diff) \
            + col(jnp.sqrt(4.0 * var_a * var_b / before)) * w2  # A + B, given A - B
        held_a, held_b = limit(0.5 * (s0 + d0), 0.5 * (s0 - d0))
        return (*out, *split_after(c, held_a, held_b, diff - d0, w3))

    def three_draws(src):
        c = src.constants(chain)
        z = normals(key, frame, point, 4 * stream + 1, 3 * n_phases).astype(real)
        a = col(c.n_a) + col(c.sd_a) * z[:n_phases]
        b = col(c.n_b) + col(c.sd_b) * z[n_phases:2 * n_phases]
        saturated, engaged = limit.flags(a, b)
        held_a, held_b = limit(a, b)
        after = col(c.sd_after) * z[2 * n_phases:]
        diff = held_a - held_b + after
        out = (diff, jnp.any(saturated, axis=0), jnp.any(engaged, axis=0))
        if not taps:
            return out
        return (*out, *split_after(c, held_a, held_b, after, tap_normals()[2]))

    linear = source.constants(chain).linear if linear is None else linear

    def each_its_own(src):  # each point its own path, so that a point's frames do not depend on its block
        fast, full = one_draw(src), three_draws(src)
        return tuple(jnp.where(per_point(linear) if x.ndim == 2 else per_point(linear)[None], a, x)
                     for a, x in zip(fast, full, strict=True))

    # With the hard ADC the draw hands on the frames' codes, not their differential: the readout (the
    # ADC's transfer with its INL and DNL, every phase image) is then evaluated once, inside the branch,
    # where every consumer of the branch's differential (phase, amplitude, the ADC's flags, each sum)
    # evaluated it again; the ADC's flags are read from the codes (docs/model.md, "Performance",
    # measurement 28). The smooth ADC's blurred codes do not show its rails: it hands on the differential.
    coded = chain.readout.codes_show_saturation
    handed_on = chain.codes if coded else (lambda d: d)

    def writing(draw):
        def branch(src):
            out = draw(src)
            return (handed_on(out[0]), *out[1:])
        return branch

    tap_a = tap_b = None
    if chain.noise.enabled:
        drawn = lax.cond(jnp.all(linear), writing(one_draw), writing(each_its_own), source)
        node, pixel_sat, sbi_on = drawn[:3]
        if taps:
            tap_a, tap_b = drawn[3:]
    else:
        c = source.constants(chain)
        held_a, held_b = limit(col(c.n_a), col(c.n_b))
        n_points = c.index.shape[0]
        full_shape = (n_phases, n_frames, n_points) if frames_first else (n_phases, n_points, n_frames)
        node = handed_on(jnp.broadcast_to(held_a - held_b, full_shape))
        if taps:
            tap_a, tap_b = jnp.broadcast_to(held_a, full_shape), jnp.broadcast_to(held_b, full_shape)
        saturated, engaged = limit.flags(col(c.n_a), col(c.n_b))
        shape = full_shape[1:]
        pixel_sat = jnp.broadcast_to(jnp.any(saturated, axis=0), shape)
        sbi_on = jnp.broadcast_to(jnp.any(engaged, axis=0), shape)
    # The stages after the noise: codes, phase, amplitude.
    frames = chain.samples_of_codes(node) if coded else chain.samples(node)
    # Valid: neither the pixel nor the ADC saturated, and the pixel receives light (a pixel that sees
    # none reads a phase of noise alone, which no camera delivers as a distance).
    valid = ~pixel_sat & ~frames.adc_saturated & per_point(source.constants(chain).lit)
    return FrameBatch(frames.codes, frames.phase, frames.amplitude, pixel_sat, frames.adc_saturated, sbi_on,
                      tap_a, tap_b, valid)


def draw_delivered(chain: Chain, source: PointConstants | PointCharges, key: tuple[Array, Array], first_frame: Array,
                   n_frames: int, stream=0, linear: Array | None = None, frames_first: bool = False,
                   taps: bool = False, image: tuple[int, int] | None = None) -> FrameBatch:
    """The frames the camera delivers: :func:`draw_frames` (the sensor's), then the camera's
    processing stages (:mod:`tofjax._processing`; without them, the drawn frames as they are).
    ``image``: the points are a frame's pixels, ``(rows, cols)`` (whole frames); ``None``: a sweep's
    points, each drawn as the centre of its uniform patch where a stage reads neighbours.

    Delivered frame ``f`` is made of raw frames ``f g .. f g + g - 1`` (``g``: raw frames per
    delivered frame). The batch's phase, amplitude and ``valid`` are the delivered frames'; its
    codes and raw taps are the first raw frame's of each delivered frame, its flags whether any of
    its raw frames saturated or engaged SBI, all at the points (a patch's centre)."""
    stages = chain.processing
    if not stages:
        return draw_frames(chain, source, key, first_frame, n_frames, stream, linear, frames_first, taps)
    g = frames_in(stages)
    if not whole_frames(stages):  # no stage reads neighbours or holds per-pixel values: each point alone
        grid, patch = (source.index.shape[0], 1, 1), False
    elif image is None:
        p = patch_size(stages)
        grid, patch = (source.index.shape[0], p, p), True
        source = expand_patches(source, p)
        linear = None if linear is None else jnp.repeat(linear, p * p)
    else:
        grid, patch = tuple(image), False
    f = draw_frames(chain, source, key, first_frame * g, n_frames * g, stream, linear, frames_first, taps)
    layout = Layout(frames_first, grid, patch)
    phase, amplitude, valid = process(stages, f.phase, f.amplitude, f.valid, layout)
    per_frame = (0, 1) if frames_first else (1, 0)  # (frames, points) axes of the per-point arrays
    raw = (1, 2) if frames_first else (2, 1)  # of the (phases, ...) arrays

    def at_points(x, axes, reduce):
        return None if x is None else reduce(layout.centre(x, axes[1]), g, axes[0])

    return FrameBatch(at_points(f.codes, raw, first_of_groups), phase, amplitude,
                      *(at_points(x, per_frame, any_of_groups) for x in (f.pixel_saturated, f.adc_saturated,
                                                                          f.sbi_engaged)),
                      at_points(f.tap_a_e, raw, first_of_groups), at_points(f.tap_b_e, raw, first_of_groups), valid)


def _nonzero(x: Array) -> Array:
    """``x`` where it is not 0, else 1: the denominator of a conditional draw whose numerator is then 0."""
    return jnp.where(x != 0.0, x, 1.0)


class Sums(eqx.Module):
    """Per-point sums over frames (deviations from the noise-free frame's phase and amplitude)."""

    valid: Array
    dev: Array
    dev2: Array
    amp: Array
    amp2: Array
    pixel_saturated: Array
    adc_saturated: Array
    sbi_engaged: Array
    codes: Array  # (phases, points), over all frames


def wrap(x: Array) -> Array:
    """Wrap to [-pi, pi) (cheap: one floor)."""
    return x - _TWO_PI * jnp.floor(x / _TWO_PI + 0.5)


def reduce_frames(c: PointConstants, f: FrameBatch, counted: Array, frames_first: bool = False) -> tuple[Sums, Array]:
    """Sums of one chunk (``counted``: frames that belong to the run, broadcast against the batch's
    ``(points, frames)``, or with ``frames_first`` its ``(frames, points)``) and each frame's validity."""
    axis, ref = (-2, lambda x: x[None, :]) if frames_first else (-1, lambda x: x[:, None])
    valid = f.valid
    use = valid & counted
    dev = jnp.where(use, wrap(f.phase - ref(c.ref_phase)), 0.0)
    amp = jnp.where(use, f.amplitude - ref(c.ref_amp), 0.0)
    total = functools.partial(_sum_frames, axis=axis)
    count = lambda x: total((x & counted).astype(float))  # noqa: E731 - counts, not a logical or
    sums = Sums(valid=count(valid), dev=total(dev), dev2=total(dev * dev), amp=total(amp), amp2=total(amp * amp),
                pixel_saturated=count(f.pixel_saturated), adc_saturated=count(f.adc_saturated),
                sbi_engaged=count(f.sbi_engaged), codes=total(jnp.where(counted, f.codes, 0.0)))
    return sums, valid


#: Frames per chunk up to which :func:`_sum_frames` adds them one by one.
_UNROLLED_FRAMES = 64


def _sum_frames(x: Array, axis: int) -> Array:
    """``x`` summed over its frames ``axis``. A few frames on a major axis (a camera frame's chunk,
    frames first) are added one by one, an elementwise loop XLA fuses with their producers: its CPU
    reduction of a major axis is far slower (docs/model.md, "Performance", measurement 2)."""
    return jnp.sum(x, axis=axis) if axis == -1 else sum_by_slices(x, axis, _UNROLLED_FRAMES)


def sample_mean_std(n: Array, total: Array, total2: Array) -> tuple[Array, Array, Array]:
    """Mean and ddof-1 standard deviation of ``n`` deviations from their sums ``total`` and sums of
    squares ``total2``, and whether there were at least two (else both are meaningless: the callers
    put NaN there). The one definition of the frames' statistics, for single and fused frequencies."""
    enough = n >= 2
    n_safe = jnp.where(enough, n, 2.0)
    mean = total / n_safe
    return mean, _depth.safe_sqrt(jnp.maximum(total2 - n_safe * mean**2, 0.0) / (n_safe - 1.0)), enough


def frame_statistics(c: PointConstants, sums: Sums, frames: int):
    """(mean phase in [0, 2 pi), phase std, amplitude mean, amplitude std) over the valid frames;
    NaN below two valid frames."""
    mean_dev, sd_dev, enough = sample_mean_std(sums.valid, sums.dev, sums.dev2)
    mean_amp, sd_amp, _ = sample_mean_std(sums.valid, sums.amp, sums.amp2)
    nan = lambda x: jnp.where(enough, x, jnp.nan)  # noqa: E731
    return nan(jnp.mod(c.ref_phase + mean_dev, _TWO_PI)), nan(sd_dev), nan(c.ref_amp + mean_amp), nan(sd_amp)
