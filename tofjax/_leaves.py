"""Parameter leaves by their dotted configuration names (``"pixel.demodulation_contrast"``): the
bridge between the configuration's keys and the :class:`tofjax.Params` pytree, shared by the
calibration, the explorer and gradient studies."""

from __future__ import annotations

import functools
from collections.abc import Mapping

import equinox as eqx
import jax.numpy as jnp
from jaxtyping import Array

from ._params import SECTION_CLASSES, Params
from ._schema import KEY_BY_DOTTED, suggest


@functools.cache
def float_leaf_names() -> tuple[str, ...]:
    """Every float configuration key that is a traced leaf of :class:`tofjax.Params`, in schema order."""
    out = []
    for name, key in KEY_BY_DOTTED.items():
        cls = SECTION_CLASSES.get(key.section)
        if key.kind == "float" and cls is not None and key.name in cls.__dataclass_fields__:
            out.append(name)
    return tuple(out)


def _split(dotted: str) -> tuple[str, str]:
    names = float_leaf_names()
    if dotted not in names:
        key = KEY_BY_DOTTED.get(dotted)
        if key is not None:
            raise KeyError(f"{dotted} is a {key.kind} key, not a float leaf of the parameters")
        raise KeyError(f"unknown parameter {dotted!r}{suggest(dotted, names)}")
    section, _, field = dotted.partition(".")
    return section, field


def get_leaf(params: Params, dotted: str) -> Array:
    """The leaf of ``params`` named by a dotted configuration key, e.g. ``"pixel.demodulation_contrast"``."""
    section, field = _split(dotted)
    return getattr(getattr(params, section), field)


def set_leaves(params: Params, values: Mapping[str, object]) -> Params:
    """A copy of ``params`` with the leaves named by dotted keys replaced (values become float64
    arrays, so a jitted function does not retrace; traced values pass through)."""
    where = [_split(name) for name in values]
    return eqx.tree_at(lambda p: tuple(getattr(getattr(p, s), f) for s, f in where), params,
                       tuple(jnp.asarray(v, dtype=float) for v in values.values()))
