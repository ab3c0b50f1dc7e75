"""tj.predict and tj.simulate called directly: sweeps of similar length share one compiled program
(tofjax._sweep.padded_samples; the Monte Carlo while the padding is cheap): the padded points change
nothing of the sweep's own, and a second length in the same bucket compiles nothing; a camera's chain
is built once (tofjax._chain.kept_chain)."""

import collections

import equinox as eqx
import jax
import numpy as np
import pytest

import tofjax as tj
from tofjax import _sweep
from tofjax._sweep import pad_sweep, padded_samples

from helpers import traces

# 0.4-3.4 m: past the 1.87 m unambiguity range of 80 MHz, so the unwrapping along the sweep runs.
DISTANCES = np.linspace(0.4, 3.4, 16)


@pytest.mark.parametrize(("n", "padded"), [(1, 16), (16, 16), (17, 32), (100, 128), (1000, 1024), (4096, 4096),
                                           (4097, 4097), (100_001, 100_001)])
def test_padded_lengths(n, padded):
    assert padded_samples(n) == padded


def test_padding_bounds():
    for n in range(1, 10_000, 7):
        m = padded_samples(n)
        assert n <= m <= max(16, 2 * n) and (m % 16 == 0 if n <= 4096 else m == n)




def test_predict_padding_changes_nothing_and_shares_the_program():
    params = tj.Params()
    whole = tj.predict(params, tj.Sweep("distance", DISTANCES))  # 16 points: no padding
    traced, part = traces(lambda: tj.predict(params, tj.Sweep("distance", DISTANCES[:13])))
    assert traced == [], f"a 13-point sweep should run the 16-point programs, compiling nothing: {traced}"
    assert np.all(np.isfinite(np.asarray(whole.depth_unwrapped_mean_m)))
    assert float(whole.depth_unwrapped_mean_m[-1]) > float(whole.unambiguity_range_m)  # unwrapped
    for (path, a), b in zip(jax.tree_util.tree_leaves_with_path(part), jax.tree_util.tree_leaves(whole), strict=True):
        expected = b[:13] if np.ndim(b) else b
        assert np.shape(a) == np.shape(expected), jax.tree_util.keystr(path)
        np.testing.assert_array_equal(a, expected, err_msg=jax.tree_util.keystr(path))


def test_no_padding_under_a_transformation(monkeypatch):
    """Inside a caller's jit/vmap the sweep runs as it is (the caller's program is compiled for its
    shapes once anyway; padding would only add points: a vmapped design grid of 2-point sweeps would
    run 16 points each)."""
    params = tj.Params()
    sweep = tj.Sweep("distance", [0.3, 3.0])
    padded = []
    monkeypatch.setattr(_sweep, "pad_sweep", lambda s: padded.append(s.samples) or pad_sweep(s))

    def noise(power):
        return tj.predict(eqx.tree_at(lambda p: p.illumination.peak_power_w, params, power), sweep).depth_std_m

    out = jax.jit(jax.vmap(noise))(np.asarray([1.0, 2.0]))
    assert padded == []
    np.testing.assert_allclose(out[0], noise(1.0), rtol=1e-12)
    assert padded == [2]  # called directly: padded


def test_monte_carlo_padding_changes_nothing_and_shares_the_program(monkeypatch):
    """simulate called directly pads a sweep as predict does while the padding draws at most
    PADDING_PHASE_IMAGES phase images: a point's frames are its own (the same key, the same frames
    of points 0-12 in a 13-point sweep run as 16 and in the 16-point sweep) and the 13-point sweep
    runs the 16-point programs; a run whose padding would draw more keeps its length. (4 frames, 4
    kept: the programs of the next test's simulate. Several frequencies: test_multifrequency.py.)"""
    from tofjax import _executor

    asked, decide = [], _executor.padded
    monkeypatch.setattr(_executor, "padded", lambda sweep, args, per_point=0: asked.append(per_point)
                        or decide(sweep, args, per_point))
    params, key = tj.Params(), jax.random.key(5)
    whole = tj.simulate(params, tj.Sweep("distance", DISTANCES), key, 4, keep_frames=4)
    traced, part = traces(lambda: tj.simulate(params, tj.Sweep("distance", DISTANCES[:13]), key, 4, keep_frames=4))
    assert traced == [], f"a 13-point sweep should run the 16-point programs, compiling nothing: {traced}"
    for (path, a), b in zip(jax.tree_util.tree_leaves_with_path(part), jax.tree_util.tree_leaves(whole), strict=True):
        expected = b[:13] if np.ndim(b) else b
        assert np.shape(a) == np.shape(expected), jax.tree_util.keystr(path)
        np.testing.assert_array_equal(a, expected, err_msg=jax.tree_util.keystr(path))
    n_phases = params.pixel.n_phases
    assert asked == [4 * n_phases] * 2  # the phase images a point draws
    sweep = tj.Sweep.linspace("distance", 0.5, 1.5, 17)  # padded to 32: 15 points more
    frames = _executor.PADDING_PHASE_IMAGES // (15 * n_phases)
    assert decide(sweep, (params,), frames * n_phases).samples == 32
    assert decide(sweep, (params,), (frames + 1) * n_phases) is sweep


def test_a_cameras_chain_is_built_once_and_only_for_that_camera(monkeypatch):
    """Called directly, predict and simulate build a camera's chain (its correlation table most of it)
    in a program of its own at the first call and keep it: the next call with the same parameters
    builds nothing; another camera gets a chain of its own, the numbers of the chain built inside a
    caller's jit; and at most KEPT_CHAINS are kept, the least recently used going first."""
    from tofjax import _chain

    built, build = [], _chain._built
    monkeypatch.setattr(_chain, "_built", lambda params, *rest: built.append(params) or build(params, *rest))
    monkeypatch.setattr(_chain, "_KEPT", collections.OrderedDict())
    sweep = tj.Sweep("distance", DISTANCES)
    params = tj.Params()
    first = tj.predict(params, sweep)
    again = tj.predict(params, sweep)
    assert [id(p) for p in built] == [id(params)]
    np.testing.assert_array_equal(again.depth_std_m, first.depth_std_m)
    narrow = eqx.tree_at(lambda p: p.illumination_waveform.duty_cycle, params, 0.3)  # a table of its own
    other = tj.predict(narrow, sweep)
    assert [id(p) for p in built] == [id(params), id(narrow)]
    in_jit = eqx.filter_jit(tj.predict)(narrow, sweep)  # traced: the program builds the chain itself
    np.testing.assert_allclose(other.depth_std_m, in_jit.depth_std_m, rtol=1e-12)
    np.testing.assert_allclose(other.amplitude_mean_lsb, in_jit.amplitude_mean_lsb, rtol=1e-12)
    assert np.max(np.abs(np.asarray(other.amplitude_mean_lsb) / np.asarray(first.amplitude_mean_lsb) - 1)) > 0.01
    key = jax.random.key(3)  # simulate keeps chains too: the kept one's frames are the traced one's
    wide = eqx.tree_at(lambda p: p.reference_waveform.duty_cycle, params, 0.6)
    frames = tj.simulate(wide, sweep, key, 4, keep_frames=4)
    tj.simulate(wide, sweep, key, 4)
    assert [id(p) for p in built] == [id(params), id(narrow), id(wide)]
    np.testing.assert_allclose(frames.codes, eqx.filter_jit(tj.simulate)(wide, sweep, key, 4, keep_frames=4).codes,
                               rtol=1e-12)
    cameras = [eqx.tree_at(lambda p: p.illumination.peak_power_w, params, float(w)) for w in range(2, 6)]
    for camera in cameras:
        tj.predict(camera, sweep)
    assert len(_chain._KEPT) == _chain.KEPT_CHAINS
    assert {id(entry[0]) for entry in _chain._KEPT.values()} == {id(c) for c in cameras}
