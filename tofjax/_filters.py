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
    xs, ys = x[:, None], x[None, :]
    upper = ys > xs
    for n in range(2, n_max + 1):
        if n % 2:
            out[n] = np.sum(x * x * order_density(n, (n + 1) // 2)) * h
            continue
        k = n // 2
        second = np.sum(x * x * (order_density(n, k) + order_density(n, k + 1))) * h
        log_k = math.lgamma(n + 1) - math.lgamma(k) - math.lgamma(n - k)
        joint = np.exp(log_k + (k - 1) * logc[:, None] + (n - k - 1) * logs[None, :]) * pdf[:, None] * pdf[None, :]
        # x < y, the diagonal's cells half inside (the trapezoid rule across the density's edge).
        cross = (np.sum(np.where(upper, xs * ys * joint, 0.0)) + 0.5 * np.sum(x * x * np.diag(joint))) * h * h
        out[n] = 0.25 * (second + 2.0 * cross)
        mean_k = np.sum(x * order_density(n, k)) * h  # the upper middle value's mean is -mean_k
        var_k = 0.5 * second - mean_k**2
        rho[n] = (cross + mean_k**2) / var_k
    return out, rho


def median_variance(n):
    """c(n): the variance of the median of ``n`` independent standard normal values (the mean of the
    two middle ones for even ``n``); 0 for ``n = 0`` (an array of counts, or a number)."""
    return jnp.asarray(_median_variances()[0])[jnp.asarray(n, dtype=jnp.int32)]


#: Nodes per neighbour of the median's moments in a frame (:func:`median_moments`).
MEDIAN_NODES = 8


def median_moments(means: list, sds: list, ok: list) -> tuple:
    """The mean and variance of the median of independent normal values N(means_j, sds_j^2), those
    where ``ok`` (the neighbours present), elementwise over their arrays: a frame's median filter of
    pixels whose expected depths differ (across a depth gradient or an edge the median follows one
    neighbour, and its variance is not c(n) s^2).

    The r-th smallest of n values is at most x where at least r are: P = sum_{i >= r} P(N(x) = i),
    N(x) Poisson-binomial of p_j = Phi((x - m_j) / s_j) (counted value by value). Its moments follow
    from E[X] = x_0 + int (1 - F) dx and E[X^2] = x_0^2 + int 2 x (1 - F) dx, by the trapezoid rule on
    :data:`MEDIAN_NODES` nodes around each value (F is flat between them), scanned in order. For an
    even count the median is the mean of the two middle values: its mean is exact, its variance
    takes their correlation in the identical case (:func:`_median_variances`)."""
    from jax import lax

    from ._processing import normal_cdf

    dtype = means[0].dtype
    m = jnp.stack([jnp.where(o, mu, 0.0) for mu, o in zip(means, ok, strict=True)], axis=-1)  # (..., n)
    s = jnp.stack([jnp.where(o, sd, 1.0) for sd, o in zip(sds, ok, strict=True)], axis=-1)
    present = jnp.stack(ok, axis=-1)
    count = jnp.sum(present, axis=-1)
    spread = jnp.max(jnp.where(present, s, 0.0), axis=-1, keepdims=True)
    offsets = jnp.linspace(-4.0, 4.0, MEDIAN_NODES, dtype=dtype).reshape((1,) * m.ndim + (-1,))
    nodes = (m[..., :, None] + jnp.where(present, s, spread)[..., :, None] * offsets).reshape(m.shape[:-1] + (-1,))
    nodes = jnp.sort(nodes, axis=-1)
    n_max = len(means)
    lower = (count + 1) // 2  # the (lower) middle rank, 1-based
    upper = count // 2 + 1

    def cdfs(x):  # P(the lower / upper middle value <= x), at nodes x (...)
        probs = jnp.zeros(x.shape + (n_max + 1,), dtype).at[..., 0].set(1.0)
        for j in range(n_max):
            p = jnp.where(present[..., j], normal_cdf((x - m[..., j]) / s[..., j]), 0.0)[..., None]
            shifted = jnp.concatenate([jnp.zeros_like(probs[..., :1]), probs[..., :-1]], axis=-1)
            probs = probs * (1.0 - p) + shifted * p
        at_least = jnp.flip(jnp.cumsum(jnp.flip(probs, -1), -1), -1)  # P(N >= i)
        return tuple(jnp.take_along_axis(at_least, r[..., None], axis=-1)[..., 0] for r in (lower, upper))

    def step(carry, x):
        x_prev, f_prev, acc = carry
        f = cdfs(x)
        h = x - x_prev
        acc = tuple(a + h[None] * jnp.stack([1.0 - 0.5 * (fp + fx), x_prev * (1.0 - fp) + x * (1.0 - fx)])
                    for a, fp, fx in zip(acc, f_prev, f, strict=True))
        return (x, f, acc), None

    first = nodes[..., 0]
    zero = jnp.zeros((2,) + first.shape, dtype)
    (_, _, acc), _ = lax.scan(step, (first, cdfs(first), (zero, zero)), jnp.moveaxis(nodes[..., 1:], -1, 0))
    moments = [(first + a[0], first**2 + a[1]) for a in acc]  # E X, E X^2 of the lower and upper middle values
    (e_lo, e2_lo), (e_hi, e2_hi) = moments
    var_lo, var_hi = jnp.maximum(e2_lo - e_lo**2, 0.0), jnp.maximum(e2_hi - e_hi**2, 0.0)
    rho = jnp.asarray(_median_variances()[1])[count]
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
            stacked = jnp.stack([jnp.where(o, d, jnp.nan) for d, o in zip(devs, ok, strict=True)])
            shift = jnp.where(count > 0, jnp.nanmedian(jnp.where(count[None] > 0, stacked, 0.0), axis=0), 0.0)
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
