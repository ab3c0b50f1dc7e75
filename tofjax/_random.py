"""Counter-based Gaussian variates for the Monte Carlo (docs/model.md, "Random-number economy").

The Monte Carlo draws its normals from Philox4x32-10 (Salmon, Moraes, Dror, Shaw, "Parallel random
numbers: as easy as 1, 2, 3", SC11, 2011; the generator of cuRAND and Random123, which passes
TestU01's BigCrush), written in 32-bit integer JAX operations. Every draw is a pure function of

- the key: two 32-bit words taken once from the caller's ``jax.random`` key, and
- the counter: (frame, sample, stream, block), the indices of the draw (one block per normal, its
  first word: :func:`normals`),

so a frame's noise does not depend on how the sweep is chunked in memory, and the same key gives the
same frames on every machine. On this project's 2-core CPU a normal costs 4-7 ns, against 11-14 ns
for ``jax.random.bits`` (threefry) and 12-16 ns per NumPy PCG64 normal.

A 32-bit word becomes one float32 standard normal by the inverse-CDF method: the top bit is the sign,
the other 31 bits a uniform u in (0, 1) (centred in its bin), and z = sqrt(2) erfc^-1(u) with
M. Giles' single-precision erfinv ("Approximating the erfinv function", GPU Computing Gems, 2011),
fed with w = -log(u (2 - u)) so the tail keeps u's full relative precision. Against the exact
quantile the variates are within 3e-7 relative for abs(z) < 5 (float32 resolution) and 4e-4 beyond
(a tail that holds 6e-7 of the probability); abs(z) never exceeds :data:`MAX_ABS_NORMAL`, the
2^-33 quantile, where a Gaussian's two tails hold 2.3e-10 of the probability.
"""

from __future__ import annotations

import math

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float, PRNGKeyArray, UInt32

_M0, _M1 = np.uint32(0xD2511F53), np.uint32(0xCD9E8D57)  # Philox4x32 multipliers
_W0, _W1 = np.uint32(0x9E3779B9), np.uint32(0xBB67AE85)  # Weyl key increments (golden ratio, sqrt 3 - 1)
_ROUNDS = 10

#: The largest abs(z) the generator returns (u = 2^-32: the centre of the first 31-bit bin).
MAX_ABS_NORMAL = 6.34

Words = tuple[UInt32[Array, "*s"], UInt32[Array, "*s"], UInt32[Array, "*s"], UInt32[Array, "*s"]]


def _mulhilo(a: Array, m: np.uint32) -> tuple[Array, Array]:
    product = a.astype(jnp.uint64) * np.uint64(m)
    return (product >> np.uint64(32)).astype(jnp.uint32), product.astype(jnp.uint32)


def philox4x32(counter: Words, key: tuple[Array, Array]) -> Words:
    """Philox4x32-10: four 32-bit counter words and a two-word key to four random words.

    Elementwise over the (broadcast) shapes of the counter words; matches Random123's known-answer
    vectors (tests/test_random.py).
    """
    c0, c1, c2, c3 = (jnp.asarray(c, dtype=jnp.uint32) for c in counter)
    k0, k1 = (jnp.asarray(k, dtype=jnp.uint32) for k in key)
    shape = jnp.broadcast_shapes(c0.shape, c1.shape, c2.shape, c3.shape)
    c0, c1, c2, c3 = (jnp.broadcast_to(c, shape) for c in (c0, c1, c2, c3))
    for _ in range(_ROUNDS):
        hi0, lo0 = _mulhilo(c0, _M0)
        hi1, lo1 = _mulhilo(c2, _M1)
        c0, c1, c2, c3 = hi1 ^ c1 ^ k0, lo1, hi0 ^ c3 ^ k1, lo0
        k0, k1 = k0 + _W0, k1 + _W1
    return c0, c1, c2, c3


def key_words(key: PRNGKeyArray) -> tuple[UInt32[Array, ""], UInt32[Array, ""]]:
    """The two Philox key words of a ``jax.random`` key (any implementation; one draw per call)."""
    words = jax.random.bits(key, (2,), dtype=jnp.uint32)
    return words[0], words[1]


# Giles' single-precision erfinv: two polynomial branches in w = -log((1 - x)(1 + x)).
_CENTRAL = (2.81022636e-08, 3.43273939e-07, -3.5233877e-06, -4.39150654e-06, 0.00021858087, -0.00125372503,
            -0.00417768164, 0.246640727, 1.50140941)
_TAIL = (-0.000200214257, 0.000100950558, 0.00134934322, -0.00367342844, 0.00573950773, -0.0076224613,
         0.00943887047, 1.00167406, 2.83297682)


def _horner(coefficients, x: Array) -> Array:
    p = jnp.full_like(x, coefficients[0])
    for c in coefficients[1:]:
        p = p * x + np.float32(c)
    return p


@eqx.filter_jit
def normal_from_bits(bits: UInt32[Array, "*s"]) -> Float[Array, "*s"]:
    """Standard normal float32 variates, one per 32-bit word (module docstring)."""
    magnitude = (bits & np.uint32(0x7FFFFFFF)).astype(jnp.float32)
    u = (magnitude + np.float32(0.5)) * np.float32(2.0**-31)  # (0, 1), one-sided tail probability x 2
    w = -jnp.log(u * (np.float32(2.0) - u))  # -log((1 - x)(1 + x)) with x = 1 - u
    central = _horner(_CENTRAL, w - np.float32(2.5))
    tail = _horner(_TAIL, jnp.sqrt(jnp.maximum(w, np.float32(5.0))) - np.float32(3.0))
    z = np.float32(math.sqrt(2.0)) * jnp.where(w < np.float32(5.0), central, tail) * (np.float32(1.0) - u)
    return jnp.where((bits >> np.uint32(31)) == np.uint32(1), -z, z)


def normals(key: tuple[Array, Array], frame: UInt32[Array, "*s"], sample: UInt32[Array, "*s"], stream,
            count: int) -> Float[Array, "count *s"]:
    """``count`` independent float32 standard normals per element of the broadcast (frame, sample)
    index arrays, from counter blocks (frame, sample, stream, block): a leading axis of ``count``.
    ``stream`` (an integer, or a traced one) separates independent uses of the same indices.
    Normal ``i`` is the first word of block ``i``.

    One block per normal, not four normals per block: XLA's CPU fusion evaluates each output word
    of a block with its own ten rounds anyway, and gathering the four words into one array costs
    more on top (docs/model.md, "Performance", measurement 8)."""
    frame, sample = jnp.asarray(frame, dtype=jnp.uint32), jnp.asarray(sample, dtype=jnp.uint32)
    shape = jnp.broadcast_shapes(frame.shape, sample.shape)
    block = jnp.arange(count, dtype=jnp.uint32).reshape((count,) + (1,) * len(shape))
    lead = lambda x: jnp.broadcast_to(x, shape)[None]  # noqa: E731 - one Philox for every block at once
    words = philox4x32((lead(frame), lead(sample), jnp.asarray(stream, dtype=jnp.uint32), block), key)
    return normal_from_bits(words[0])
