"""A phasor in circular Gaussian noise beyond the delta method (tofjax/_rician.py): the shipped series
against the quadrature and the Bessel form, the phase variance and mean amplitude against sampling,
the asymptotes."""

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from tofjax import _rician

# Compiled once per shape: eagerly, each of their operations would compile on its own (the file
# took 1.8x as long).
phase_variance = jax.jit(_rician.phase_variance)
mean_abs = jax.jit(_rician.mean_abs)


def test_shipped_series_are_the_fit_within_the_stated_bounds():
    """The shipped coefficients are compute_coefficients' (the fit is reproducible), and the series
    stay within the module's bounds: G within 5e-8 of the quadrature, M within 1e-10 of the Bessel
    form, over v from 1e-6 to 1e10 (both intervals and their meeting point)."""
    fitted = _rician.compute_coefficients()
    for name, coefficients in _rician._coefficients().items():
        np.testing.assert_allclose(coefficients, fitted[name], rtol=1e-12, atol=1e-15)
    v = np.geomspace(1e-6, 1e10, 397)
    g, m = (np.asarray(x) for x in jax.jit(_rician.moments)(jnp.asarray(v)))
    np.testing.assert_allclose(g, _rician.quadrature_g(v), rtol=5e-8)
    np.testing.assert_allclose(m, _rician._mean_ratio(v), rtol=1e-10)


def test_power_basis_by_estrin_is_the_chebyshev_series():
    """Every series as evaluated (power basis, Estrin's scheme) is its shipped Chebyshev series
    (NumPy's chebval, an independent evaluation) within 1e-13 on the whole interval [-1, 1], its ends
    included: catches a wrong basis conversion and a term dropped or paired wrongly (degrees 8 and
    20: odd counts of terms, which Estrin's pairing carries over)."""
    x = np.linspace(-1.0, 1.0, 2001)
    for name, coefficients in _rician._coefficients().items():
        expected = np.polynomial.chebyshev.chebval(x, coefficients)
        got = _rician._polynomial(x, _rician._power_coefficients()[name])
        np.testing.assert_allclose(got, expected, rtol=0, atol=1e-13, err_msg=name)


@pytest.mark.parametrize("v", [0.02, 0.3, 1.0, 6.0])
def test_phase_variance_and_mean_amplitude_match_sampling(v):
    rng = np.random.default_rng(int(100 * v))
    n = 2_000_000
    s = math.sqrt(v)
    z = 1.0 + s * (rng.standard_normal(n) + 1j * rng.standard_normal(n))
    theta2 = np.angle(z) ** 2
    assert float(phase_variance(jnp.asarray(v))) == pytest.approx(np.mean(theta2), abs=4 * np.std(theta2) / math.sqrt(n))
    mean = float(mean_abs(jnp.asarray(1.0), jnp.asarray(s)))
    assert mean == pytest.approx(np.mean(np.abs(z)), abs=4 * np.std(np.abs(z)) / math.sqrt(n))


def test_limits_and_derivatives():
    v = jnp.asarray([1e-9, 1e-5, 1e10, jnp.inf])
    g = np.asarray(phase_variance(v))
    np.testing.assert_allclose(g[:2], np.asarray(v[:2]) * (1 + np.asarray(v[:2])), rtol=1e-9)
    np.testing.assert_allclose(g[2:], math.pi**2 / 3, rtol=1e-4)  # a uniform phase
    # Continuous where the two series meet, increasing, with finite derivatives everywhere.
    edge = _rician.V_SPLIT
    lo, hi = phase_variance(jnp.asarray(edge * (1 - 1e-9))), phase_variance(jnp.asarray(edge * (1 + 1e-9)))
    assert float(hi) == pytest.approx(float(lo), rel=5e-8)
    grid = jnp.asarray(np.geomspace(1e-6, 1e10, 2001))
    assert np.all(np.diff(np.asarray(phase_variance(grid))) > 0)
    slopes = jax.vmap(jax.grad(phase_variance))(grid)
    assert np.all(np.isfinite(slopes)) and np.all(np.asarray(slopes) >= 0)
    a = jnp.asarray([0.0, 1e-3, 1.0, 1e6])
    np.testing.assert_allclose(mean_abs(a, jnp.zeros(4)), a, rtol=1e-15)  # no noise
    assert float(mean_abs(jnp.asarray(0.0), jnp.asarray(2.0))) == pytest.approx(2.0 * math.sqrt(math.pi / 2))
    grads = jax.vmap(jax.grad(mean_abs, argnums=(0, 1)))(a, jnp.full(4, 0.5))
    assert all(np.all(np.isfinite(np.asarray(x))) for x in grads)
