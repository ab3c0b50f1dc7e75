"""Posterior sampling with emcee over the same parameters and residuals as the least squares.

The log-probability is jitted and vmapped over walkers (``vectorize=True``), what depends on the
problem alone computed once per run (:mod:`fitting._hoist`), in the unconstrained space: -chi^2/2
plus the log prior (uniform within the bounds by default, optionally Gaussian) plus the
log-Jacobian of the bound transform. Walkers start in a small Gaussian ball around the
least-squares solution. Burn-in is twice the longest autocorrelation time and the chain is thinned
by half the shortest; a chain shorter than 50 autocorrelation times triggers a
:class:`ShortChainWarning`.
"""

from __future__ import annotations

import dataclasses
import warnings
from pathlib import Path

import jax
import numpy as np

from ._hoist import hoisted
from ._least_squares import LeastSquaresResult
from ._problem import Problem, batched_log_posterior

try:
    import emcee
except ImportError:  # the [fit] extra; the least squares do without it
    emcee = None


class ShortChainWarning(UserWarning):
    """The chain is shorter than 50 autocorrelation times: the posterior summary is rough."""


@dataclasses.dataclass
class PosteriorResult:
    """Posterior summary and the flattened, burned-in, thinned samples (parameters' own units)."""

    names: tuple[str, ...]
    samples: np.ndarray
    median: np.ndarray
    p16: np.ndarray
    p84: np.ndarray
    std: np.ndarray
    autocorr_time: np.ndarray
    acceptance_fraction: float
    walkers: int
    steps: int
    burn_in: int
    thin: int
    warnings: list[str]

    def as_dict(self) -> dict:
        return {
            "parameters": {n: {"median": float(m), "p16": float(lo), "p84": float(hi), "std": float(s),
                               "autocorr_time_steps": float(t)}
                           for n, m, lo, hi, s, t in zip(self.names, self.median, self.p16, self.p84, self.std,
                                                         self.autocorr_time, strict=True)},
            "walkers": self.walkers, "steps": self.steps, "burn_in": self.burn_in, "thin": self.thin,
            "acceptance_fraction": self.acceptance_fraction, "samples": int(self.samples.shape[0]),
            "warnings": self.warnings,
        }


def _backend(path: Path | None, walkers: int, ndim: int, resume: bool):
    if path is None:
        return None, False
    try:
        import h5py  # noqa: F401
    except ImportError:
        raise ValueError("an HDF5 backend needs h5py: pip install h5py") from None
    backend = emcee.backends.HDFBackend(str(path))
    if resume and Path(path).exists() and backend.iteration > 0:
        if backend.shape != (walkers, ndim):
            raise ValueError(f"{path} holds a chain of {backend.shape[0]} walkers x {backend.shape[1]} parameters, "
                             f"not {walkers} x {ndim}")
        return backend, True
    backend.reset(walkers, ndim)
    return backend, False


def sample_posterior(problem: Problem, least_squares: LeastSquaresResult, *, walkers: int = 32, steps: int = 2000,
                     seed: int = 0, backend_path: str | Path | None = None, resume: bool = False,
                     progress: bool = True) -> PosteriorResult:
    """Run emcee's affine-invariant ensemble sampler (see the module docstring).

    **Arguments:**
    - ``problem``, ``least_squares``: the problem and its least-squares solution (the start).
    - ``walkers``: an even number >= 2 x parameters; ``steps``: steps to run now.
    - ``seed``: seeds the walkers' start and the sampler.
    - ``backend_path``: an HDF5 file to store the chain; with ``resume`` an existing chain is
      continued for ``steps`` more steps.
    - ``progress``: report the steps (:class:`tofjax.progress.Progress`: a bar on a terminal, a line
      every 10 s otherwise).

    Needs emcee, the ``[fit]`` extra (``pip install "tofjax[fit]"``).
    """
    if emcee is None:
        raise ModuleNotFoundError('fitting.sample_posterior needs emcee, which is not installed: '
                                  'pip install "tofjax[fit]"')
    ndim = problem.n_params
    if walkers < 2 * ndim or walkers % 2:
        raise ValueError(f"walkers = {walkers} is out of range: allowed an even number >= {2 * ndim} "
                         f"(2 x {ndim} parameters)")
    if steps < 1:
        raise ValueError(f"steps = {steps} is out of range: allowed integer >= 1")
    half = walkers // 2
    # What depends on the problem alone (the camera's tables, the sweeps) is computed once here, not
    # in each of the run's calls (fitting._hoist).
    log_posterior = hoisted(batched_log_posterior, problem, np.zeros((half, ndim)))

    def log_prob(u: np.ndarray) -> np.ndarray:
        # emcee evaluates all walkers once (the start) and then half of them per move: the start
        # in halves too, so that one batch shape (one compiled program) serves the whole run.
        u = np.asarray(u, dtype=float)
        out = np.concatenate([np.asarray(log_posterior(u[i:i + half]), dtype=float)
                              for i in range(0, len(u), half)])
        out[~np.isfinite(out)] = -np.inf
        return out

    rng = np.random.default_rng(seed)
    backend, resuming = _backend(Path(backend_path) if backend_path else None, walkers, ndim, resume)
    sampler = emcee.EnsembleSampler(walkers, ndim, log_prob, vectorize=True, backend=backend)
    sampler.random_state = np.random.RandomState(seed).get_state()
    if resuming:
        start = None
    else:
        cov = least_squares.unconstrained_covariance
        u0 = least_squares.unconstrained
        if np.all(np.isfinite(cov)):
            ball = rng.multivariate_normal(np.zeros(ndim), 0.01 * cov + 1e-12 * np.eye(ndim), size=walkers)
        else:
            ball = 1e-3 * rng.standard_normal((walkers, ndim))
        start = u0 + ball
    # tofjax's own reporter, not emcee's bar: a bar on a terminal, a line every 10 s in a log (emcee
    # writes its bar's carriage-return updates into logs).
    from tofjax.progress import Progress

    with Progress(steps, "posterior", unit="step", enabled=progress) as bar:
        for _ in sampler.sample(sampler.get_last_sample() if start is None else start, iterations=steps,
                                progress=False):
            bar.update(1)
    total = sampler.iteration
    tau = np.asarray(sampler.get_autocorr_time(quiet=True, tol=0), dtype=float)
    notes = []
    if not np.all(np.isfinite(tau)) or total < 50 * np.max(tau):
        notes.append(f"the chain ({total} steps) is shorter than 50 autocorrelation times "
                     f"(max {np.max(tau):.0f} steps): run more steps for a reliable posterior")
        warnings.warn(notes[-1], ShortChainWarning, stacklevel=2)
    finite_tau = tau[np.isfinite(tau)]
    burn = int(min(2 * np.max(finite_tau), total // 2)) if finite_tau.size else total // 2
    thin = max(1, int(0.5 * np.min(finite_tau))) if finite_tau.size else 1
    chain_u = sampler.get_chain(discard=burn, thin=thin, flat=True)
    samples = np.asarray(jax.vmap(problem.constrained)(chain_u))
    acceptance = float(np.mean(sampler.acceptance_fraction))
    if not 0.1 < acceptance < 0.9:
        notes.append(f"mean acceptance fraction {acceptance:.2f} is outside 0.1-0.9: the sampler is struggling")
    return PosteriorResult(
        names=problem.names, samples=samples, median=np.median(samples, axis=0),
        p16=np.percentile(samples, 16, axis=0), p84=np.percentile(samples, 84, axis=0),
        std=np.std(samples, axis=0, ddof=1), autocorr_time=tau, acceptance_fraction=acceptance, walkers=walkers,
        steps=total, burn_in=burn, thin=thin, warnings=notes,
    )
