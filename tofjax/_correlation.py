"""The reference/illumination correlation, tabulated once per call (thesis §3.2.2, Eq 3.24, Table 4.17).

Tap A collects the fraction a_j of the modulated light, phase step theta_j, at reflected phase phi:

    a_j(phi) = sum_{k=-K..K} R_k conj(S_k) exp(i k (phi - theta_j)) / S_0,    K = N_HARMONICS,

with R_k, S_k the Fourier coefficients of reference and emitted waveform (:mod:`tofjax._waveforms`).
The series is the model's correlation; evaluating it per sample costs K complex exponentials per
phase. For a call with many operating points, one inverse real FFT per phase step instead puts a_j
and its derivative on a grid of :data:`N_TABLE` points per period, once per call (for 2 and 4 phases,
whose steps are whole grid rows, the first step's table rolled: a_j(phi) = a_0(phi - theta_j)), and every sample is
a cubic Hermite interpolation between two grid rows: O(phases) per sample, C^1 in the distance (the
interpolant's derivative is exact at the grid points), and differentiable in the duty cycles through
the coefficients. The table stores each cell's cubic in the power basis of the position u in [0, 1)
inside the cell, c0 + u (c1 + u (c2 + u c3)) (the Hermite cubic through the cell's two grid values
and slopes, rewritten once per call): a sample reads one row and evaluates three multiply-adds per
phase step, instead of two rows and the four Hermite basis polynomials (docs/model.md,
"Performance", measurement 12). A call with at most :data:`SERIES_POINTS`
operating points sums the series directly (cheaper than building the table, and exact):
:meth:`Correlation.__call__` picks by the static number of points.

Error bound (docs/model.md, "Correlation"). Cubic Hermite interpolation with exact end slopes errs by
at most h^4 / 384 max|a'''' | with h = 1 / N_TABLE period, and the series bounds the fourth derivative
by 2 sum_k abs(P_k) (2 pi k)^4, P_k = R_k conj(S_k) / S_0. :attr:`Correlation.error_bound` is that
number for the waveforms at hand, as a fraction of the modulated electrons: 4e-9 for the 50 %
rectangular pair, 1e-13 for the default gauss-extended pair, 3e-8 for a 5 % pulse in a 50 % gate
(corners and narrow pulses are the hard cases). The tests compare the table with the direct series.
"""

from __future__ import annotations

import functools

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jax import lax
from jaxtyping import Array, Complex, Float

from ._params import AbstractWaveform
from ._waveforms import N_HARMONICS, fourier_coefficients, phase_steps

#: Table points per period (a power of two for the FFT; 16 per harmonic of the series).
N_TABLE = 16384
#: Up to this many operating points a call sums the series instead of tabulating: the costs cross
#: near 8 points (the default camera's exposure on this project's 2-core machine: 4 points 0.9 ms
#: summed, 1.1 ms tabulated; 16 points 1.6 / 1.1 ms; 64 points 4.2 / 1.2 ms). A design study that
#: vmaps over parameters with a few points each stays cheap.
SERIES_POINTS = 8
#: Returns per pixel up to which :meth:`Correlation.weighted_sum` adds them one lookup at a time.
UNROLLED_RETURNS = 64


class Correlation(eqx.Module):
    """The tap-A fraction of every phase step as a function of the reflected phase.

    **Fields:**
    - ``coefficients``: P_k, k = 0..K (the series).
    - ``n_phases``: the phase steps (static).
    - ``table``: ``(N_TABLE, phases, 4)``: on cell k, between the grid points k / N_TABLE and
      (k + 1) / N_TABLE of a period, the coefficients c0..c3 of a_j = c0 + c1 u + c2 u^2 + c3 u^3,
      u in [0, 1) the position inside the cell (c0 is a_j at the grid point, c1 its slope per grid
      step); ``None`` where the call evaluates the series directly.
    - ``error_bound``: the interpolation's worst-case error bound (module docstring), as a
      fraction of the modulated electrons (0 for the series).
    """

    coefficients: Complex[Array, " harmonics"]
    n_phases: int = eqx.field(static=True)
    table: Float[Array, "points phases 2"] | None
    error_bound: Float[Array, ""]

    @eqx.filter_jit  # one program per shape when called eagerly (inlined under an outer jit)
    def __call__(self, delay_periods: Float[Array, "*b"]) -> Float[Array, "*b phases"]:
        """a_j at reflected phase 2 pi ``delay_periods`` (any shape)."""
        if self.table is None:
            return _series(self.coefficients, self.n_phases, delay_periods)
        return _lookup(self.table, delay_periods)

    def weighted_sum(self, weights: Float[Array, "*b k"], path: Float[Array, "*b k"], periods_per_path: Float[Array, ""],
                     offset_periods: Float[Array, "*b"] | float = 0.0, mask=None) -> Float[Array, "*b phases"]:
        """sum_r weights_r a_j(delay_r) over the last axis, delay_r = path_r x ``periods_per_path`` +
        ``offset_periods`` (several returns of one pixel add as phasors); ``mask`` (NumPy, ``(k,
        phases)``): each return counted only in the phase images where it is 1 (a moving scene's,
        :meth:`tofjax.Returns.phase_mask`).

        Up to :data:`UNROLLED_RETURNS` returns, every return's table cell and position inside it are
        found first (one pass over the returns), then the sum is written return by return, one row
        lookup each: XLA fuses the lookups and the adds into one loop that writes only the sum.
        Gathering every return's row and contracting them (``einsum``) wrote a ``(*b, k, phases)``
        temporary and ran a batched product of tiny matrices; finding the cells inside the loop made
        XLA find them again for every phase step (docs/model.md, "Performance", measurement 13).
        """
        k = path.shape[-1]
        delay = path * periods_per_path + jnp.asarray(offset_periods)[..., None]
        if self.table is None or k > UNROLLED_RETURNS:
            if mask is not None:
                return jnp.einsum("...k,kp,...kp->...p", weights, jnp.asarray(mask), self(delay))
            return jnp.einsum("...k,...kp->...p", weights, self(delay))
        cell, u = _cells(self.table.shape[0], delay)
        terms = [weights[..., r, None] * _cubic(self.table, cell[..., r], u[..., r]) for r in range(k)]
        if mask is not None:  # each return only in its phase images (a row of 0/1, explicitly broadcast)
            terms = [t * jnp.asarray(mask[r]).reshape((1,) * (t.ndim - 1) + (-1,)) for r, t in enumerate(terms)]
        return functools.reduce(jnp.add, terms)


def _cells(n: int, delay_periods: Float[Array, "*b"]) -> tuple[Array, Float[Array, "*b"]]:
    """The table cell (int32) of each delay, of ``n`` per period, and the position in [0, 1) inside it."""
    x = delay_periods - jnp.floor(delay_periods)
    t = x * n
    # The cell index carries no gradient; the position inside the cell does.
    cell = lax.stop_gradient(jnp.clip(jnp.floor(t), 0, n - 1))
    return cell.astype(jnp.int32), t - cell


def _cubic(table: Float[Array, "points phases 4"], cell: Array, u: Float[Array, "*b"]) -> Float[Array, "*b phases"]:
    """The cell's cubic at position ``u`` inside it, c0 + u (c1 + u (c2 + u c3)), every phase step."""
    c = table[cell]
    u = u[..., None]
    return c[..., 0] + u * (c[..., 1] + u * (c[..., 2] + u * c[..., 3]))


def _lookup(table: Float[Array, "points phases 4"], delay_periods: Float[Array, "*b"]) -> Float[Array, "*b phases"]:
    """The tabulated a_j at ``delay_periods``."""
    return _cubic(table, *_cells(table.shape[0], delay_periods))


def correlation_coefficients(illumination: AbstractWaveform, reference: AbstractWaveform,
                             n_harmonics: int = N_HARMONICS):
    """P_k = R_k conj(S_k) / S_0, k = 0..n_harmonics: the correlation's Fourier coefficients per
    unit of modulated light."""
    s = fourier_coefficients(illumination, n_harmonics)
    r = fourier_coefficients(reference, n_harmonics)
    return r * jnp.conj(s) / jnp.real(s[0]).astype(s.dtype)


@eqx.filter_jit
def correlation(illumination: AbstractWaveform, reference: AbstractWaveform, n_phases: int, *,
                n_harmonics: int = N_HARMONICS, points: int = N_TABLE, tabulate: bool = True) -> Correlation:
    """The correlation of the waveforms for the phase steps of an ``n_phases`` measurement:
    tabulated (``tabulate``), or evaluated as the series."""
    if points < 2 * n_harmonics + 2:
        raise ValueError(f"points = {points} cannot hold {n_harmonics} harmonics: allowed >= {2 * n_harmonics + 2}")
    return _from_coefficients(correlation_coefficients(illumination, reference, n_harmonics), n_phases, points,
                              tabulate)


@eqx.filter_jit
def drift_correlation(illumination: AbstractWaveform, reference: AbstractWaveform, n_phases: int, *,
                      n_harmonics: int = N_HARMONICS, points: int = N_TABLE, tabulate: bool = True) -> Correlation:
    """The periodic part G_j of the antiderivative of a_j in the delay (periods): a_j's series with
    P_k / (i 2 pi k) for k >= 1 and no constant term, so that the average of a_j over delays
    [x, y] is P_0 + (G_j(y) - G_j(x)) / (y - x) (:mod:`tofjax._interference`: light whose delay
    drifts during an integration)."""
    p = correlation_coefficients(illumination, reference, n_harmonics)
    k = jnp.arange(1, n_harmonics + 1, dtype=float).astype(p.dtype)
    q = jnp.concatenate([jnp.zeros(1, p.dtype), p[1:] / (2j * jnp.pi * k)])
    return _from_coefficients(q, n_phases, points, tabulate)


def _from_coefficients(p, n_phases: int, points: int, tabulate: bool) -> Correlation:
    """The :class:`Correlation` of series coefficients ``p`` (k = 0..K)."""
    n_harmonics = p.shape[0] - 1
    if not tabulate:
        return Correlation(p, n_phases, None, jnp.asarray(0.0))
    k = jnp.arange(n_harmonics + 1, dtype=float)
    theta = phase_steps(n_phases)
    shifts = theta / (2.0 * np.pi) * points  # each phase step in grid steps
    if np.all(shifts == np.round(shifts)):
        # 2 and 4 phases on a power-of-two grid: a_j(phi) = a_0(phi - theta_j) is the table of the
        # first step rolled by whole rows (exact), one pair of transforms instead of one per step.
        table = jnp.stack([jnp.roll(_spectral_table(p, k, np.zeros(1), points)[:, 0], int(s), axis=0)
                           for s in shifts], axis=1)
    else:
        table = _spectral_table(p, k, theta, points)
    table = _power_basis(table)
    fourth = 2.0 * jnp.sum(jnp.abs(p[1:]) * (2.0 * jnp.pi * k[1:]) ** 4)
    return Correlation(p, n_phases, table, fourth / (384.0 * points**4))


def _spectral_table(p: Complex[Array, " harmonics"], k: Array, theta: np.ndarray, points: int) -> Float[Array, "points phases 2"]:
    """a_j and its slope per grid step at the ``points`` grid points of a period, for phase steps
    ``theta``: one inverse real FFT each of the series' coefficients (module docstring)."""
    spectra = p[None, :] * jnp.exp(-1j * (k[None, :] * jnp.asarray(theta)[:, None]).astype(p.dtype))  # delay phi - theta_j
    values = points * jnp.fft.irfft(spectra, n=points, axis=-1)
    slopes = jnp.fft.irfft(2j * jnp.pi * k.astype(p.dtype)[None, :] * spectra, n=points, axis=-1)  # d a / d(grid step)
    return jnp.stack([values, slopes], axis=-1).transpose(1, 0, 2)


def _power_basis(table: Float[Array, "points phases 2"]) -> Float[Array, "points phases 4"]:
    """Each cell's Hermite cubic through the values p and slopes m (per grid step) at its two ends,
    as c0 + c1 u + c2 u^2 + c3 u^3 (the cell after the last wraps to the first grid point)."""
    p0, m0 = table[..., 0], table[..., 1]
    p1, m1 = jnp.roll(p0, -1, axis=0), jnp.roll(m0, -1, axis=0)
    return jnp.stack([p0, m0, 3.0 * (p1 - p0) - 2.0 * m0 - m1, 2.0 * (p0 - p1) + m0 + m1], axis=-1)


def _series(p: Complex[Array, " harmonics"], n_phases: int, delay_periods: Float[Array, "*b"]) -> Float[Array, "*b phases"]:
    k = jnp.arange(1, p.shape[0], dtype=float)
    theta = jnp.asarray(phase_steps(n_phases))
    delay_periods = jnp.asarray(delay_periods, dtype=float)
    delay = 2.0 * jnp.pi * delay_periods[..., None] - theta.reshape((1,) * delay_periods.ndim + (-1,))
    k = k.reshape((1,) * delay.ndim + (-1,))
    terms = jnp.real(p[1:].reshape(k.shape) * jnp.exp(1j * (k * delay[..., None]).astype(p.dtype)))
    return jnp.real(p[0]) + 2.0 * jnp.sum(terms, axis=-1)


def series(illumination: AbstractWaveform, reference: AbstractWaveform, n_phases: int,
           delay_periods: Float[Array, "*b"], n_harmonics: int = N_HARMONICS) -> Float[Array, "*b phases"]:
    """The correlation summed term by term: O(K) per sample."""
    return _series(correlation_coefficients(illumination, reference, n_harmonics), n_phases, delay_periods)
