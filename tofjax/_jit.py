"""Compiled entry points with a small per-call cost (docs/model.md, "Performance").

:func:`jit` compiles a function the way ``equinox.filter_jit`` does (array leaves of the arguments
traced, every other leaf static and part of the cache key), but keeps its own cache of one
``jax.jit`` per argument structure, so that a call costs one pytree flatten and jax's C++ dispatch,
where ``equinox.filter_jit`` re-partitions the arguments on every call (equinox issue #973;
docs/model.md, "Performance", measurement 11). Used for the programs users call in loops (frames,
``predict``, ``simulate``); the small helpers keep ``equinox.filter_jit``. Public as ``tofjax.jit``,
for other packages' entry points that are called in loops (``fitting``'s least-squares steps and
posterior batches).

Differences from ``equinox.filter_jit``: the outputs must be arrays (pytrees of them, with static
fields as usual); arguments are bound to the signature with its defaults applied, so leaving out a
default or passing it compiles once.
"""

from __future__ import annotations

import functools
import inspect
from collections.abc import Callable

import equinox as eqx
import jax


def jit(fn: Callable) -> Callable:
    """``fn`` compiled once per argument structure and static values (module docstring); under an
    outer transformation it is traced into the caller's program like ``jax.jit``."""
    signature = inspect.signature(fn)
    cache: dict = {}

    def body(treedef, mask, statics, *arrays):
        arrays_it, statics_it = iter(arrays), iter(statics)
        leaves = [next(arrays_it) if m else next(statics_it) for m in mask]
        args, kwargs = jax.tree_util.tree_unflatten(treedef, leaves)
        return fn(*args, **kwargs)

    body.__name__, body.__qualname__ = fn.__name__, fn.__qualname__  # profiles and logs name the program

    @functools.wraps(fn)
    def call(*args, **kwargs):
        bound = signature.bind(*args, **kwargs)
        bound.apply_defaults()
        leaves, treedef = jax.tree_util.tree_flatten((bound.args, bound.kwargs))
        mask = tuple(eqx.is_array(x) for x in leaves)  # equinox.filter_jit's split
        statics = tuple(x for x, m in zip(leaves, mask, strict=True) if not m)
        key = (treedef, mask, statics)
        compiled = cache.get(key)
        if compiled is None:
            compiled = cache[key] = jax.jit(functools.partial(body, treedef, mask, statics))
        return compiled(*(x for x, m in zip(leaves, mask, strict=True) if m))

    return call


def traced(tree) -> bool:
    """Whether any leaf of ``tree`` is a tracer: the call runs under ``jit``, ``vmap`` or ``grad``,
    so its values are not concrete (no host loop over them, no padding on the host)."""
    return any(isinstance(x, jax.core.Tracer) for x in jax.tree_util.tree_leaves(tree))


class method:  # noqa: N801 - used as a decorator, like ``property``
    """A method of an ``equinox.Module`` bound as a ``functools.partial`` of it and the instance.

    Equinox binds every method of a module as a ``BoundMethod``, itself a module, built per access: its
    construction checks every leaf of the instance, 0.1-0.15 ms for a prepared camera or frame, as much
    as a third of a 224 x 172 noise image, and the public calls reached three more through their
    helpers (docs/model.md, "Performance", measurement 19). The price: the bound method is not a
    pytree (``equinox.filter_jit`` of it sees the instance as a constant, as ``jax.jit`` always does).
    """

    def __init__(self, fn: Callable):
        self.__func__ = fn
        functools.update_wrapper(self, fn)

    def __get__(self, instance, owner=None):
        # Not a types.MethodType: equinox's __getattribute__ makes every one of those a BoundMethod.
        return self if instance is None else functools.partial(self.__func__, instance)

    def __call__(self, *args, **kwargs):  # through the class: ``Cls.name(instance, ...)``
        return self.__func__(*args, **kwargs)
