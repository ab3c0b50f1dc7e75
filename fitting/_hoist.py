"""A function of (problem, x) called many times with one problem: what depends on the problem alone
computed once.

emcee calls the log-posterior thousands of times with the same :class:`~fitting._problem.Problem`
and new parameters. Most of one call's program does not depend on the parameters: the camera's
waveform and correlation tables, the ADC's code tables, the sweeps' operating points. A compiled
program recomputes them at every call, because the problem is one of its arguments. Partial
evaluation (JAX's own, the rule ``jax.linearize`` is built on) splits the traced function in two: a
*known* program of the problem's leaves alone, run once, whose values (the residuals) the *unknown*
program then takes with ``x`` at every call. The same operations on the same values: the results are
those of the whole program, to the bit where XLA rounds alike (tests/test_fitting.py checks the
posterior). The README's calibration, 16 walkers: 3.5-3.7 -> 1.3-1.4 ms a call at the test suite's
XLA settings; emcee's 32 walkers x 2000 steps of bench/bench_calibration.py 9.5 -> 5.5 s at XLA's
default ones.
"""

from __future__ import annotations

from collections.abc import Callable

import jax
from jax.extend.core import jaxpr_as_fun

# JAX's partial evaluation has no public name; jax is pinned to 0.10 (pyproject.toml), whose
# ``partial_eval_jaxpr_nounits`` this is (tests/test_fitting.py runs it).
from jax._src.interpreters.partial_eval import partial_eval_jaxpr_nounits


def hoisted(fn: Callable, problem, example) -> Callable:
    """``x -> fn(problem, x)`` for every ``x`` of ``example``'s shapes and dtypes, with every value
    that depends on ``problem`` alone computed here, once, by a program of its own."""
    leaves, tree = jax.tree_util.tree_flatten(problem)
    x_leaves, x_tree = jax.tree_util.tree_flatten(example)

    def flat(leaves, x_leaves):
        return fn(jax.tree_util.tree_unflatten(tree, leaves), jax.tree_util.tree_unflatten(x_tree, x_leaves))

    closed, out_shape = jax.make_jaxpr(flat, return_shape=True)(leaves, x_leaves)
    unknowns = [False] * len(leaves) + [True] * len(x_leaves)
    known, unknown, _, _ = partial_eval_jaxpr_nounits(closed, unknowns, instantiate=True)
    residuals = jax.jit(jaxpr_as_fun(known))(*leaves)  # instantiate: every output is the unknown program's
    per_call = jax.jit(jaxpr_as_fun(unknown))
    out_tree = jax.tree_util.tree_structure(out_shape)

    def call(x):
        x_now, now_tree = jax.tree_util.tree_flatten(x)
        if now_tree != x_tree:
            raise ValueError(f"hoisted: x has the structure {now_tree}, the example {x_tree}")
        return jax.tree_util.tree_unflatten(out_tree, per_call(*residuals, *x_now))

    call.once, call.per_call = known, unknown  # the two programs' jaxprs, to inspect
    return call
