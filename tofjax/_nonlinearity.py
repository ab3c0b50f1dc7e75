"""The readout chain's gain compression: a stage added after the thesis (docs/model.md, "Adding a
stage: a worked example").

A source follower and a column amplifier compress large signals; to third order, an odd transfer
curve of the differential x = A - B (a differential readout cancels the even orders):

    y = x - c x^3,   c = k / N_sat^2,

with k = ``pixel.readout_nonlinearity`` the relative gain lost at a differential of one full well
N_sat (data sheets quote it as the readout's nonlinearity at full scale; 0: linear). The curve stays
monotonic while 3 k (x / N_sat)^2 < 1, beyond any reachable differential for k <= 0.25.

For a Gaussian input of mean mu and variance s^2 (Gaussian moments E x^3 = mu^3 + 3 mu s^2, E x^4,
E x^6) the output's variance is exact,

    Var y = s^2 - 6 c (mu^2 s^2 + s^4) + c^2 (9 mu^4 s^2 + 36 mu^2 s^4 + 15 s^6),

and its mean E y = mu - c (mu^3 + 3 mu s^2) is taken to first order in the noise, f(mu) = mu - c mu^3:
the term left out, 3 c mu s^2, is a fraction 3 k s^2 / N_sat^2 of the mean, 1e-5 for the default
camera at k = 0.25 with a full well's worth of shot noise (s^2 = N_sat = 7.9e4), and keeping it would
couple the expected code to every noise source's gradient (60 % more compile
time for a gradient of ``predict``; docs/model.md, "Adding a stage").
"""

from __future__ import annotations

from jaxtyping import Array, Float

from ._stages import AbstractStage, Moments, Samples, replace


class ReadoutNonlinearity(AbstractStage):
    """y = x - c x^3 on the held differential (module docstring).

    **Fields:** ``k`` (relative gain loss at one full well), ``full_well_e`` (N_sat, e-)."""

    k: Float[Array, ""]
    full_well_e: Float[Array, ""]

    @property
    def c(self) -> Array:
        """The cubic coefficient k / N_sat^2, 1/e-^2."""
        return self.k / self.full_well_e**2

    def moments(self, m: Moments) -> Moments:
        c, mu, s2 = self.c, m.diff, m.var_diff
        mu2 = mu * mu
        mean = mu * (1.0 - c * mu2)  # first order in the noise (module docstring)
        var = s2 * (1.0 - 6.0 * c * (mu2 + s2) + c * c * (9.0 * mu2 * mu2 + s2 * (36.0 * mu2 + 15.0 * s2)))
        return replace(m, diff=mean, var_diff=var)

    def sample(self, s: Samples) -> Samples:
        x = s.diff
        return replace(s, diff=x - self.c * (x * x * x))
