"""The chain's stages: one ordered tuple that the analytic path folds as moments and the Monte Carlo
as samples (docs/model.md, "The composed chain").

A stage is a small Module with two rules, for what it does to

- the **moments** of the signal (:class:`Moments`: means and variances per operating point and phase
  image, phase axis last): :func:`tofjax.predict` folds them through every stage;
- a **sample** of it (:class:`Samples`: one value per phase image, point and frame, phase axis first):
  :func:`tofjax.simulate` folds the frames it drew through the stages after the noise sources.

The Monte Carlo draws the stages up to the last noise source together (:mod:`tofjax._frames`: one
normal per tap before the limit and one per phase image after it, or a single normal where the
limit cannot act), so a stage placed after the noise sources is one class and one place in the
tuple; a stage among them (acting on each tap before the limit) also needs its rule in that draw.
"""

from __future__ import annotations

import abc
import dataclasses

import equinox as eqx
import jax.numpy as jnp
from jaxtyping import Array

from ._charges import TapCharges


class Moments(eqx.Module):
    """The signal's moments at one node of the chain, per operating point (``*b``) and phase image
    (last axis); a field is ``None`` until the stage that makes it.

    **Fields:**
    - ``charges``: the exposure's expected charges (the noise sources read them);
    - ``a``, ``b``: each tap's mean, its expected charge, held after the limit, e-;
    - ``var_a``, ``var_b``: each tap's variance before the limit, e-^2 (what the limit sees);
    - ``diff``, ``var_diff``: after the limit, the mean and variance of the differential A - B (the
      readout's input), e- and e-^2; ``post_a``, ``post_b``: the taps' variances added after it;
    - ``code``, ``u``, ``slope_u``, ``var_code``: after the readout, the expected code, the code
      position, its slope d u / d charge, and the code variance (with quantisation), LSB;
    - ``phase``, ``var_phase``, ``v_first``, ``amp``, ``var_amp``: after the demodulation, ``(*b,)``;
      the camera's processing stages (:mod:`tofjax._processing`) act on these;
    - ``delivered``: the probability that the camera's processing delivers the point (its own
      invalidation, :mod:`tofjax._invalidation`), ``(*b,)``; ``None``: 1;
    - ``image`` (static): whether the operating points' last two axes are an image of neighbouring
      pixels (a frame), so that a spatial stage filters across them; ``False``: independent points
      (a sweep), each the centre of a uniform patch, where a spatial stage's closed form applies;
    - ``correlation`` (static): the correlation of the phase noise of a pixel and its (side,
      diagonal) neighbour, which a spatial filter's overlapping windows make (0: independent pixels).
    """

    charges: TapCharges
    a: Array
    b: Array
    var_a: Array
    var_b: Array
    diff: Array | None = None
    var_diff: Array | None = None
    post_a: Array | None = None
    post_b: Array | None = None
    code: Array | None = None
    u: Array | None = None
    slope_u: Array | None = None
    var_code: Array | None = None
    phase: Array | None = None
    var_phase: Array | None = None
    v_first: Array | None = None
    amp: Array | None = None
    var_amp: Array | None = None
    delivered: Array | None = None
    image: bool = eqx.field(static=True, default=False)
    correlation: tuple[float, float] = eqx.field(static=True, default=(0.0, 0.0))

    @classmethod
    def of(cls, charges: TapCharges, image: bool = False) -> Moments:
        """The moments the exposure hands on: the expected charges, no variance yet (``image``: the
        points are a frame's pixels)."""
        zero = jnp.zeros(charges.photo_a.shape, charges.photo_a.dtype)
        return cls(charges, charges.a, charges.b, zero, zero, image=image)

    @property
    def limited(self) -> bool:
        """Whether the limit has acted (the signal is the held differential)."""
        return self.diff is not None


class Samples(eqx.Module):
    """Frames at one node after the noise sources, phase axis first: ``(phases, *points)``, the
    points' axes as the draw lays them out (points and frames, either order); a field is ``None``
    until the stage that makes it.

    **Fields:** ``diff`` (the differential A - B, e-; ``None`` for frames that start at their codes,
    :meth:`tofjax.chain.Chain.samples_of_codes`), ``u`` and ``codes`` (code position and codes),
    ``adc_saturated`` (``(*points)``), ``phase`` (arg Z in (-pi, pi]) and ``amplitude`` (``(*points)``),
    ``valid`` (whether the camera delivers the frame's point: not saturated, and kept by its
    processing). The camera's processing stages (:mod:`tofjax._processing`) see ``phase``,
    ``amplitude`` and ``valid`` as ``(frames, ..., rows, cols)``: frames first and the pixels'
    neighbourhood on the last two axes.
    """

    diff: Array | None
    u: Array | None = None
    codes: Array | None = None
    adc_saturated: Array | None = None
    phase: Array | None = None
    amplitude: Array | None = None
    valid: Array | None = None


def replace(state, **fields):
    """``state`` with ``fields`` replaced (a stage's new node)."""
    return dataclasses.replace(state, **fields)


class AbstractStage(eqx.Module):
    """One stage of the chain (module docstring)."""

    @abc.abstractmethod
    def moments(self, m: Moments) -> Moments:
        """The moments after this stage, from those before it."""

    def sample(self, s: Samples) -> Samples:
        """Frames after this stage, from those before it (stages after the noise sources)."""
        raise NotImplementedError(
            f"{type(self).__name__} acts before the last noise source: the Monte Carlo's draw "
            "(tofjax._frames.draw_frames) needs its rule")


def fold_moments(stages: tuple[AbstractStage, ...], m: Moments) -> Moments:
    """``m`` through ``stages`` in order."""
    for stage in stages:
        m = stage.moments(m)
    return m


def fold_samples(stages: tuple[AbstractStage, ...], s: Samples) -> Samples:
    """``s`` through ``stages`` in order."""
    for stage in stages:
        s = stage.sample(s)
    return s
