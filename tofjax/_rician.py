"""Phase and amplitude of a phasor in Gaussian noise, beyond the delta method (Rice, 1944).

A phasor of amplitude A with circular complex Gaussian noise of variance s^2 per quadrature has SNR
rho = A^2 / (2 s^2) and a first-order (delta-method) phase variance v = s^2 / A^2 = 1 / (2 rho). Its
phase deviation theta, wrapped to (-pi, pi], has the density (Rice's phase distribution, e.g.
Papoulis, Probability, Random Variables and Stochastic Processes)

    p(theta) = exp(-rho) / (2 pi) + sqrt(rho / pi) cos(theta) exp(-rho sin^2 theta)
                                      (1 + erf(sqrt(rho) cos theta)) / 2,

and its modulus has the Rician mean E|Z| = s sqrt(pi / 2) L_1/2(-rho)
= s sqrt(pi / 2) ((1 + rho) I0e(rho / 2) + rho I1e(rho / 2)) (exponentially scaled Bessel functions).
Both, relative to the delta method, are functions of v alone:

- G(v) = E[theta^2], what the Monte Carlo's circular statistics estimate: v (1 + v) at high SNR (the
  delta method's second order), pi^2 / 3 (a uniform phase) as rho -> 0;
- M(v) = E|Z| / A: 1 + v / 2 (the noise bias of the amplitude) at high SNR, sqrt(pi v / 2) as A -> 0.

They are evaluated without a table lookup, as two Chebyshev series on two intervals of v, both
summed for every point and one selected: a gather per point is what a CPU does worst (the table's
lookups were 40 % of a 224 x 172 noise image; docs/model.md, "Performance"). The variables follow each
function's structure:

- v <= 0.05: G = v (1 + v + v R(v)) and M = 1 + v S(v) with R and S series in v: the high-SNR
  expansions v (1 + v + 8/3 v^2 + ...) and 1 + v/2 + ..., their leading terms exact (a noiseless
  phasor has G = 0 and M = 1 to the last bit). Their corrections, exp(-1/(2v)) and smaller, are
  below the quadrature's accuracy there; beyond, no power series in v can follow them;
- v > 0.05: G = pi^2/3 + w T(w) and M = sqrt(pi v / 2) (1 + w U(w)) with T and U series in
  w = 1 / sqrt(v) on [0, 1 / sqrt(0.05)]. Both are analytic in w, at w = 0 too (a uniform phase,
  G = pi^2/3 - sqrt(2 pi) w + w^2/4 + ...; the Rayleigh mean), so one series reaches v = infinity, and
  no signal gives the uniform phase and the Rayleigh mean to the last bit.

The coefficients are fitted once at Chebyshev nodes (:func:`compute_coefficients`: G by quadrature of
Rice's density, M from the Bessel form) and shipped as ``tofjax/data/rician_chebyshev.csv``. Error
bounds (tests/test_rician.py, log-spaced v over 1e-6..1e10): G within 1e-7 of the quadrature (the
quadrature's own accuracy), M within 1e-10 of the Bessel form. Every series is a polynomial with
Python-number coefficients: its derivatives are exact, its arithmetic stays in the input's precision.

Each series is evaluated in the power basis by Estrin's scheme (its coefficients converted once, on
first use: on [-1, 1] they sum to at most 3.6 in magnitude, so the conversion loses nothing measurable:
within 2e-14 of Clenshaw's recurrence). Clenshaw's recurrence is one chain of 3 dependent operations
per term; Estrin's is about log2(degree) deep, which lets a CPU overlap a pixel's terms: the noise
image of a 224 x 172 exposure 0.66-0.78 -> 0.49-0.54 ms (docs/model.md, "Performance", measurement 22).
"""

from __future__ import annotations

import functools
import math
from importlib import resources
from pathlib import Path

import equinox as eqx
import jax.numpy as jnp
from jax import lax
import numpy as np
from jaxtyping import Array, Float

#: Where the two intervals meet, in v (module docstring), and the second's end in w = 1 / sqrt(v).
V_SPLIT = 0.05
W_END = 1.0 / math.sqrt(V_SPLIT)
_FILE = "rician_chebyshev.csv"
_UNIFORM = math.pi**2 / 3.0
#: Series degree per function and interval (G's first interval is at the quadrature's accuracy with 8).
DEGREES = {"g_low": 8, "g_high": 20, "m_low": 8, "m_high": 20}
_NODES = 300


def _wrapped_variance(rho: np.ndarray) -> np.ndarray:
    """E[theta^2] for Rice's phase density at SNR ``rho`` (composite Simpson over [0, pi])."""
    from scipy.special import erf

    n = 40_001
    theta = np.linspace(0.0, np.pi, n)
    c, s = np.cos(theta), np.sin(theta)
    r = rho[:, None]
    density = np.exp(-r) / (2 * np.pi) + np.sqrt(r / np.pi) * c * np.exp(-r * s * s) * (1 + erf(np.sqrt(r) * c)) / 2
    weights = np.ones(n)
    weights[1:-1:2], weights[2:-1:2] = 4.0, 2.0
    return 2.0 * (density * theta**2) @ weights * (theta[1] - theta[0]) / 3.0


def quadrature_g(v: np.ndarray) -> np.ndarray:
    """G(v) by quadrature of Rice's phase density (the reference; 50 points per batch)."""
    v = np.asarray(v, dtype=float)
    return np.concatenate([_wrapped_variance(0.5 / v[i:i + 50]) for i in range(0, len(v), 50)])


def _mean_ratio(v: np.ndarray) -> np.ndarray:
    """M(v) = E|Z| / A from the Bessel form of the Rician mean."""
    from scipy.special import i0e, i1e

    rho = 0.5 / v
    return np.sqrt(v) * np.sqrt(np.pi / 2) * ((1 + rho) * i0e(rho / 2) + rho * i1e(rho / 2))


def compute_coefficients() -> dict[str, np.ndarray]:
    """The series' Chebyshev coefficients (module docstring), least squares at 300 Chebyshev nodes per
    interval (about a second; the shipped CSV holds the result)."""
    x = np.cos(np.pi * (np.arange(_NODES) + 0.5) / _NODES)
    v_low = np.maximum(0.5 * (x + 1.0) * V_SPLIT, 1e-7)  # G / v -> 1 at v -> 0; the quadrature needs v > 0
    w = np.maximum(0.5 * (x + 1.0) * W_END, 1e-9)
    v_high = 1.0 / w**2
    # The first interval's series hold the expansions' leading terms exactly (G = v (1 + v + v R),
    # M = 1 + v S): a noiseless phasor's G = 0 and M = 1 to the last bit, v (1 + v) at small v.
    # The second's hold their limits at w = 0 exactly too (G = pi^2/3 + w T, M = sqrt(pi v / 2) (1 + w U)):
    # no signal is a uniform phase and the Rayleigh mean to the last bit.
    targets = {"g_low": (quadrature_g(v_low) / v_low - 1.0 - v_low) / v_low,
               "g_high": (quadrature_g(v_high) - _UNIFORM) / w,
               "m_low": (_mean_ratio(v_low) - 1.0) / v_low,
               "m_high": (_mean_ratio(v_high) / np.sqrt(0.5 * np.pi * v_high) - 1.0) / w}
    nodes = {"low": 2.0 * v_low / V_SPLIT - 1.0, "high": 2.0 * w / W_END - 1.0}
    return {name: np.polynomial.chebyshev.chebfit(nodes[name[2:]], y, DEGREES[name]) for name, y in targets.items()}


def write_coefficients(path) -> None:
    """Regenerate the shipped coefficients (``python -c "from tofjax._rician import write_coefficients;
    write_coefficients('tofjax/data/rician_chebyshev.csv')"``)."""
    rows = compute_coefficients()
    header = ("# Chebyshev coefficients (c0, c1, ...) of G = E[theta^2] (Rice's phase density, composite Simpson, 40001\n"
              "# points) and M = E|Z| / A (Bessel form) of a phasor in circular complex Gaussian noise, per interval of the\n"
              "# first-order phase variance v: low (R and S of G = v (1 + v + v R), M = 1 + v S, series in v on [0, 0.05]); high (the\n"
              "# T and U of G = pi^2/3 + w T, M = sqrt(pi v / 2) (1 + w U), series in w = 1 / sqrt(v) on [0, 1 / sqrt(0.05)]).\n"
              "# tofjax._rician.compute_coefficients.\n"
              "name,coefficients\n")
    Path(path).write_text(header + "".join(name + "," + ",".join(repr(float(c)) for c in coeffs) + "\n"
                                           for name, coeffs in rows.items()), encoding="utf-8")


@functools.cache
def _coefficients() -> dict[str, tuple[float, ...]]:
    """The shipped Chebyshev coefficients, as Python numbers."""
    text = resources.files("tofjax").joinpath("data", _FILE).read_text(encoding="utf-8")
    lines = [line for line in text.splitlines() if line and not line.startswith("#")][1:]
    return {line.split(",")[0]: tuple(float(c) for c in line.split(",")[1:]) for line in lines}


@functools.cache
def _power_coefficients() -> dict[str, tuple[float, ...]]:
    """The same series in the power basis, a_0 + a_1 x + ... (constants of the compiled programs)."""
    return {name: tuple(float(a) for a in np.polynomial.chebyshev.cheb2poly(np.asarray(c)))
            for name, c in _coefficients().items()}


def _polynomial(x, coefficients: tuple[float, ...]):
    """sum_k a_k x^k by Estrin's scheme (elementwise; pairs a_k + a_k+1 x, then pairs of those with x^2,
    x^4, ...: log2(degree) dependent steps instead of Horner's degree)."""
    terms, power = list(coefficients), x
    while len(terms) > 1:
        terms = [terms[i] + terms[i + 1] * power if i + 1 < len(terms) else terms[i] for i in range(0, len(terms), 2)]
        power = power * power
    return terms[0]


@eqx.filter_jit
def moments(v: Float[Array, "*b"]) -> tuple[Float[Array, "*b"], Float[Array, "*b"]]:
    """(G(v), M(v)) for first-order phase variances ``v`` (module docstring); ``v = inf`` (no
    signal) gives G = pi^2 / 3."""
    c = _power_coefficients()
    # No signal (v = inf): finite values and zero (not NaN) derivatives, in the input's precision.
    v = jnp.minimum(v, math.sqrt(float(jnp.finfo(jnp.result_type(v)).max)))
    low = v <= V_SPLIT
    v_low = jnp.minimum(v, V_SPLIT)  # each series at a point of its own interval: finite, no stray gradient
    v_high = jnp.maximum(v, V_SPLIT)
    x_low = 2.0 * v_low / V_SPLIT - 1.0
    x_high = (2.0 / W_END) * lax.rsqrt(v_high) - 1.0
    w = 0.5 * W_END * (x_high + 1.0)
    g = jnp.where(low, v_low * (1.0 + v_low * (1.0 + _polynomial(x_low, c["g_low"]))),
                  _UNIFORM + w * _polynomial(x_high, c["g_high"]))
    m = jnp.where(low, 1.0 + v_low * _polynomial(x_low, c["m_low"]),
                  jnp.sqrt(0.5 * math.pi * v_high) * (1.0 + w * _polynomial(x_high, c["m_high"])))
    return g, m


def phase_variance(v: Float[Array, "*b"]) -> Float[Array, "*b"]:
    """G(v) = E[theta^2] of the wrapped phase deviation for a first-order phase variance ``v``:
    v (1 + v) for small v, bounded by pi^2 / 3."""
    return moments(v)[0]


def mean_abs(amplitude: Float[Array, "*b"], sigma: Float[Array, "*b"]) -> Float[Array, "*b"]:
    """E|Z| of a phasor of ``amplitude`` in circular Gaussian noise of ``sigma`` per quadrature (exact
    at every SNR; ``sigma = 0`` gives the amplitude, ``amplitude = 0`` sigma sqrt(pi / 2))."""
    ok = amplitude > 0.0
    a = jnp.where(ok, amplitude, 1.0)
    _, m = moments(jnp.where(ok, (sigma / a) ** 2, 1.0))
    return jnp.where(ok, amplitude * m, sigma * math.sqrt(0.5 * math.pi))
