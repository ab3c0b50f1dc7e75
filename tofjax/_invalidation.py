"""The camera's own invalidation: what its data say it cannot trust (docs/model.md, "The camera's
processing"). A camera sees only its frames, not the scene: it rejects a pixel whose amplitude (its
confidence) is below a threshold, and a flying pixel, whose depth differs from its neighbours' by
more than a threshold (a pixel that straddles a depth edge reads between the two surfaces).

:class:`Invalidation` acts on each frame (samples: the frame's amplitude and its neighbours' depths)
and on the probability that a point is delivered (moments):

- amplitude: P(a >= a_min) = Phi((E a - a_min) / sd a), the frame's amplitude taken as Gaussian;
- flying pixel: a pixel is rejected where at least ``flying_pixel_neighbours`` of its 8 neighbours
  (those present) differ from it by more than ``flying_pixel_m``. Given the pixel's own depth d0,
  each neighbour j differs with probability p_j(d0) = 1 - [Phi((d0 - m_j + T) / s_j) - Phi((d0 - m_j
  - T) / s_j)], independently; the count of those that differ is Poisson-binomial, and the
  probability that fewer than the threshold differ is its expectation over d0 ~ N(m_0, s_0^2), by
  Gauss-Hermite quadrature (:data:`QUADRATURE_NODES` nodes). A sweep's point has 8 neighbours of its
  own statistics (a uniform patch); a frame's pixel its image's.

The two conditions are treated as independent (the amplitude's noise and the depth's are those of the
phasor's two axes). A point also saturates in the sensor (the hard limits): that is the chain's
validity, to which this adds.
"""

from __future__ import annotations

import math

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from ._processing import AbstractProcessing, neighbours, normal_cdf, wrap_phase
from ._stages import Moments, Samples, replace

#: Gauss-Hermite nodes of the flying-pixel probability (exact for a polynomial of degree 2 x 24 - 1 in
#: the pixel's own depth; the integrand is smooth in it).
QUADRATURE_NODES = 24


class Invalidation(AbstractProcessing):
    """The camera's invalidation (module docstring).

    **Fields:** ``min_amplitude_lsb`` (a frame whose amplitude is below it is not delivered; 0:
    off), ``flying_pixel_m`` (the depth difference to a neighbour beyond which it counts as
    differing; ``None``: no flying-pixel filter), ``flying_pixel_neighbours`` (static: how many of the 8 neighbours must
    differ, 1 .. 8), ``to_m`` (the unambiguity range over 2 pi: metres per radian of phase, bound
    from the camera's frequency when the chain is built)."""

    min_amplitude_lsb: Float[Array, ""] | float = 0.0
    flying_pixel_m: Float[Array, ""] | float | None = None
    flying_pixel_neighbours: int = eqx.field(static=True, default=1)
    to_m: Float[Array, ""] | None = None

    def __check_init__(self):
        n = self.flying_pixel_neighbours
        if isinstance(n, bool) or not isinstance(n, int) or not 1 <= n <= 8:
            raise ValueError(f"Invalidation: flying_pixel_neighbours = {n!r} is out of range: allowed integer "
                             "1 <= value <= 8")
        for name, zero, allowed in (("min_amplitude_lsb", True, "0 <= value (0: off)"),
                                    ("flying_pixel_m", False, "0 < value (None: off)")):
            value = getattr(self, name)
            if isinstance(value, int | float) and not (math.isfinite(value) and (value >= 0 if zero else value > 0)):
                raise ValueError(f"Invalidation: {name} = {value!r} is out of range: allowed {allowed}")

    @property
    def reach(self) -> int:
        return 1 if self._flying else 0

    @property
    def _flying(self) -> bool:
        """Whether the flying-pixel filter is on (a static choice: ``flying_pixel_m`` not ``None``)."""
        return self.flying_pixel_m is not None

    def bind(self, params, correlation, sample) -> Invalidation:
        return eqx.tree_at(lambda s: s.to_m, self, params.unambiguity_range_m / (2.0 * jnp.pi),
                           is_leaf=lambda x: x is None)

    def sample(self, s: Samples) -> Samples:
        valid = s.valid & (s.amplitude >= self.min_amplitude_lsb)
        if self._flying:
            threshold = self.flying_pixel_m / self.to_m
            near = neighbours(s.phase, 1, 0.0)
            present = neighbours(s.valid, 1, False)
            differ = sum((o & (jnp.abs(wrap_phase(v - s.phase)) > threshold)).astype(jnp.int32)
                         for i, (v, o) in enumerate(zip(near, present, strict=True)) if i != 4)
            valid = valid & (differ < self.flying_pixel_neighbours)
        return replace(s, valid=valid)

    def moments(self, m: Moments) -> Moments:
        sd_amp = jnp.sqrt(m.var_amp)
        threshold = jnp.asarray(self.min_amplitude_lsb, dtype=m.amp.dtype)
        z = (m.amp - threshold) / jnp.where(sd_amp > 0, sd_amp, 1.0)
        p = jnp.where(sd_amp > 0, normal_cdf(z), (m.amp >= threshold).astype(m.amp.dtype))
        p = jnp.where(threshold > 0, p, 1.0)
        if self._flying:
            kept, shift, var = self._kept_flying(m)
            ratio = var / jnp.where(m.var_phase > 0, m.var_phase, 1.0)
            m = replace(m, phase=jnp.mod(m.phase + shift, 2.0 * jnp.pi), var_phase=var, v_first=ratio * m.v_first)
            p = p * kept
        return replace(m, delivered=p if m.delivered is None else m.delivered * p)

    def _kept_flying(self, m: Moments) -> tuple[Array, Array, Array]:
        """The flying-pixel filter's closed form (module docstring): the probability that fewer than
        ``flying_pixel_neighbours`` neighbours differ, and the mean and variance of the pixel's own
        phase deviation in the frames it keeps (a frame whose pixel strays from its neighbours is
        the one rejected, so the kept frames are less noisy).

        Neighbour j's phase, given the pixel's own deviation d0, is Gaussian with mean m_j + r_j s_j /
        s_0 d0 and variance s_j^2 (1 - r_j^2): r_j the correlation an earlier spatial filter made
        (:attr:`~tofjax._stages.Moments.correlation`)."""
        sd = jnp.sqrt(jnp.maximum(m.var_phase, 0.0))
        t = self.flying_pixel_m / self.to_m
        side, diagonal = m.correlation
        rho = [diagonal if i % 2 == 0 else side for i in range(9)]
        if m.image:
            means = [wrap_phase(v - m.phase) for v in neighbours(m.phase, 1, 0.0)]
            sds = neighbours(sd, 1, 1.0)
            present = neighbours(jnp.ones(m.phase.shape, bool), 1, False)
        else:
            means, sds, present = [jnp.zeros_like(sd)] * 9, [sd] * 9, [None] * 9
        lead = lambda x: None if x is None else x[None]  # noqa: E731 - against the nodes' leading axis
        others = [(lead(mu), lead(s), lead(o), r)
                  for i, (mu, s, o, r) in enumerate(zip(means, sds, present, rho, strict=True)) if i != 4]
        safe0 = jnp.where(sd > 0, sd, 1.0)[None]
        x, w = np.polynomial.hermite.hermgauss(QUADRATURE_NODES)
        nodes = jnp.asarray(math.sqrt(2.0) * x).reshape((-1,) + (1,) * sd.ndim)  # on a leading axis
        d0 = nodes * sd[None]  # the pixel's own deviation at each node, N(0, s0^2)
        # Poisson-binomial: the probabilities of 0 .. k - 1 neighbours differing, neighbour by neighbour.
        counts = [jnp.ones_like(d0)] + [jnp.zeros_like(d0)] * (self.flying_pixel_neighbours - 1)
        for mu, s, o, r in others:
            centre = mu + (r * s / safe0 - 1.0) * d0  # the difference neighbour - pixel, given d0
            spread = s * math.sqrt(1.0 - r * r)
            safe = jnp.where(spread > 0, spread, 1.0)
            inside = normal_cdf((t - centre) / safe) - normal_cdf((-t - centre) / safe)
            inside = jnp.where(spread > 0, inside, (jnp.abs(centre) <= t).astype(d0.dtype))
            q = 1.0 - inside if o is None else jnp.where(o, 1.0 - inside, 0.0)
            counts = [c * (1.0 - q) + (counts[i - 1] * q if i else 0.0) for i, c in enumerate(counts)]
        weights = jnp.asarray(w / math.sqrt(math.pi)).reshape(nodes.shape)
        k = weights * sum(counts)
        kept, first, second = jnp.sum(k, axis=0), jnp.sum(k * d0, axis=0), jnp.sum(k * d0 * d0, axis=0)
        ok = kept > 0
        safe = jnp.where(ok, kept, 1.0)
        shift = jnp.where(ok, first / safe, 0.0)
        var = jnp.where(ok, jnp.maximum(second / safe - shift * shift, 0.0), m.var_phase)
        return jnp.clip(kept, 0.0, 1.0), shift, var
