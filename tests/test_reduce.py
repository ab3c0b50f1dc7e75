"""Reductions over a short last axis written as slices (tofjax/_reduce.py) equal jax.numpy's."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from tofjax import _reduce


@pytest.mark.parametrize("length", [1, 4, 9, _reduce.UNROLLED + 1])
def test_equal_to_jax_numpy_under_jit_and_grad(length):
    x = jnp.asarray(np.random.default_rng(length).normal(size=(3, 5, length)))
    for ours, theirs in ((_reduce.sum_last, jnp.sum), (_reduce.mean_last, jnp.mean), (_reduce.max_last, jnp.max)):
        np.testing.assert_allclose(jax.jit(ours)(x), theirs(x, axis=-1), rtol=1e-14, atol=1e-15)
        # Gradients compiled (eagerly, the slices' transposes would compile a program each).
        np.testing.assert_allclose(jax.jit(jax.grad(lambda v, f=ours: jnp.sum(f(v) ** 2)))(x),
                                   jax.grad(lambda v, f=theirs: jnp.sum(f(v, axis=-1) ** 2))(x), rtol=1e-13, atol=1e-15)
