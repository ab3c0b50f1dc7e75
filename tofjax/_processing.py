"""The camera's own depth processing: stages after the demodulation (docs/model.md, "The camera's
processing").

A product does not deliver its pixels' raw phase: it corrects the systematic error its factory
calibration measured (:class:`tofjax.processing.Calibration`), filters the depth in space and time
(:class:`tofjax.processing.SpatialFilter`, :class:`tofjax.processing.TemporalAverage`) and
invalidates what its own data say it cannot trust (:class:`tofjax.processing.Invalidation`). Each is
a stage of the chain (:mod:`tofjax._stages`), placed after :class:`~tofjax._depth.Demodulation` in
the one ordered tuple: :func:`tofjax.predict` folds its moments (phase, phase variance, amplitude,
the probability the point is delivered), :func:`tofjax.simulate` its samples (each frame's phase,
amplitude and validity). A camera without processing stages is the sensor alone, bit for bit.

Where the neighbours are. In a frame, a pixel's neighbours are the frame's other pixels: the
samples' last two axes are the image. A sweep's operating point is one pixel, the centre of a
uniform patch: its moments take each spatial stage's closed form for independent neighbours of the
same statistics, and its Monte Carlo draws the patch (:func:`patch_size` pixels square, each its own
random stream) and keeps the centre, so that both paths describe the same camera.

Frames in time. A stage that combines several raw frames into one delivered frame (a temporal
average) says how many (:attr:`AbstractProcessing.frames_in`); the Monte Carlo then draws that many
raw frames per delivered frame, raw frame ``f * g + j`` for delivered frame ``f`` (the draws are
keyed by frame, so a delivered frame's raw frames are the same whatever the chunking).

Stages see (and keep) phases in (-pi, pi] per frame and [0, 2 pi) in the moments, as the
demodulation hands them on; a spatial or temporal combination works on deviations wrapped around a
centre, so that a neighbourhood straddling the phase's wrap is combined as the distances it stands
for, not as numbers 2 pi apart.
"""

from __future__ import annotations

import math

import equinox as eqx
import jax
import jax.numpy as jnp
from jaxtyping import Array

from ._stages import AbstractStage, Samples, fold_samples


class AbstractProcessing(AbstractStage):
    """A stage of the camera's processing (module docstring). Besides its two rules
    (:meth:`moments`, :meth:`sample`) it may say:

    - :attr:`reach`: how many pixels away its neighbourhood reaches (0: the pixel alone);
    - :attr:`pixelwise`: whether it holds values of its own per pixel of a frame (bound from the
      camera's pattern), so that a frame's samples reach it as whole images;
    - :attr:`frames_in`: raw frames per delivered frame (1: frame by frame);
    - :meth:`bind`: the stage with what it needs of the camera (a calibration's table), called once
      when the chain is built;
    - :meth:`reference`: what it does to a noise-free frame's phase (a calibration shifts it; a
      filter of a uniform neighbourhood leaves it as it is).
    """

    @property
    def reach(self) -> int:
        return 0

    @property
    def frames_in(self) -> int:
        return 1

    @property
    def pixelwise(self) -> bool:
        return False

    def bind(self, params, correlation, sample) -> AbstractProcessing:
        """This stage for a camera of ``params`` with its mixer's ``correlation`` and its pixels'
        ``sample`` (a :class:`tofjax.PixelPattern` or ``None``)."""
        return self

    def reference(self, phase: Array) -> Array:
        """The phase of a noise-free frame after this stage (a uniform neighbourhood's)."""
        return phase


def check_processing(processing) -> None:
    """``TypeError`` unless ``processing`` is a tuple of processing stages."""
    if not isinstance(processing, tuple):
        raise TypeError(f"processing must be a tuple of tofjax.processing stages, got {type(processing).__name__}")
    for stage in processing:
        if not isinstance(stage, AbstractProcessing):
            raise TypeError(f"processing: every stage must be a tofjax.processing stage, got {type(stage).__name__}")


def bind_all(processing, params, correlation, sample) -> tuple[AbstractProcessing, ...]:
    """The camera's processing stages bound to its chain (:meth:`AbstractProcessing.bind`)."""
    check_processing(processing)
    return tuple(stage.bind(params, correlation, sample) for stage in processing)


def patch_size(stages) -> int:
    """The side of the uniform patch a sweep's Monte Carlo draws: every spatial stage's reach added
    on each side (a filter's output at the centre reads a later stage's neighbourhood), so that the
    centre's delivered value is exact; 1 without a spatial stage."""
    return 1 + 2 * sum(stage.reach for stage in stages)


def frames_in(stages) -> int:
    """Raw frames per delivered frame (the product of the stages')."""
    return math.prod(stage.frames_in for stage in stages)


# ---- the samples' layout: (frames, ..., rows, cols) for the stages, the draw's for the rest ----------


class Layout(eqx.Module):
    """How a batch of drawn frames maps onto the processing's ``(frames, *grid)``: ``frames_first``
    (the draw's per-point arrays are ``(frames, points)``, else ``(points, frames)``), ``grid``
    (the points as ``(rows, cols)`` of a frame, or ``(points, p, p)``: each sweep point's patch),
    ``patch`` (whether the grid is patches, whose centres are the points)."""

    frames_first: bool = eqx.field(static=True)
    grid: tuple[int, ...] = eqx.field(static=True)
    patch: bool = eqx.field(static=True)

    def to_grid(self, x: Array) -> Array:
        """A per-point array of the draw, ``(frames, points)`` or ``(points, frames)``, as
        ``(frames, *grid)``."""
        x = x if self.frames_first else jnp.moveaxis(x, -1, 0)
        return x.reshape((x.shape[0],) + self.grid)

    def from_grid(self, x: Array) -> Array:
        """Back to the draw's layout, at the points (a patch's centre)."""
        if self.patch:
            c = self.grid[-1] // 2
            x = x[..., c, c]
        x = x.reshape((x.shape[0], -1))
        return x if self.frames_first else jnp.moveaxis(x, 0, -1)

    def centre(self, x: Array, axis: int) -> Array:
        """A drawn array whose ``axis`` runs over the patches' pixels: the patches' centres."""
        if not self.patch:
            return x
        p2 = self.grid[-1] * self.grid[-2]
        x = jnp.moveaxis(x, axis, -1)
        return jnp.moveaxis(x.reshape(x.shape[:-1] + (-1, p2))[..., p2 // 2], -1, axis)


def process(stages, phase: Array, amplitude: Array, valid: Array, layout: Layout) -> tuple[Array, Array, Array]:
    """The delivered (phase, amplitude, validity) of drawn frames through the processing ``stages``,
    in the draw's layout at its points (``layout``), ``frames_in`` raw frames per delivered frame."""
    s = Samples(None, phase=layout.to_grid(phase), amplitude=layout.to_grid(amplitude), valid=layout.to_grid(valid))
    s = fold_samples(stages, s)
    return layout.from_grid(s.phase), layout.from_grid(s.amplitude), layout.from_grid(s.valid)


def draw_factor(stages, image: bool) -> int:
    """Raw phase images drawn per delivered frame and point, over the sensor's own: the raw frames
    per delivered frame, and a sweep's patch (:func:`patch_size`)."""
    return frames_in(stages) * (1 if image else patch_size(stages) ** 2)


def whole_frames(stages) -> bool:
    """Whether a frame's Monte Carlo must draw whole frames: a stage reads neighbours, or holds
    values per pixel."""
    return any(stage.reach or stage.pixelwise for stage in stages)


def first_of_groups(x: Array, g: int, axis: int) -> Array:
    """Every ``g``-th entry along ``axis`` (the first raw frame of each delivered frame)."""
    if g == 1:
        return x
    return jax.lax.slice_in_dim(x, 0, x.shape[axis], g, axis=axis)


def any_of_groups(x: Array, g: int, axis: int) -> Array:
    """Whether any entry of each group of ``g`` along ``axis`` holds (a delivered frame's raw frames)."""
    if g == 1:
        return x
    axis = axis % x.ndim
    return jnp.any(x.reshape(x.shape[:axis] + (-1, g) + x.shape[axis + 1:]), axis=axis + 1)


def expand_patches(consts, p: int):
    """A sweep's per-point constants (points axis last) repeated for each pixel of its ``p x p``
    patch, each pixel its own random stream (counter word ``index p^2 + j``)."""
    n = p * p
    if n == 1:
        return consts

    def rep(x):
        return None if x is None else jnp.repeat(x, n, axis=-1)

    index = (consts.index[:, None] * jnp.uint32(n) + jnp.arange(n, dtype=jnp.uint32)[None, :]).reshape(-1)
    return eqx.tree_at(lambda c: c.index, jax.tree_util.tree_map(rep, consts), index)


# ---- neighbourhoods: shifted copies of an image with invalid padding --------------------------------


def wrap_phase(x: Array) -> Array:
    """Wrap to (-pi, pi]."""
    return jnp.pi - jnp.mod(jnp.pi - x, 2.0 * jnp.pi)


def neighbours(x: Array, r: int, fill) -> list[Array]:
    """The ``(2r + 1)^2`` shifted copies of ``x`` over its last two axes (row-major offsets from
    (-r, -r) to (r, r); the centre is entry ``len // 2``), ``fill`` beyond the image's border."""
    if r == 0:
        return [x]
    pad = [(0, 0)] * (x.ndim - 2) + [(r, r), (r, r)]
    padded = jnp.pad(x, pad, constant_values=fill)
    rows, cols = x.shape[-2:]
    return [padded[..., r + dy:r + dy + rows, r + dx:r + dx + cols]
            for dy in range(-r, r + 1) for dx in range(-r, r + 1)]


def normal_cdf(x: Array) -> Array:
    return 0.5 * jax.scipy.special.erfc(-x / math.sqrt(2.0))


