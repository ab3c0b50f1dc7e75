"""Least squares with optimistix Levenberg-Marquardt, covariance from the Jacobian, and a report
of what the data cannot separate.

The covariance is (J^T J)^-1 of the whitened residuals in the parameters' own units, computed on
the correlation scale (J^T J normalised by its diagonal) so that parameters of very different
magnitude (fF and V) do not ruin the conditioning. Directions whose eigenvalue is below 1e-10 of
the largest are not determined by the data: the parameters in them get an infinite sigma, and the
diagnostics name them. Sigmas are not rescaled by chi^2/dof (the residuals are whitened by the
data's own uncertainties); ``chi2_per_dof`` says whether that is justified.
"""

from __future__ import annotations

import dataclasses
import itertools

import jax
import jax.numpy as jnp
import numpy as np
import optimistix as optx

from ._problem import Problem, evaluate, jacobian_theta, residuals

#: Parameters that only scale the number of photo-electrons (signal and background alike,
#: Eqs 3.11 and 3.18): their product is what the data measure.
FLUX_SCALERS = {
    "illumination.peak_power_w", "scene.reflectivity", "camera.k_lens", "camera.fill_factor",
    "pixel.photo_responsivity_a_per_w", "camera.f_number",
}
CORRELATION_LIMIT = 0.95
NULL_EIGENVALUE = 1e-10


class ConvergenceError(RuntimeError):
    """The least-squares solver did not converge; the message says why and after how many steps."""


@dataclasses.dataclass
class LeastSquaresResult:
    """Estimates, uncertainties and diagnostics of a least-squares fit."""

    names: tuple[str, ...]
    units: tuple[str, ...]
    initial: np.ndarray
    estimate: np.ndarray
    sigma: np.ndarray
    covariance: np.ndarray
    correlation: np.ndarray
    unconstrained: np.ndarray
    unconstrained_covariance: np.ndarray
    chi2: float
    dof: int
    converged: bool
    steps: int
    solver_message: str
    condition_number: float
    degeneracies: list[str]
    residual_summary: list[dict]

    @property
    def chi2_per_dof(self) -> float:
        return self.chi2 / self.dof if self.dof > 0 else float("nan")

    def as_dict(self) -> dict:
        def num(x):
            x = float(x)
            return x if np.isfinite(x) else ("inf" if x > 0 else ("-inf" if x < 0 else "nan"))

        return {
            "parameters": {
                n: {"unit": u, "initial": float(i), "estimate": float(e), "sigma": num(s)}
                for n, u, i, e, s in zip(self.names, self.units, self.initial, self.estimate, self.sigma, strict=True)
            },
            "correlation": [[num(x) for x in row] for row in self.correlation],
            "chi2": self.chi2, "dof": self.dof, "chi2_per_dof": num(self.chi2_per_dof),
            "converged": self.converged, "steps": self.steps, "solver_result": self.solver_message,
            "condition_number": num(self.condition_number), "degeneracies": self.degeneracies,
            "residuals": self.residual_summary,
        }


def _explain(a: str, b: str) -> str:
    if a in FLUX_SCALERS and b in FLUX_SCALERS:
        return "both only scale the number of photo-electrons (Eqs 3.11, 3.18), so the data fix their product"
    if "pixel.demodulation_contrast" in (a, b) and (a in FLUX_SCALERS or b in FLUX_SCALERS):
        return ("the amplitude fixes contrast x photo-electrons; only the shot-noise share of the depth noise "
                "separates them, so data where shot noise dominates (bright, long exposures, background light) help")
    return "their effects on every residual are nearly proportional"


def _covariance(jac_theta: np.ndarray, names) -> tuple[np.ndarray, float, list[str]]:
    jtj = jac_theta.T @ jac_theta
    scale = np.sqrt(np.diag(jtj))
    messages = []
    zero = scale == 0
    for i in np.flatnonzero(zero):
        messages.append(f"{names[i]} does not affect any residual: the data say nothing about it")
    scale = np.where(zero, 1.0, scale)
    normalised = jtj / np.outer(scale, scale)
    evals, evecs = np.linalg.eigh(normalised)
    top = evals.max() if evals.size else 1.0
    null = evals <= NULL_EIGENVALUE * top
    condition = float(top / evals.min()) if evals.min() > 0 else float("inf")
    inv_evals = np.where(null, 0.0, 1.0 / np.where(null, 1.0, evals))
    cov = (evecs * inv_evals) @ evecs.T / np.outer(scale, scale)
    undetermined = np.zeros(len(names), bool) | zero
    for k in np.flatnonzero(null):
        members = np.flatnonzero(np.abs(evecs[:, k]) > 0.1)
        undetermined[members] = True
        if len(members) > 1:
            combo = " and ".join(names[m] for m in members)
            reason = _explain(names[members[0]], names[members[1]]) if len(members) == 2 else \
                "their combined effect on the residuals cancels"
            messages.append(f"{combo} cannot be separated by these data (one combination is undetermined): {reason}")
    cov[undetermined, :] = np.inf
    cov[:, undetermined] = np.inf
    return cov, condition, messages


def _correlation(cov: np.ndarray) -> np.ndarray:
    with np.errstate(invalid="ignore", divide="ignore"):
        d = np.sqrt(np.diag(cov))
        corr = cov / np.outer(d, d)
    corr[~np.isfinite(corr)] = np.nan
    np.fill_diagonal(corr, 1.0)
    return corr


def _summaries(problem: Problem, theta, paths) -> list[dict]:
    from ._data import OBSERVABLES

    evaluated = evaluate(problem, jnp.asarray(theta))
    out = []
    for path, per_file, v_file, masks in zip(paths, evaluated, problem.values, problem.masks, strict=True):
        for name, (m, s), v, mask in zip(OBSERVABLES, per_file, v_file, masks, strict=True):
            mask = np.asarray(mask)
            r = ((np.asarray(m) - np.asarray(v)) / np.asarray(s))[mask]
            if r.size == 0:
                continue
            out.append({"file": path, "observable": name, "rows": int(r.size), "rms": float(np.sqrt(np.mean(r**2))),
                        "mean": float(np.mean(r)), "max_abs": float(np.max(np.abs(r)))})
    return out


def fit_least_squares(problem: Problem, *, max_steps: int = 256, rtol: float = 1e-8, atol: float = 1e-8,
                      throw: bool = True, paths=None) -> LeastSquaresResult:
    """Fit ``problem`` by Levenberg-Marquardt (optimistix) from the configuration's values.

    **Arguments:**
    - ``problem``: from :func:`fitting.build_problem`; ``paths``: the files' names for the
      residual summary (default: file 0, 1, ...).
    - ``max_steps``, ``rtol``, ``atol``: solver limits and tolerances.
    - ``throw``: raise :class:`ConvergenceError` if the solver did not converge (default); with
      ``False`` the result has ``converged = False`` and is returned for inspection.
    """
    n_params = len(problem.parameters)
    dof = problem.n_residuals - n_params
    if problem.n_residuals < n_params:
        raise ValueError(f"{problem.n_residuals} residuals cannot determine {n_params} parameters")
    solver = optx.LevenbergMarquardt(rtol=rtol, atol=atol)
    sol = optx.least_squares(residuals, solver, problem.initial_unconstrained(), args=problem, max_steps=max_steps,
                             throw=False)
    converged = bool(sol.result == optx.RESULTS.successful)
    message = optx.RESULTS[sol.result] if not converged else "successful"
    steps = int(sol.stats["num_steps"])
    if not converged and throw:
        raise ConvergenceError(f"least squares did not converge after {steps} steps: {message}")
    u = sol.value
    theta = problem.constrained(u)
    jac_theta = np.asarray(jacobian_theta(problem, theta))
    if not np.all(np.isfinite(jac_theta)):
        raise ConvergenceError("the Jacobian at the solution is not finite; the fit cannot be trusted")
    names = problem.names
    cov, condition, messages = _covariance(jac_theta, names)
    corr = _correlation(cov)
    for i, j in itertools.combinations(range(n_params), 2):
        if np.isfinite(corr[i, j]) and abs(corr[i, j]) > CORRELATION_LIMIT:
            messages.append(f"{names[i]} and {names[j]} are strongly correlated (correlation {corr[i, j]:+.3f}): "
                            f"{_explain(names[i], names[j])}; their individual sigmas are large")
    dtheta = np.asarray(jax.jacfwd(problem.constrained)(u)).diagonal()
    with np.errstate(invalid="ignore", divide="ignore"):
        cov_u = cov / np.outer(dtheta, dtheta)
    r = np.asarray(residuals(u, problem))
    return LeastSquaresResult(
        names=names, units=tuple(p.unit for p in problem.parameters),
        initial=np.array([p.initial for p in problem.parameters]), estimate=np.asarray(theta),
        sigma=np.sqrt(np.diag(cov)), covariance=cov, correlation=corr, unconstrained=np.asarray(u),
        unconstrained_covariance=cov_u, chi2=float(np.sum(r**2)), dof=dof, converged=converged, steps=steps,
        solver_message=message, condition_number=condition, degeneracies=messages,
        residual_summary=_summaries(problem, theta, paths or [f"file {i}" for i in range(len(problem.bases))]),
    )
