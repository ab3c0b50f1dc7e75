"""The camera's depth filters in space and time (docs/model.md, "The camera's processing").

:class:`SpatialFilter` combines each pixel's depth with its k x k neighbourhood's (a box mean or a
median, over the neighbours the camera delivers); :class:`TemporalAverage` averages a pixel's depth
over n consecutive raw frames. Both combine deviations wrapped around a centre (the pixel's own
phase; the frames' circular mean), so a neighbourhood across the phase's wrap is combined as
distances. Amplitude passes a spatial filter as it is (a camera's confidence image is its pixels'
own); a temporal average averages it too.

Closed forms (the moments), for independent pixels or frames of variance s^2:
- box mean of n: s^2 / n (exact; in a frame, sum_j s_j^2 / n^2 over the neighbours present);
- median of n: c(n) s^2, with c(n) the variance of the median of n standard normals
  (:func:`median_variance`, exact by quadrature: 0.449 for 3, 0.287 for 5, 0.166 for 9, 0.064 for 25;
  pi / (2 n) for large n, the median's efficiency 2 / pi); for even n the median is the mean of the
  two middle values, as the frames take it;
- mean of n frames: s^2 / n (a static scene).
In a frame the moments filter the expected phase image as the samples do (the mean of the
neighbours' expected phases for the box, their median for the median: a depth edge is blurred
alike), and each pixel's variance takes its neighbours' (box) or their mean times c(n) (median).
"""

from __future__ import annotations

import functools
import itertools
import math

import equinox as eqx
import jax.numpy as jnp
import numpy as np

from ._processing import AbstractProcessing, neighbours, wrap_phase
from ._stages import Moments, Samples, replace

#: The spatial filters' kinds.
SPATIAL_KINDS = ("box", "median")
#: The largest neighbourhood side.
MAX_SIZE = 7
#: The correlation of the medians of two k x k windows of independent normal values offset by one pixel
#: to the side and diagonally (estimated once by Monte Carlo, 4e5 pairs each, standard error 0.001;
#: tests/test_processing.py checks them): a box mean's is the windows' overlap, (k - 1) / k and
#: ((k - 1) / k)^2, a median's about 0.86 times that.
MEDIAN_NEIGHBOUR_CORRELATION = {3: (0.570, 0.366), 5: (0.734, 0.569), 7: (0.811, 0.683)}


@functools.cache
def _median_variances(n_max: int = MAX_SIZE * MAX_SIZE) -> tuple[np.ndarray, np.ndarray]:
    """c(n), n = 0 .. ``n_max`` (:func:`median_variance`), and for even n the correlation of the two
    middle values (0 for odd n), by quadrature of the order statistics' densities on a grid (error
    below 1e-7)."""
    x = np.linspace(-9.0, 9.0, 3601)
    h = x[1] - x[0]
    pdf = np.exp(-0.5 * x * x) / math.sqrt(2.0 * math.pi)
    cdf = 0.5 * np.array([math.erfc(-v / math.sqrt(2.0)) for v in x])
    sf = 1.0 - cdf
    logc, logs = np.log(np.maximum(cdf, 1e-300)), np.log(np.maximum(sf, 1e-300))

    def order_density(n: int, r: int) -> np.ndarray:  # density of the r-th of n (1-based)
        log_k = math.lgamma(n + 1) - math.lgamma(r) - math.lgamma(n - r + 1)
        return np.exp(log_k + (r - 1) * logc + (n - r) * logs) * pdf

    out, rho = np.zeros(n_max + 1), np.zeros(n_max + 1)
    out[1] = 1.0
    for n in range(2, n_max + 1):
        if n % 2:
            out[n] = np.sum(x * x * order_density(n, (n + 1) // 2)) * h
            continue
        k = n // 2
        second = np.sum(x * x * (order_density(n, k) + order_density(n, k + 1))) * h
        log_k = math.lgamma(n + 1) - math.lgamma(k) - math.lgamma(n - k)
        # The joint density of the two middle values, x < y, is separable: exp(log_k) f(x) g(y), so the
        # sum over x < y is a cumulative sum, the diagonal's cells half inside (the trapezoid rule
        # across the density's edge).
        f = x * np.exp((k - 1) * logc) * pdf
        g = x * np.exp((n - k - 1) * logs) * pdf
        below = np.cumsum(f) - f  # sum of f over the grid points left of each
        cross = math.exp(log_k) * (np.sum(g * below) + 0.5 * np.sum(f * g)) * h * h
        out[n] = 0.25 * (second + 2.0 * cross)
        mean_k = np.sum(x * order_density(n, k)) * h  # the upper middle value's mean is -mean_k
        var_k = 0.5 * second - mean_k**2
        rho[n] = (cross + mean_k**2) / var_k
    return out, rho


def median_variance(n):
    """c(n): the variance of the median of ``n`` independent standard normal values (the mean of the
    two middle ones for even ``n``); 0 for ``n = 0`` (an array of counts, or a number)."""
    return jnp.asarray(_median_variances()[0])[jnp.asarray(n, dtype=jnp.int32)]


def _batcher_pairs(n: int) -> list[tuple[int, int]]:
    """The compare-exchange pairs of Batcher's odd-even merge sort of ``n`` (a power of two) values:
    a sorting network, n log^2 n / 4 comparisons."""
    pairs = []
    p = 1
    while p < n:
        k = p
        while k >= 1:
            for j in range(k % p, n - k, 2 * k):
                for i in range(min(k, n - j - k)):
                    if (i + j) // (2 * p) == (i + j + k) // (2 * p):
                        pairs.append((i + j, i + j + k))
            k //= 2
        p *= 2
    return pairs


def masked_median(values: list, ok: list):
    """The median of ``values`` where ``ok`` (the mean of the two middle ones for an even count),
    elementwise over their arrays; arbitrary where none is. A sorting network of element-wise minima
    and maxima (Batcher's, the values padded to a power of two): XLA's sort of a short axis on a CPU
    took 400 times as long for a 3 x 3 median of a frame."""
    big = jnp.asarray(jnp.inf, values[0].dtype)
    v = [jnp.where(o, x, big) for x, o in zip(values, ok, strict=True)]  # the missing ones sort last
    v += [jnp.full_like(v[0], big)] * ((1 << (len(v) - 1).bit_length()) - len(v))
    for i, j in _batcher_pairs(len(v)):
        v[i], v[j] = jnp.minimum(v[i], v[j]), jnp.maximum(v[i], v[j])
    n = sum(o.astype(jnp.int32) for o in ok)
    lo, hi = jnp.maximum(n - 1, 0) // 2, n // 2

    def rank(r):
        return sum(jnp.where(r == k, v[k], 0.0) for k in range(len(values)))

    return 0.5 * (rank(lo) + rank(hi))


#: Gauss-Hermite nodes per value of the median's moments across an edge, and grid points where the
#: values' means lie within their noise (:func:`median_moments`).
MEDIAN_NODES = 12
MEDIAN_GRID = 33


def median_moments(means: list, sds: list, ok: list) -> tuple:
    """The mean and variance of the median of independent normal values N(means_j, sds_j^2), those
    where ``ok`` (the neighbours present), elementwise over their arrays: a frame's median filter of
    pixels whose expected depths differ (across a depth gradient or an edge the median follows one
    neighbour, and its variance is not c(n) s^2).

    The r-th smallest of n values is at most x where at least r are below it, a Poisson-binomial count
    of p_i = Phi((x - m_i) / s_i). Two quadratures of its distribution, each where it is accurate:

    - means spread beyond the noise (an edge, a steep gradient): value j is the r-th where X_j = x
      and exactly r - 1 of the others lie below, so E[g(X_(r))] = sum_j E_{x ~ N(m_j, s_j^2)}[g(x)
      P(N_-j(x) = r - 1)], each by Gauss-Hermite quadrature in its own value (:data:`MEDIAN_NODES`
      nodes, normalised by the weights' total, 1 exactly);
    - means within the noise (the median is then as narrow as c(n) s^2, which those nodes do not
      resolve): E[X] = x_0 + int (1 - F) dx and E[X^2] = x_0^2 + int 2 x (1 - F) dx by the trapezoid rule
      on :data:`MEDIAN_GRID` points across the means' spread plus 5 standard deviations of the median.

    For an odd count the median is the middle value; for an even one (a frame's border, an invalid
    neighbour) the mean of the two middle values: its mean is exact, its variance takes their
    correlation, the identical case's within the noise (:func:`_median_variances`) and half of it
    across an edge (an interpolation: there the two are mostly different neighbours' own values).
    Against 4000 samples of each of 300 random 3 x 3 and 5 x 5 neighbourhoods, means spread by 0-10
    standard deviations: an odd count's variance within 5 % at the median of the neighbourhoods and
    within 5-27 % at their 95th percentile (the samples' own error: 2 % and 4 %); an even count's within
    2 % within the noise, 25 % across an edge."""
    from jax import lax

    from ._processing import normal_cdf

    dtype = means[0].dtype
    n = len(means)
    m = jnp.stack([jnp.where(o, mu, 0.0) for mu, o in zip(means, ok, strict=True)])  # (n, ...)
    s = jnp.stack([jnp.where(o, sd, 1.0) for sd, o in zip(sds, ok, strict=True)])
    present = jnp.stack(ok)
    count = jnp.sum(present, axis=0).astype(jnp.int32)
    safe_count = jnp.maximum(count, 1).astype(dtype)
    lower, upper = (count + 1) // 2, count // 2 + 1  # the middle ranks, 1-based
    needed = n // 2 + 1  # counts 0 .. needed - 1 reach every middle rank
    lead = lambda x: x[None]  # noqa: E731 - against the nodes' leading axis

    def below(x, skip):
        """P(exactly k of the values (value ``skip`` never counted) lie below x), k = 0 .. needed - 1:
        a Poisson-binomial, value by value (one scan step, so the program stays small)."""
        def step(counts, value):  # the counts one array each: no stacked copy per step (a third faster)
            mu, sd, o, i = value
            p = jnp.where(lead(o & (i != skip)), normal_cdf((x - lead(mu)) / lead(sd)), 0.0)
            q = 1.0 - p
            return (counts[0] * q,) + tuple(c * q + fewer * p for c, fewer in zip(counts[1:], counts[:-1], strict=True)), None

        start = (jnp.ones(x.shape, dtype),) + tuple(jnp.zeros(x.shape, dtype) for _ in range(needed - 1))
        return lax.scan(step, start, (m, s, present, jnp.arange(n, dtype=jnp.int32)))[0]

    def at_rank(counts, k):  # P(exactly k), per pixel's k (counts: k = 0 .. needed - 1)
        return sum(jnp.where(k[None] == i, c, 0.0) for i, c in enumerate(counts))

    # Across an edge: each value's own Gauss-Hermite nodes.
    t, w = np.polynomial.hermite.hermgauss(MEDIAN_NODES)
    shape = (-1,) + (1,) * count.ndim
    t = jnp.asarray(math.sqrt(2.0) * t, dtype).reshape(shape)
    w = jnp.asarray(w / math.sqrt(math.pi), dtype).reshape(shape)

    def own(value):  # value j's contribution to (weights, x, x^2) of the lower and upper middle values
        mu, sd, o, j = value
        x = lead(mu) + t * lead(sd)
        counts = below(x, j)
        out = []
        for rank in (lower, upper):
            weight = jnp.where(lead(o), w * at_rank(counts, rank - 1), 0.0)
            out.append(jnp.stack([jnp.sum(weight, 0), jnp.sum(weight * x, 0), jnp.sum(weight * x * x, 0)]))
        return jnp.stack(out)

    sums = jnp.sum(lax.map(own, (m, s, present, jnp.arange(n, dtype=jnp.int32))), axis=0)  # (2, 3, ...)

    def from_sums(r):
        total, first, second = sums[r]
        safe = jnp.where(total > 0, total, 1.0)
        mean = first / safe
        return mean, jnp.maximum(second / safe - mean * mean, 0.0)

    edge = [from_sums(0), from_sums(1)]

    # Within the noise: the CDF on a grid around the means.
    centre = jnp.sum(jnp.where(present, m, 0.0), 0) / safe_count
    noise = jnp.sqrt(jnp.sum(jnp.where(present, s * s, 0.0), 0) / safe_count)
    spread = jnp.max(jnp.where(present, jnp.abs(m - centre[None]), 0.0), 0)
    half = spread + 5.0 * jnp.sqrt(median_variance(count)) * noise
    grid = lead(centre) + jnp.asarray(np.linspace(-1.0, 1.0, MEDIAN_GRID), dtype).reshape(shape) * lead(half)
    counts = below(grid, jnp.int32(-1))
    acc = []
    for rank in (lower, upper):
        cumulative = tuple(itertools.accumulate(counts))  # P(N <= k)
        tail = at_rank(cumulative, rank - 1)  # P(X_(r) > x) = P(N(x) < r)
        h = grid[1:] - grid[:-1]
        first = grid[0] + jnp.sum(h * 0.5 * (tail[1:] + tail[:-1]), 0)
        second = grid[0] ** 2 + jnp.sum(h * (grid[1:] * tail[1:] + grid[:-1] * tail[:-1]), 0)
        acc.append((first, jnp.maximum(second - first * first, 0.0)))
    flat = spread < noise
    (e_lo, var_lo), (e_hi, var_hi) = ((jnp.where(flat, a[0], b[0]), jnp.where(flat, a[1], b[1]))
                                      for a, b in zip(acc, edge, strict=True))
    # The two middle values' correlation: the identical case's within the noise; across an edge they
    # are two neighbours' own values, independent.
    rho = jnp.asarray(_median_variances()[1])[count] * jnp.where(flat, 1.0, 0.5)
    odd = count % 2 == 1
    mean = jnp.where(odd, e_lo, 0.5 * (e_lo + e_hi))
    var = jnp.where(odd, var_lo, 0.25 * (var_lo + var_hi + 2.0 * rho * jnp.sqrt(var_lo * var_hi)))
    return mean, var


class SpatialFilter(AbstractProcessing):
    """A k x k spatial filter of the depth (module docstring): ``kind`` ``"box"`` (the mean) or
    ``"median"``, ``size`` k (odd, 3 .. 7); static. It reads the neighbours the camera delivers
    (not saturated, not invalidated by an earlier stage) and never makes a pixel valid."""

    kind: str = eqx.field(static=True, default="median")
    size: int = eqx.field(static=True, default=3)

    def __check_init__(self):
        if self.kind not in SPATIAL_KINDS:
            raise ValueError(f"SpatialFilter: kind = {self.kind!r} is not allowed: expected one of "
                             + ", ".join(map(repr, SPATIAL_KINDS)))
        if isinstance(self.size, bool) or not isinstance(self.size, int) or self.size % 2 == 0 \
                or not 3 <= self.size <= MAX_SIZE:
            raise ValueError(f"SpatialFilter: size = {self.size!r} is out of range: allowed an odd integer "
                             f"3 <= value <= {MAX_SIZE}")

    @property
    def reach(self) -> int:
        return self.size // 2

    @property
    def neighbour_correlation(self) -> tuple[float, float]:
        """The correlation this filter makes between a pixel's filtered phase noise and its side and
        diagonal neighbours' (independent pixels before it)."""
        if self.kind == "median":
            return MEDIAN_NEIGHBOUR_CORRELATION[self.size]
        side = (self.size - 1) / self.size
        return side, side * side

    def _combine(self, centre, values, ok):
        """The filtered phase from the neighbours' ``values`` (phases) where ``ok``, and their count."""
        devs = [wrap_phase(v - centre) for v in values]
        count = sum(o.astype(centre.dtype) for o in ok)
        if self.kind == "box":
            total = sum(jnp.where(o, d, 0.0) for d, o in zip(devs, ok, strict=True))
            shift = total / jnp.maximum(count, 1.0)
        else:
            shift = jnp.where(count > 0, masked_median(devs, ok), 0.0)
        return centre + shift, count

    def sample(self, s: Samples) -> Samples:
        r = self.reach
        phase, _ = self._combine(s.phase, neighbours(s.phase, r, 0.0), neighbours(s.valid, r, False))
        return replace(s, phase=wrap_phase(phase))

    def moments(self, m: Moments) -> Moments:
        n = self.size * self.size
        if not m.image:  # a uniform patch of independent pixels
            factor = 1.0 / n if self.kind == "box" else median_variance(n)
            return replace(m, var_phase=factor * m.var_phase, v_first=factor * m.v_first,
                           correlation=self.neighbour_correlation)
        r = self.reach
        ok = neighbours(jnp.isfinite(m.var_phase), r, False)
        variances = [jnp.where(o, v, 0.0) for v, o in zip(neighbours(m.var_phase, r, 0.0), ok, strict=True)]
        if self.kind == "box":
            phase, count = self._combine(m.phase, neighbours(m.phase, r, 0.0), ok)
            c = jnp.maximum(count, 1.0)
            var = sum(variances) / (c * c)
        else:
            devs = [wrap_phase(v - m.phase) for v in neighbours(m.phase, r, 0.0)]
            shift, var = median_moments(devs, [jnp.sqrt(v) for v in variances], ok)
            phase = m.phase + shift
        ratio = var / jnp.where(m.var_phase > 0, m.var_phase, 1.0)
        return replace(m, phase=jnp.mod(phase, 2.0 * jnp.pi), var_phase=var, v_first=ratio * m.v_first,
                       correlation=self.neighbour_correlation)


class TemporalAverage(AbstractProcessing):
    """The mean of ``frames`` consecutive raw frames (static, 2 .. 64) per delivered frame (module
    docstring): the depth as wrapped deviations around their circular mean, the amplitude as
    numbers, over the raw frames that are valid; a delivered frame is valid where any of them is."""

    frames: int = eqx.field(static=True, default=2)

    def __check_init__(self):
        if isinstance(self.frames, bool) or not isinstance(self.frames, int) or not 2 <= self.frames <= 64:
            raise ValueError(f"TemporalAverage: frames = {self.frames!r} is out of range: allowed integer "
                             "2 <= value <= 64")

    @property
    def frames_in(self) -> int:
        return self.frames

    def sample(self, s: Samples) -> Samples:
        g = self.frames
        group = lambda x: x.reshape((-1, g) + x.shape[1:])  # noqa: E731 - (n g, ...) -> (n, g, ...)
        phase, amplitude, valid = group(s.phase), group(s.amplitude), group(s.valid)
        w = valid.astype(phase.dtype)
        centre = jnp.arctan2(jnp.sum(w * jnp.sin(phase), axis=1), jnp.sum(w * jnp.cos(phase), axis=1))
        count = jnp.maximum(jnp.sum(w, axis=1), 1.0)
        shift = jnp.sum(w * wrap_phase(phase - centre[:, None]), axis=1) / count
        return replace(s, phase=wrap_phase(centre + shift), amplitude=jnp.sum(w * amplitude, axis=1) / count,
                       valid=jnp.any(valid, axis=1))

    def moments(self, m: Moments) -> Moments:
        f = 1.0 / self.frames
        return replace(m, var_phase=f * m.var_phase, v_first=f * m.v_first, var_amp=f * m.var_amp)
