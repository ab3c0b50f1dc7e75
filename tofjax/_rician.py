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

They are tabulated once (:func:`compute_table`, by quadrature for G and the Bessel form for M; shipped
as ``tofjax/data/rician_phase_variance.csv``) and interpolated by cubic Hermite in log-log space
(G within 7e-8 of the quadrature, M within 1e-8 of the Bessel form); beyond the table, v (1 + v + 2.67 v^2) and 1 + v/2 + v^2/8 below
v = 1e-4, pi^2/3 - sqrt(2 pi / v) + 1 / (4 v) and sqrt(pi v / 2) (1 + 1 / (4 v)) above v = 1e8 (all
within 3e-8). A table lookup keeps the per-point cost and the compiled program small.
"""

from __future__ import annotations

import functools
import math
from importlib import resources
from pathlib import Path

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

_LOG_V_MIN, _LOG_V_MAX = math.log(1e-4), math.log(1e8)
_TABLE_POINTS = 481
_UNIFORM = math.pi**2 / 3.0
_TABLE_FILE = "rician_phase_variance.csv"


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


def _mean_ratio(v: np.ndarray) -> np.ndarray:
    """M(v) = E|Z| / A from the Bessel form of the Rician mean."""
    from scipy.special import i0e, i1e

    rho = 0.5 / v
    return np.sqrt(v) * np.sqrt(np.pi / 2) * ((1 + rho) * i0e(rho / 2) + rho * i1e(rho / 2))


def compute_table(log_v: np.ndarray | None = None) -> np.ndarray:
    """Rows (log v, log G, d log G / d log v, log M, d log M / d log v), on the table's grid by
    default (a few seconds; the shipped CSV holds the result). Slopes by central differences."""
    x = np.linspace(_LOG_V_MIN, _LOG_V_MAX, _TABLE_POINTS) if log_v is None else np.asarray(log_v, dtype=float)
    h = 1e-4
    points = np.concatenate([x, x + h, x - h])
    g = np.log(_wrapped_variance(0.5 * np.exp(-points))).reshape(3, -1)
    m = np.log(_mean_ratio(np.exp(points))).reshape(3, -1)
    return np.stack([x, g[0], (g[1] - g[2]) / (2 * h), m[0], (m[1] - m[2]) / (2 * h)], axis=1)


def write_table(path) -> None:
    """Regenerate the shipped table (``python -c "from tofjax._rician import write_table; ..."``)."""
    rows = compute_table()
    header = ("# A phasor in circular complex Gaussian noise against its first-order phase variance v = s^2 / A^2:\n"
              "# G = E[theta^2] of the wrapped phase (Rice's phase density, composite Simpson over [0, pi], 40001 points)\n"
              "# and M = E|Z| / A (Rician mean, Bessel form). Computed by tofjax._rician.compute_table; slopes by\n"
              "# central differences (h = 1e-4 in log v).\n"
              "log_v,log_g,slope_g,log_m,slope_m\n")
    Path(path).write_text(header + "".join(",".join(repr(float(x)) for x in row) + "\n" for row in rows),
                          encoding="utf-8")


@functools.cache
def _table() -> np.ndarray:
    """The shipped table, rows (log v, log G, slope, log M, slope)."""
    text = resources.files("tofjax").joinpath("data", _TABLE_FILE).read_text(encoding="utf-8")
    lines = [line for line in text.splitlines() if line and not line.startswith("#")][1:]
    return np.array([[float(x) for x in line.split(",")] for line in lines])


@eqx.filter_jit
def moments(v: Float[Array, "*b"]) -> tuple[Float[Array, "*b"], Float[Array, "*b"]]:
    """(G(v), M(v)) for first-order phase variances ``v`` (module docstring); ``v = inf`` (no
    signal) gives G = pi^2 / 3."""
    table = jnp.asarray(_table())
    step = (_LOG_V_MAX - _LOG_V_MIN) / (_TABLE_POINTS - 1)
    v = jnp.minimum(v, 1e200)  # no signal: finite values and zero (not NaN) derivatives
    small = v < math.exp(_LOG_V_MIN)
    large = v > math.exp(_LOG_V_MAX)
    t = (jnp.log(jnp.where(small | large, 1.0, v)) - _LOG_V_MIN) / step
    cell = jnp.clip(jnp.floor(t), 0, _TABLE_POINTS - 2)
    u = t - cell
    i = cell.astype(jnp.int32)
    u2, u3 = u * u, u * u * u
    h00, h10, h01, h11 = 2 * u3 - 3 * u2 + 1, (u3 - 2 * u2 + u) * step, 3 * u2 - 2 * u3, (u3 - u2) * step

    def hermite(value: int, slope: int) -> Array:  # one gather per table column: no (..., 5) rows
        y, dy = table[:, value], table[:, slope]
        return jnp.exp(h00 * y[i] + h10 * dy[i] + h01 * y[i + 1] + h11 * dy[i + 1])

    inside = (hermite(1, 2), hermite(3, 4))
    vs = jnp.where(small, v, 0.0)
    vl = jnp.where(large, v, 1.0)
    g = jnp.where(small, vs * (1.0 + vs + 2.668 * vs**2),
                  jnp.where(large, _UNIFORM - jnp.sqrt(2.0 * math.pi / vl) + 0.25 / vl, inside[0]))
    m = jnp.where(small, 1.0 + 0.5 * vs + 0.125 * vs**2,
                  jnp.where(large, jnp.sqrt(0.5 * math.pi * vl) * (1.0 + 0.25 / vl), inside[1]))
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
