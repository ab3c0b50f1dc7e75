"""Test configuration: tofjax turns on float64 on import; NaN checks stay off so that the tests
see what a user sees."""

import os
import tempfile

# One persistent JAX compilation cache for a test run's processes: the pytest-xdist workers and the
# notebooks' kernels (which inherit the environment) compile many of the same programs. Set before
# jax is imported; a user's own setting wins.
os.environ.setdefault("JAX_COMPILATION_CACHE_DIR", os.path.join(tempfile.gettempdir(), f"tofjax-tests-jax-cache-{os.getuid()}"))

import jax  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402

import tofjax  # noqa: F401, E402  (enables x64)

jax.config.update("jax_numpy_rank_promotion", "raise")


def tree_allclose(x, y, *, rtol=1e-7, atol=0.0) -> bool:
    leaves_x, tree_x = jax.tree_util.tree_flatten(x)
    leaves_y, tree_y = jax.tree_util.tree_flatten(y)
    return tree_x == tree_y and all(np.allclose(a, b, rtol=rtol, atol=atol) for a, b in zip(leaves_x, leaves_y, strict=True))


@pytest.fixture(scope="session")
def default_params():
    return tofjax.Params()
