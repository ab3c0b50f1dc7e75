"""The chain as one ordered tuple of stages (tofjax/_stages.py, tofjax/_chain.py), folded as moments by
predict and as samples by simulate, and the worked example of adding a stage: the readout's gain
compression (tofjax/_nonlinearity.py, docs/model.md "Adding a stage")."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from equinox import tree_at
from helpers import fd_check

import tofjax as tj
from tofjax._chain import build_chain
from tofjax._charges import TapCharges
from tofjax._noise import Noise
from tofjax._nonlinearity import ReadoutNonlinearity
from tofjax._stages import Moments, fold_moments

NEAR = tj.Sweep("distance", [0.4, 0.5, 0.7])  # differentials of about 0.5, 0.3 and 0.15 full well


def _camera(k: float) -> tj.Params:
    return tj.Params(pixel=tj.Pixel(readout_nonlinearity=k))


def test_the_chain_is_one_ordered_tuple_of_stages():
    chain = build_chain(tj.Params())
    assert [type(s).__name__ for s in chain.stages] == [
        "Noise", "SBI", "Noise", "ReadoutNonlinearity", "Readout", "Demodulation"]
    assert [[src.name for src in s.sources] for s in chain.stages if isinstance(s, Noise)] == [
        ["reset", "photon_shot", "dark_shot"], ["hold", "readout"]]
    # The breakdown's budget keeps its order (the sweep file's noise columns).
    assert [s.name for s in chain.noise.sources] == ["reset", "hold", "photon_shot", "dark_shot", "readout"]


def test_a_noise_source_acts_where_it_stands_in_the_tuple():
    # Without SBI, tap A beyond the full well holds it (slope 0): the sources before the limit reach
    # the differential through tap B alone, those after it through both taps. Moving the
    # after-limit stage in front of the limit moves its variance behind the slopes, in closed form.
    chain = build_chain(tj.Params(pixel=tj.Pixel(sbi=False, readout_noise_e=50.0)))
    well = float(chain.limit.full_well_e)
    a = jnp.array([[1.5 * well, 0.2 * well]])
    zero = jnp.zeros((1,))
    q = TapCharges(a, jnp.array([[0.3 * well, 0.4 * well]]), zero, zero, zero, zero)
    before, limit, after = chain.stages[:3]
    var_b_before = np.asarray(before.variance_e2(q)[1])
    post_a, post_b = (np.asarray(jnp.broadcast_to(v, a.shape)) for v in after.variance_e2(q))
    as_built = chain.drawn_moments(q)
    moved = chain.stages[2:3] + chain.stages[:2]  # after-limit sources in front of the limit
    m = fold_moments(moved, Moments.of(q))
    # Phase 0: tap A saturated (slope 0); phase 1: both taps linear.
    np.testing.assert_allclose(np.asarray(as_built.var_diff)[0, 0], var_b_before[0, 0] + post_a[0, 0] + post_b[0, 0],
                               rtol=1e-12)
    np.testing.assert_allclose(np.asarray(m.var_diff)[0, 0], var_b_before[0, 0] + post_b[0, 0], rtol=1e-12)
    np.testing.assert_allclose(np.asarray(m.var_diff)[0, 1], np.asarray(as_built.var_diff)[0, 1], rtol=1e-12)


@pytest.mark.parametrize("mu_fw, sd_fw", [(0.0, 0.05), (0.4, 0.02), (-0.7, 0.1), (0.9, 0.001)])
def test_gain_compression_moments_are_those_of_the_cubic_of_a_gaussian(mu_fw, sd_fw):
    # Against Gauss-Hermite quadrature of y = x - c x^3 (exact for a polynomial of degree <= 2n - 1):
    # the variance exactly, the mean to first order in the noise, f(mu), 3 c mu s^2 from the exact one.
    well, k = 8e4, 0.2
    stage = ReadoutNonlinearity(jnp.asarray(k), jnp.asarray(well))
    mu, sd = mu_fw * well, sd_fw * well
    zero = jnp.zeros((1, 1))
    m = Moments(TapCharges(zero, zero, zero[0], zero[0], zero[0], zero[0]), zero, zero, zero, zero,
                diff=jnp.full((1, 1), mu), var_diff=jnp.full((1, 1), sd**2))
    out = stage.moments(m)
    z, w = np.polynomial.hermite_e.hermegauss(20)
    w = w / w.sum()
    x = mu + sd * z
    y = x - k / well**2 * x**3
    mean, c = np.sum(w * y), k / well**2
    np.testing.assert_allclose(float(out.diff[0, 0]), mu - c * mu**3, rtol=1e-14, atol=1e-12 * well)
    np.testing.assert_allclose(float(out.diff[0, 0]) - mean, 3 * c * mu * sd**2, rtol=1e-6, atol=1e-9 * well)
    np.testing.assert_allclose(float(out.var_diff[0, 0]), np.sum(w * (y - mean) ** 2), rtol=1e-10)


def test_predict_folds_the_compression_between_the_noise_and_the_adc():
    # The expected code is the readout's at f(mu) = mu - c mu^3, mu the held differential's mean of
    # the same camera without compression.
    k = 0.2
    plain, compressed = tj.predict(_camera(0.0), NEAR), tj.predict(_camera(k), NEAR)
    chain = build_chain(_camera(0.0))
    m = chain.moments(chain.expose(*NEAR.operating_points(chain.params)))
    c = k / float(chain.limit.full_well_e) ** 2
    mu = np.asarray(m.diff)
    expected = chain.readout.linearize(jnp.asarray(mu - c * mu**3))[0]
    np.testing.assert_allclose(np.asarray(compressed.code_mean), np.asarray(expected), rtol=1e-12)
    # Compression costs amplitude: about k (x / N_sat)^2 at the largest differential, 5 % at 0.4 m.
    loss = 1 - np.asarray(compressed.amplitude_mean_lsb) / np.asarray(plain.amplitude_mean_lsb)
    assert 0.02 < loss[0] < 0.06 and loss[0] > loss[1] > loss[2] > 0, loss


def test_simulate_folds_the_compression_into_every_frame():
    k = 0.2
    p = _camera(k)
    chain = build_chain(p)
    mc = tj.simulate(p, NEAR, jax.random.key(5), 3000, keep_frames=4, raw=True)
    # Each kept frame's codes digitise the compressed difference of its taps as read.
    x = np.asarray(mc.frames_tap_a_e) - np.asarray(mc.frames_tap_b_e)
    c = k / float(chain.limit.full_well_e) ** 2
    codes = chain.readout.quantize(chain.readout.position(jnp.asarray(x - c * x**3)))
    np.testing.assert_array_equal(np.asarray(mc.codes), np.asarray(codes))
    # The frames' statistics agree with the analytic fold (3000 frames: amplitude std error < 0.1 %).
    an = tj.predict(p, NEAR)
    np.testing.assert_allclose(np.asarray(mc.amplitude_mean_lsb), np.asarray(an.amplitude_mean_lsb), rtol=3e-3)
    np.testing.assert_allclose(np.asarray(mc.depth_std_m), np.asarray(an.depth_std_m), rtol=0.1)


def test_gain_compression_is_differentiable_and_bounded():
    def amplitude(k):
        p = tj.Params(pixel=tj.Pixel(readout_nonlinearity=k))
        return tj.predict(p, NEAR).amplitude_mean_lsb[0]

    fd_check(amplitude, 0.1)
    with pytest.raises(ValueError, match=r"pixel.readout_nonlinearity = 0.3 is out of range: allowed 0 <= value <= 0.25"):
        tj.Pixel(readout_nonlinearity=0.3)


def test_the_monte_carlo_says_which_stage_it_cannot_draw():
    chain = build_chain(tj.Params())
    compression = chain.stages[3]
    odd = chain.stages[:1] + (compression,) + chain.stages[1:3] + chain.stages[4:]
    odd_chain = tree_at(lambda c: c.stages, chain, odd)
    q = chain.expose(*NEAR.operating_points(chain.params))
    with pytest.raises(NotImplementedError, match="the Monte Carlo draws noise, limit, noise"):
        odd_chain.drawn_moments(q)
