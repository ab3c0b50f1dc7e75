"""Reductions over a short axis (the phases, last; a chunk's frames, major), written as
elementwise operations.

XLA's CPU backend runs a reduction over a few trailing elements of many rows as a library kernel
that costs 2-4x the same sum written as adds of the axis' slices, which XLA fuses into one loop with
their producers (docs/model.md, "Performance", measurement 9). Not for an operand whose producer is
expensive to evaluate per slice: the frame's contraction of 9 returns with their correlation rows
stays an ``einsum`` (written as slices, XLA evaluated the table lookups once per slice). Axes longer
than :data:`UNROLLED` keep the library reduction. The results equal ``jnp.sum`` and friends to
rounding (the order of the adds).
"""

from __future__ import annotations

import functools

import jax.numpy as jnp
from jax import lax
from jaxtyping import Array

#: The longest last axis that is reduced by slices.
UNROLLED = 16


def _slices(x: Array, axis: int = -1) -> list[Array]:
    return [lax.index_in_dim(x, i, axis, keepdims=False) for i in range(x.shape[axis])]


def sum_by_slices(x: Array, axis: int, most: int) -> Array:
    """``jnp.sum(x, axis=axis)``, written as adds of the axis' slices when it has at most ``most``
    elements (the library reduction otherwise). Also for a short *major* axis, which XLA's CPU
    reduction runs at about 20 ns per element (:func:`tofjax._frames.reduce_frames`' frames)."""
    if x.shape[axis] > most or x.shape[axis] == 0:
        return jnp.sum(x, axis=axis)
    return functools.reduce(jnp.add, _slices(x, axis))


def sum_last(x: Array) -> Array:
    """``jnp.sum(x, axis=-1)``."""
    return sum_by_slices(x, -1, UNROLLED)


def mean_last(x: Array) -> Array:
    """``jnp.mean(x, axis=-1)``."""
    return sum_last(x) / x.shape[-1]


def max_last(x: Array) -> Array:
    """``jnp.max(x, axis=-1)``."""
    if x.shape[-1] > UNROLLED or x.shape[-1] == 0:
        return jnp.max(x, axis=-1)
    return functools.reduce(jnp.maximum, _slices(x))


def min_last(x: Array) -> Array:
    """``jnp.min(x, axis=-1)``."""
    if x.shape[-1] > UNROLLED or x.shape[-1] == 0:
        return jnp.min(x, axis=-1)
    return functools.reduce(jnp.minimum, _slices(x))
