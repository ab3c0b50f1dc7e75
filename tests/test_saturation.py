"""Saturation and SBI (thesis §3.2.4-3.2.5, §4.2.10-4.2.11, Figs 3.12-3.13, 5.15)."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tofjax._saturation import flags, saturate

WELL = 78_000.0


def test_without_sbi_each_tap_stops_at_the_full_well():
    a, b = saturate(jnp.array([1e4, 9e4, 2e5]), jnp.array([5e3, 7e4, 1e5]), WELL, sbi=False)
    np.testing.assert_array_equal(a, [1e4, WELL, WELL])
    np.testing.assert_array_equal(b, [5e3, 7e4, WELL])
    sat, sbi_on = flags(jnp.array([1e4, 9e4]), jnp.array([5e3, 7e4]), WELL, sbi=False)
    np.testing.assert_array_equal(sat, [False, True])
    assert not np.any(sbi_on)


def test_sbi_keeps_the_difference_and_pins_the_high_tap():
    n_a = jnp.array([1e4, 9e4, 3e5])
    n_b = jnp.array([5e3, 7e4, 2.5e5])
    a, b = saturate(n_a, n_b, WELL, sbi=True)
    np.testing.assert_allclose(a - b, n_a - n_b)  # the differential keeps integrating
    np.testing.assert_allclose(a[1:], WELL)  # the first tap to reach the threshold stays there
    np.testing.assert_allclose(b[1:], WELL - (n_a - n_b)[1:])  # the other rises towards V_reset
    sat, sbi_on = flags(n_a, n_b, WELL, sbi=True)
    np.testing.assert_array_equal(sbi_on, [False, True, True])
    assert not np.any(sat)


def test_sbi_saturates_only_when_the_difference_reaches_the_well():
    a, b = saturate(jnp.array([2e5]), jnp.array([1e5]), WELL, sbi=True)
    assert float(a[0]) == pytest.approx(WELL) and float(b[0]) == 0.0  # low tap at V_reset
    sat, _ = flags(jnp.array([2e5]), jnp.array([1e5]), WELL, sbi=True)
    assert bool(sat[0])


@pytest.mark.parametrize("sbi", [False, True])
def test_smooth_mode_tends_to_the_hard_mode(sbi):
    n_a = jnp.linspace(0, 3e5, 301)
    n_b = 0.6 * n_a + 1e3
    hard = jnp.stack(saturate(n_a, n_b, WELL, sbi))
    errors = [float(jnp.max(jnp.abs(jnp.stack(saturate(n_a, n_b, WELL, sbi, jnp.asarray(t))) - hard)))
              for t in (1000.0, 100.0, 10.0)]
    assert errors[0] > errors[1] > errors[2]
    assert errors[2] < 10.0  # within 3/16 x temperature (the switch's value at the kink)


@pytest.mark.parametrize("sbi", [False, True])
def test_smooth_mode_is_exact_away_from_the_limits(sbi):
    """Small tap charges (far from the well and from V_reset) pass unchanged: no softplus tail."""
    n_a = jnp.array([450.0, 1000.0, 5000.0, 60000.0])
    n_b = jnp.array([900.0, 800.0, 5200.0, 40000.0])
    smooth = saturate(n_a, n_b, WELL, sbi, jnp.asarray(437.0))
    np.testing.assert_array_equal(smooth[0], n_a)
    np.testing.assert_array_equal(smooth[1], n_b)


@settings(max_examples=60, deadline=None)
@given(st.floats(0, 4e5), st.floats(0, 4e5), st.booleans())
def test_smooth_gradients_are_finite_everywhere(a, b, sbi):
    def f(x, y):
        out_a, out_b = saturate(x, y, WELL, sbi, jnp.asarray(300.0))
        return out_a - 2.0 * out_b

    g = jax.grad(f, argnums=(0, 1))(jnp.asarray(a), jnp.asarray(b))
    assert all(np.isfinite(float(x)) for x in g)
