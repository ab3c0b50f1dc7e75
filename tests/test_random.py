"""The Monte Carlo's counter-based normals (tofjax/_random.py): Philox4x32-10 against Random123's
known answers, the inverse-CDF normals against the exact quantile, and their statistics."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from scipy import stats

from tofjax import _random

# Random123's published known-answer vectors for Philox4x32-10 (counter, key, output).
KAT = [
    ((0, 0, 0, 0), (0, 0), (0x6627E8D5, 0xE169C58D, 0xBC57AC4C, 0x9B00DBD8)),
    ((0xFFFFFFFF,) * 4, (0xFFFFFFFF,) * 2, (0x408F276D, 0x41C83B0E, 0xA20BC7C6, 0x6D5451FD)),
    ((0x243F6A88, 0x85A308D3, 0x13198A2E, 0x03707344), (0xA4093822, 0x299F31D0),
     (0xD16CFE09, 0x94FDCCEB, 0x5001E420, 0x24126EA1)),
]


@pytest.mark.parametrize("counter, key, expected", KAT)
def test_philox_matches_random123_known_answers(counter, key, expected):
    out = _random.philox4x32(tuple(np.uint32(c) for c in counter), tuple(np.uint32(k) for k in key))
    assert tuple(int(w) for w in out) == expected


def test_normals_follow_the_exact_quantile():
    """Every 32-bit word maps to the Gaussian quantile of its bin centre: within 3e-7 relative
    for |z| < 5 and 4e-4 in the far tail (the accuracy the module docstring states)."""
    magnitude = np.unique(np.concatenate([np.arange(0, 2**31, 65_537), np.arange(4000), 2**31 - 1 - np.arange(4000)]))
    for sign in (0, 1):
        bits = (magnitude + sign * 2**31).astype(np.uint32)
        z = np.asarray(_random.normal_from_bits(jnp.asarray(bits))).astype(float)
        exact = stats.norm.isf((magnitude + 0.5) * 2.0**-32) * (-1 if sign else 1)
        central = np.abs(exact) < 5
        np.testing.assert_allclose(z[central], exact[central], rtol=3e-7, atol=2e-7)
        np.testing.assert_allclose(z[~central], exact[~central], rtol=4e-4)
        assert np.max(np.abs(z)) <= _random.MAX_ABS_NORMAL


def test_normals_have_gaussian_moments_and_independent_streams():
    n = 1 << 20
    frame = jnp.arange(n // 4, dtype=jnp.uint32)
    key = _random.key_words(jax.random.key(3))
    z = np.asarray(_random.normals(key, frame, jnp.uint32(7), 0, 4)).astype(float)
    flat = z.ravel()
    assert abs(flat.mean()) < 5 / np.sqrt(n)
    assert flat.var() == pytest.approx(1.0, abs=5 * np.sqrt(2 / n))
    assert np.mean(flat**4) == pytest.approx(3.0, abs=5 * np.sqrt(96 / n))
    assert stats.kstest(flat[:200_000], "norm").pvalue > 1e-3
    # Neighbouring blocks (the normals of one counter), neighbouring counters and another stream are
    # uncorrelated.
    other = np.asarray(_random.normals(key, frame, jnp.uint32(7), 1, 4)).astype(float)
    for a, b in ((z[0], z[1]), (z[0, :-1], z[0, 1:]), (z[2], other[2])):
        assert abs(np.corrcoef(a, b)[0, 1]) < 5 / np.sqrt(a.size)


def test_draws_depend_on_the_key_and_the_counter_only():
    key = _random.key_words(jax.random.key(0))
    whole = _random.normals(key, jnp.arange(64, dtype=jnp.uint32)[None, :], jnp.arange(3, dtype=jnp.uint32)[:, None],
                            0, 5)
    part = _random.normals(key, jnp.arange(32, 64, dtype=jnp.uint32)[None, :], jnp.uint32(2), 0, 5)
    np.testing.assert_array_equal(whole[:, 2:3, 32:], part)  # the same frames, however they are grouped
    again = _random.normals(_random.key_words(jax.random.key(1)), jnp.arange(32, 64, dtype=jnp.uint32)[None, :],
                            jnp.uint32(2), 0, 5)
    assert not np.array_equal(np.asarray(part), np.asarray(again))
