"""Helpers shared by the test modules (``from helpers import ...``; tests/ is on sys.path)."""

import jax
import numpy as np


def tree_allclose(x, y, *, rtol=1e-7, atol=0.0) -> bool:
    leaves_x, tree_x = jax.tree_util.tree_flatten(x)
    leaves_y, tree_y = jax.tree_util.tree_flatten(y)
    return tree_x == tree_y and all(np.allclose(a, b, rtol=rtol, atol=atol) for a, b in zip(leaves_x, leaves_y, strict=True))


def fd_check(f, x0, rtol=1e-4):
    """jax.grad(f) against a central finite difference (step 1e-6 relative) at the float x0."""
    g = float(jax.grad(f)(x0))
    h = 1e-6 * abs(x0)
    fd = (float(f(x0 + h)) - float(f(x0 - h))) / (2 * h)
    scale = abs(float(f(x0))) / abs(x0)  # a derivative this small is "zero" at this precision
    assert np.isfinite(g)
    assert abs(g - fd) <= rtol * max(abs(fd), 1e-6 * scale), (g, fd)


def split_between_taps(fraction_a, contrast, active_e, background_e):
    """The tap split of the one exposure (tofjax._charges.Exposure.charges): photo-electrons of taps A
    and B from the correlation fractions a_j (Eqs 3.19-3.21)."""
    import jax.numpy as jnp

    from tofjax._charges import Exposure

    active_e, background_e = jnp.asarray(active_e, dtype=float), jnp.asarray(background_e, dtype=float)
    contrast = jnp.asarray(contrast, dtype=float)
    zero = jnp.zeros(active_e.shape)
    q = Exposure(contrast * active_e[..., None] * fraction_a, active_e, background_e, contrast, jnp.zeros(()),
                 zero, zero).charges()
    return q.photo_a, q.photo_b
