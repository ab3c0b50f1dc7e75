"""The calibration problem: free parameters, data rows, and the whitened residuals.

The model side is :func:`tofjax.predict` (analytic path) in the smooth mode, so the residuals are
differentiable everywhere, including near saturation. Residual = (model - data) / sigma, for the
amplitude (LSB) and the depth standard deviation (m) of every row that enters the fit.
"""

from __future__ import annotations

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import tofjax as tj
from jaxtyping import Array, Float

from ._data import OBSERVABLES, SweepRows
from ._parameters import FreeParameter


class Problem(eqx.Module):
    """Free parameters plus prepared sweeps (build with :func:`fitting.build_problem`).

    Every file contributes one residual slot per row and observable; rows that do not enter the
    fit are masked (residual 0), so the shapes depend only on the files' row counts and a new data
    realisation does not recompile.
    """

    parameters: tuple[FreeParameter, ...] = eqx.field(static=True)
    relative_error: float | None = eqx.field(static=True)
    bases: tuple[tj.Params, ...]
    sweeps: tuple[tj.Sweep, ...]
    values: tuple[tuple[Array, ...], ...]
    masks: tuple[tuple[Array, ...], ...]
    frames: tuple[Array, ...]
    smooth: tj.Smooth

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(p.name for p in self.parameters)

    @property
    def n_residuals(self) -> int:
        return sum(int(np.sum(m)) for per_file in self.masks for m in per_file)

    def initial_unconstrained(self) -> Float[Array, " params"]:
        return jnp.asarray([p.to_unconstrained(p.initial) for p in self.parameters])

    def constrained(self, u: Float[Array, " params"]) -> Float[Array, " params"]:
        return jnp.stack([p.to_constrained(u[i]) for i, p in enumerate(self.parameters)])

    def with_values(self, base: tj.Params, theta: Float[Array, " params"]) -> tj.Params:
        """``base`` with the free parameters set to ``theta``."""
        def leaves(p):
            return tuple(getattr(getattr(p, q.section), q.field) for q in self.parameters)

        return eqx.tree_at(leaves, base, tuple(theta[i] for i in range(len(self.parameters))))

    def predict(self, theta: Float[Array, " params"], i: int, sweep: tj.Sweep | None = None) -> tj.Result:
        """The model of file ``i`` at ``theta`` (smooth mode), on its rows or on ``sweep``."""
        return tj.predict(self.with_values(self.bases[i], theta), self.sweeps[i] if sweep is None else sweep,
                          smooth=self.smooth)

    def evaluate(self, theta: Float[Array, " params"]) -> tuple[tuple[tuple[Array, Array], ...], ...]:
        """Per file and observable: (model value, row uncertainty) on every row (masked rows: 1)."""
        out = []
        for i in range(len(self.bases)):
            r = self.predict(theta, i)
            n = self.frames[i]
            if self.relative_error is not None:
                sigmas = tuple(self.relative_error * jnp.abs(v) for v in self.values[i])
            else:
                sigmas = (r.amplitude_std_lsb / jnp.sqrt(jnp.maximum(n, 1.0)),
                          r.depth_std_m / jnp.sqrt(2.0 * jnp.maximum(n - 1.0, 1.0)))
            models = (r.amplitude_mean_lsb, r.depth_std_m)
            out.append(tuple((m, jnp.where(mask, s, 1.0))
                             for m, s, mask in zip(models, sigmas, self.masks[i], strict=True)))
        return tuple(out)

    def residuals_theta(self, theta: Float[Array, " params"]) -> Float[Array, " residuals"]:
        parts = []
        for per_file, values, masks in zip(self.evaluate(theta), self.values, self.masks, strict=True):
            parts.extend(jnp.where(mask, (m - v) / s, 0.0)
                         for (m, s), v, mask in zip(per_file, values, masks, strict=True))
        return jnp.concatenate(parts)

    def residuals(self, u: Float[Array, " params"]) -> Float[Array, " residuals"]:
        """Whitened residuals at unconstrained parameters ``u`` (0 for masked rows)."""
        return self.residuals_theta(self.constrained(u))


    def log_likelihood(self, theta: Float[Array, " params"]) -> Float[Array, ""]:
        """Gaussian log-likelihood, with the normalisation of parameter-dependent uncertainties."""
        total = jnp.asarray(0.0)
        for per_file, values, masks in zip(self.evaluate(theta), self.values, self.masks, strict=True):
            for (m, s), v, mask in zip(per_file, values, masks, strict=True):
                total = total - jnp.sum(jnp.where(mask, 0.5 * ((m - v) / s) ** 2 + jnp.log(s), 0.0))
        return total

    def log_prior(self, u: Float[Array, " params"]) -> Float[Array, ""]:
        """Log prior density in the unconstrained space: uniform (or Gaussian) in theta within the
        bounds, times the Jacobian of the transform."""
        theta = self.constrained(u)
        total = jnp.asarray(0.0)
        for i, p in enumerate(self.parameters):
            total = total + p.log_abs_jacobian(u[i])
            if p.prior is not None:
                mu, sigma = p.prior
                total = total - 0.5 * ((theta[i] - mu) / sigma) ** 2
        return total

    def log_posterior(self, u: Float[Array, " params"]) -> Float[Array, ""]:
        return self.log_likelihood(self.constrained(u)) + self.log_prior(u)


def build_problem(parameters: tuple[FreeParameter, ...], rows: list[SweepRows], smooth: tj.Smooth | None = None,
                  relative_error: float | None = None) -> Problem:
    """Assemble the problem from free parameters and prepared sweep files."""
    return Problem(
        parameters=tuple(parameters), relative_error=relative_error,
        bases=tuple(r.params for r in rows), sweeps=tuple(r.sweep for r in rows),
        values=tuple(tuple(jnp.asarray(np.where(r.data[n][1], r.data[n][0], 0.0)) for n in OBSERVABLES)
                     for r in rows),
        masks=tuple(tuple(jnp.asarray(r.data[n][1]) for n in OBSERVABLES) for r in rows),
        frames=tuple(jnp.asarray(r.frames, dtype=float) for r in rows),
        smooth=smooth if smooth is not None else tj.Smooth(),
    )


# Module-level compiled entry points: they take the problem as an argument, so every problem of
# the same structure (parameters, files' row counts and static settings) reuses one compilation.
@eqx.filter_jit
def residuals(u, problem: Problem):
    return problem.residuals(u)


@eqx.filter_jit
def jacobian_theta(problem: Problem, theta):
    return jax.jacfwd(problem.residuals_theta)(theta)


@eqx.filter_jit
def evaluate(problem: Problem, theta):
    return problem.evaluate(theta)


@eqx.filter_jit
def batched_log_posterior(problem: Problem, u_batch):
    return jax.vmap(problem.log_posterior)(u_batch)
