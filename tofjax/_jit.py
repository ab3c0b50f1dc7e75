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
import weakref
from collections.abc import Callable

import equinox as eqx
import jax


def jit(fn: Callable) -> Callable:
    """``fn`` compiled once per argument structure and static values (module docstring); under an
    outer transformation it is traced into the caller's program like ``jax.jit``."""
    signature = inspect.signature(fn)
    cache: dict = {}

    def body(specs, n_args, names, *arrays):
        arrays_it = iter(arrays)
        values = [_unflatten(spec, arrays_it) for spec in specs]
        return fn(*values[:n_args], **dict(zip(names, values[n_args:], strict=True)))

    body.__name__, body.__qualname__ = fn.__name__, fn.__qualname__  # profiles and logs name the program

    @functools.wraps(fn)
    def call(*args, **kwargs):
        bound = signature.bind(*args, **kwargs)
        bound.apply_defaults()
        names = tuple(bound.kwargs)
        flat = [_flatten(x) for x in (*bound.args, *bound.kwargs.values())]
        key = (tuple(f[0] for f in flat), len(bound.args), names)
        compiled = cache.get(key)
        if compiled is None:
            compiled = cache[key] = jax.jit(functools.partial(body, *key))
        return compiled(*(a for f in flat for a in f[1]))

    return call


#: Flattened modules by identity: ``id -> (weak reference, spec, arrays)`` (:func:`_flatten`).
_FLAT: dict[int, tuple] = {}


def _flatten(x) -> tuple[tuple, tuple]:
    """``(spec, arrays)`` of one argument: ``spec`` (the tree structure, which leaves are arrays and
    the other leaves' values: the compiled program's cache key, equinox.filter_jit's split) and the
    array leaves. An ``equinox.Module`` is flattened once and looked up by identity afterwards (a
    module and its arrays are immutable): a prepared camera or frame has 80-90 leaves, and their
    flattening and split took 75-100 us of every call on this project's CPU and 0.4 ms on an H200's
    host (docs/model.md, "Performance", measurement 20). Modules holding tracers (inside a caller's
    transformation) are not kept."""
    hit = _FLAT.get(id(x)) if isinstance(x, eqx.Module) else None
    if hit is not None and hit[0]() is x:
        return hit[1], hit[2]
    leaves, treedef = jax.tree_util.tree_flatten(x)
    mask = tuple(eqx.is_array(leaf) for leaf in leaves)
    spec = (treedef, mask, tuple(leaf for leaf, m in zip(leaves, mask, strict=True) if not m))
    arrays = tuple(leaf for leaf, m in zip(leaves, mask, strict=True) if m)
    if isinstance(x, eqx.Module) and not traced(arrays):
        _FLAT[id(x)] = (weakref.ref(x), spec, arrays)
        weakref.finalize(x, _FLAT.pop, id(x), None)
    return spec, arrays


def _unflatten(spec: tuple, arrays_it):
    treedef, mask, statics = spec
    statics_it = iter(statics)
    return jax.tree_util.tree_unflatten(treedef, [next(arrays_it) if m else next(statics_it) for m in mask])


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
