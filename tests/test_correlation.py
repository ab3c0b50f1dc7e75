"""The mixer's correlation, tabulated once per call (tofjax/_correlation.py, thesis §3.2.2): the table
against the 1024-harmonic series for every waveform, its stated error bound, its closed forms and
its derivatives."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from helpers import fd_check, split_between_taps

import tofjax
from tofjax._correlation import N_TABLE, _spectral_table, correlation, correlation_coefficients, series
from tofjax._waveforms import phase_steps

WAVEFORMS = [("pulse", 0.5, "pulse", 0.5), ("pulse", 0.25, "pulse", 0.5), ("sine", 1.0, "sine", 1.0),
             ("sine", 0.4, "pulse", 0.5), ("triangle", 0.3, "gauss_extended", 0.5), ("sawtooth", 0.3, "pulse", 0.5),
             ("gauss_extended", 0.25, "gauss_extended", 0.5), ("fourier", 0.25, "triangle", 0.6),
             ("pulse", 0.05, "pulse", 0.5)]
DELAYS = np.random.default_rng(0).uniform(0.0, 3.0, 1001)  # random, so between the grid points


def _waves(ill, ill_duty, ref, ref_duty):
    return (tofjax.IlluminationWaveform(shape=ill, duty_cycle=ill_duty),
            tofjax.ReferenceWaveform(shape=ref, duty_cycle=ref_duty))


@pytest.mark.parametrize("n", [2, 3, 5])
@pytest.mark.parametrize("waves", WAVEFORMS, ids=lambda w: f"{w[0]}{w[1]}-{w[2]}{w[3]}")
def test_table_matches_the_1024_harmonic_series_within_its_bound(waves, n):
    """The interpolated table against the series term by term, for every waveform; the error bound
    h^4/384 max|a''''| holds, and the tap electrons agree within 1e-6 relative (default contrast,
    no background: the hardest case for a relative error)."""
    ill, ref = _waves(*waves)
    table = correlation(ill, ref, n)
    direct = series(ill, ref, n, DELAYS)
    error = np.max(np.abs(np.asarray(table(DELAYS)) - np.asarray(direct)))
    assert error <= float(table.error_bound) * 1.01 + 1e-14
    assert float(table.error_bound) < 3e-8  # the docstring's worst case: a 5 % pulse
    active = jnp.full(DELAYS.shape, 1e4)
    exact = split_between_taps(direct, 0.42, active, jnp.zeros(DELAYS.shape))
    tabled = split_between_taps(table(DELAYS), 0.42, active, jnp.zeros(DELAYS.shape))
    for e, t in zip(exact, tabled, strict=True):
        np.testing.assert_allclose(t, e, rtol=1e-6)


@pytest.mark.parametrize("n", [2, 4])
def test_rolled_table_equals_one_transform_per_phase_step(n):
    """2 and 4 phase steps are whole grid rows: the table is the first step's, rolled. It equals
    the table made with one transform per step (to the FFTs' rounding, 1e-12 of the swing)."""
    ill, ref = _waves("gauss_extended", 0.25, "pulse", 0.5)
    rolled = np.asarray(correlation(ill, ref, n).table)[..., :2]  # each cell's value and slope at its grid point
    p = correlation_coefficients(ill, ref)
    direct = np.asarray(_spectral_table(p, jnp.arange(p.shape[0], dtype=float), phase_steps(n), N_TABLE))
    np.testing.assert_allclose(rolled, direct, rtol=0, atol=1e-12 * np.max(np.abs(direct)))


def test_rectangular_pair_correlates_to_a_triangle():
    ill, ref = _waves("pulse", 0.5, "pulse", 0.5)
    tau = np.linspace(0, 1, 41, endpoint=False)
    a = np.asarray(correlation(ill, ref, 4)(tau))[:, 0]
    expected = 1 - 2 * np.abs(tau - np.round(tau))  # 1 in phase, 0 in anti-phase
    np.testing.assert_allclose(a, expected, atol=2e-3)  # harmonic truncation at the corners


def test_sine_pair_correlates_to_a_cosine():
    ill, ref = _waves("sine", 1.0, "sine", 1.0)
    t = np.linspace(0, 1, 13)
    a = np.asarray(correlation(ill, ref, 4)(t))
    theta = tofjax.waveforms.phase_steps(4)
    np.testing.assert_allclose(a, 0.5 + 0.25 * np.cos(2 * np.pi * t[:, None] - theta[None, :]), atol=1e-12)


def test_quarter_duty_pulse_inside_half_gate_has_a_flat_top():
    """Fig 5.4: at 25 % duty the pulse fits the 50 % gate for delays up to 1/8 period."""
    ill, ref = _waves("pulse", 0.25, "pulse", 0.5)
    a = np.asarray(correlation(ill, ref, 4)(np.array([0.0, 0.05, 0.1, 0.5])))[:, 0]
    np.testing.assert_allclose(a[:3], 1.0, atol=2e-3)
    assert a[3] == pytest.approx(0.0, abs=2e-3)


def test_derivatives_in_delay_and_duty_match_finite_differences():
    ill, ref = _waves("gauss_extended", 0.25, "gauss_extended", 0.5)
    fd_check(lambda x: correlation(ill, ref, 4)(x)[1], 0.3137, rtol=1e-5)
    fd_check(lambda duty: correlation(tofjax.IlluminationWaveform(shape="pulse", duty_cycle=duty), ref, 3)(0.21)[1],
             0.3, rtol=1e-5)
    # The delay derivative equals the series' own derivative (the interpolant is C^1).
    slope = jax.grad(lambda x: series(ill, ref, 4, x)[0])(0.7)
    assert float(jax.grad(lambda x: correlation(ill, ref, 4)(x)[0])(0.7)) == pytest.approx(float(slope), rel=1e-5)


def test_each_cell_is_the_hermite_cubic_between_its_grid_points():
    """The table's power basis: cell k's cubic ends (u = 1) at the value and slope that cell k + 1
    starts with (C^1, the last cell wrapping to the first), and starts at the grid value and slope
    of the transforms. Fails with a wrong basis change (the table-vs-series test then fails too, but
    only through the interpolation's error)."""
    ill, ref = _waves("pulse", 0.25, "gauss_extended", 0.5)
    c = np.asarray(correlation(ill, ref, 4).table)
    end_value, end_slope = c.sum(axis=-1), c[..., 1] + 2 * c[..., 2] + 3 * c[..., 3]
    swing = np.max(np.abs(c[..., 0]))
    np.testing.assert_allclose(end_value, np.roll(c[..., 0], -1, axis=0), rtol=0, atol=1e-13 * swing)
    np.testing.assert_allclose(end_slope, np.roll(c[..., 1], -1, axis=0), rtol=0, atol=1e-13 * swing)


@pytest.mark.parametrize("tabulate", [True, False])
@pytest.mark.parametrize("k", [9, 65])
def test_weighted_sum_of_returns_is_the_sum_of_their_correlations(k, tabulate):
    """sum_r w_r a_j(path_r s + offset): return by return up to 64 returns (k = 9), contracted
    beyond (k = 65), tabulated or summed as the series; against the lookups one return at a time,
    and its path derivative against that sum's."""
    from tofjax._correlation import UNROLLED_RETURNS

    assert 9 <= UNROLLED_RETURNS < 65
    ill, ref = _waves("gauss_extended", 0.25, "pulse", 0.5)
    corr = correlation(ill, ref, 4, tabulate=tabulate)
    rng = np.random.default_rng(3)
    w, path = rng.uniform(0.0, 2.0, (5, k)), rng.uniform(0.1, 9.0, (5, k))
    s, offset = 0.2678, rng.normal(0.0, 0.05, 5)
    # Every return's own lookup (one call on all of them), weighted and summed over the returns.
    explicit = lambda p: jnp.sum(w[..., None] * corr(p * s + offset[:, None]), axis=1)  # noqa: E731
    np.testing.assert_allclose(corr.weighted_sum(w, path, s, offset), explicit(path), rtol=1e-13, atol=1e-13)
    grad = jax.grad(lambda p: jnp.sum(corr.weighted_sum(w, p, s, offset)[:, 1]))(path)
    np.testing.assert_allclose(grad, jax.grad(lambda p: jnp.sum(explicit(p)[:, 1]))(path), rtol=1e-11, atol=1e-11)
