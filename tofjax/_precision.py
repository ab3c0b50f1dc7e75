"""The precision a camera's frames run in (:meth:`tofjax.Camera.astype`; docs/model.md, "float32
frames"): the choices, and the cast of a pytree's floating-point arrays to one of them."""

from __future__ import annotations

import equinox as eqx
import jax
import jax.numpy as jnp

#: The precisions a camera's frames run in (:meth:`Camera.astype`).
PRECISIONS = ("float64", "float32")


def in_precision(tree, precision: str):
    """``tree`` with its float64 (complex128) arrays cast to ``precision`` (complex64 for complex):
    what a float32 camera's programs take (:meth:`Camera.astype`)."""
    real = jnp.dtype(precision)
    complex_ = jnp.dtype({"float32": "complex64", "float64": "complex128"}[precision])

    def cast(x):
        if not eqx.is_array(x) or x.dtype == real or x.dtype == complex_:
            return x
        if jnp.issubdtype(x.dtype, jnp.complexfloating):
            return x.astype(complex_)
        return x.astype(real) if jnp.issubdtype(x.dtype, jnp.floating) else x

    return jax.tree_util.tree_map(cast, tree)
