"""Saturation and SBI (thesis §3.2.4-3.2.5, §4.2.10-4.2.11, Figs 3.12-3.13, 5.15)."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tofjax._saturation import SBI, Saturation, flags, saturate

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


@settings(max_examples=80, deadline=None)
@given(st.floats(-2e3, 3e5), st.floats(-2e3, 3e5), st.booleans(), st.sampled_from([None, 50.0, 437.0]))
def test_closed_form_slopes_equal_forward_mode_derivatives(a, b, sbi, temperature):
    """The analytic path's slopes of the held differential are the derivatives of the limit itself."""
    t = None if temperature is None else jnp.asarray(temperature)
    stage = SBI(jnp.asarray(WELL), t) if sbi else Saturation(jnp.asarray(WELL), t)
    a, b = jnp.asarray(a), jnp.asarray(b)
    kinks = jnp.array([a - WELL, b - WELL, a - b, a, b, a - b - WELL, b - a - WELL])
    if temperature is None and bool(jnp.any(jnp.abs(kinks) < 1e-6)):
        return  # on a kink of the hard mode the derivative is not defined
    diff = lambda x, y: jnp.subtract(*stage(x, y))  # noqa: E731
    slope_a, slope_b = stage.slopes(a, b)
    assert float(slope_a) == pytest.approx(float(jax.grad(diff, 0)(a, b)), abs=1e-9)
    assert float(slope_b) == pytest.approx(float(jax.grad(diff, 1)(a, b)), abs=1e-9)


@pytest.mark.parametrize("sbi", [False, True])
def test_linear_region_passes_every_charge_within_reach(sbi):
    """Where the limit says it is linear, every charge within reach keeps its differential, the
    pixel stays unsaturated and the SBI flag is the same: checked on a grid of the reach box."""
    stage = SBI(jnp.asarray(WELL)) if sbi else Saturation(jnp.asarray(WELL))
    rng = np.random.default_rng(2)
    n_a, n_b = (jnp.asarray(rng.uniform(-1e3, 1.6e5, 400)) for _ in range(2))
    reach = jnp.asarray(rng.uniform(10.0, 3e3, 400))
    linear, engaged = stage.linear(n_a, n_b, reach, reach)
    assert 0.05 < float(jnp.mean(linear)) < 0.95
    grid = jnp.linspace(-1.0, 1.0, 9)
    a = (n_a[:, None, None] + reach[:, None, None] * grid[None, :, None]) * jnp.ones((1, 1, 9))
    b = (n_b[:, None, None] + reach[:, None, None] * grid[None, None, :]) * jnp.ones((1, 9, 1))
    held_a, held_b = stage(a, b)
    saturated, sbi_on = stage.flags(a, b)
    ok = jnp.all(jnp.abs((held_a - held_b) - (a - b)) < 1e-6, axis=(1, 2)) & ~jnp.any(saturated, axis=(1, 2))
    same_flag = jnp.all(sbi_on == engaged[:, None, None], axis=(1, 2))
    assert bool(jnp.all(ok[linear] & same_flag[linear]))
    assert bool(jnp.all(stage.passes(n_a, n_b, reach, reach)[linear]))


@pytest.mark.parametrize("sbi", [False, True])
def test_headroom_is_positive_exactly_where_the_limit_does_not_saturate(sbi):
    """The limit's headroom: the full well minus the fuller tap (saturation) or minus the taps'
    difference (SBI), > 0 exactly where :meth:`flags` says unsaturated."""
    limit = SBI(jnp.asarray(WELL)) if sbi else Saturation(jnp.asarray(WELL))
    a, b = np.meshgrid(np.linspace(0.0, 3 * WELL, 61), np.linspace(0.0, 3 * WELL, 61))
    headroom = np.asarray(limit.headroom(a, b))
    np.testing.assert_allclose(headroom, WELL - (np.abs(a - b) if sbi else np.maximum(a, b)), rtol=1e-15)
    np.testing.assert_array_equal(headroom > 0, ~np.asarray(limit.flags(a, b)[0]))


def test_result_headroom_is_the_nearest_limit_and_marks_what_the_hard_model_measures():
    """``Result.headroom`` > 0 exactly where the analytic path measures the point, over distances
    that saturate the pixel (with and without SBI) and an ADC whose range the signal overruns; with
    the ADC far away it is 1 - full_well_fraction (no SBI: the fuller tap over the full well)."""
    import tofjax as tj

    d = np.linspace(0.15, 1.5, 28)
    sweep = tj.Sweep("distance", d)
    base = tj.Config()
    for config in (base, base.replace("pixel.sbi", False), base.replace("adc.v_ref_pos_v", 0.35)):
        r = tj.predict(config.params, sweep)
        headroom, valid = np.asarray(r.headroom), np.asarray(r.valid_fraction)
        assert np.any(headroom < 0) and np.any(headroom > 0)
        np.testing.assert_array_equal(headroom > 0, valid > 0)
    far = tj.predict(base.replace("pixel.sbi", False).replace("adc.enabled", False).params, sweep)
    np.testing.assert_allclose(far.headroom, 1.0 - np.asarray(far.full_well_fraction), rtol=1e-12, atol=1e-12)
