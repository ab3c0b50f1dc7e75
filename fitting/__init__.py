"""fitting: calibrate tofjax's sensor parameters against measured sweeps.

Least squares with optimistix (Levenberg-Marquardt) and posterior sampling with emcee, on the
whitened residuals of amplitude and depth noise rows of tofjax-sweep files. The command line is
``tofjax calibrate``; this package is its Python API. Names load on first use (so that ``tofjax
--help``, which registers the subcommand, imports neither JAX nor emcee).
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING

_EXPORTS = {
    "Calibration": "_calibrate", "calibrate": "_calibrate",
    "BoundsAtSolution": "_bounds", "physical_flags": "_bounds",
    "SweepRows": "_data", "load_rows": "_data", "Measurement": "_data", "read_measurement": "_data",
    "FileComparison": "_compare", "compare": "_compare", "write_comparison": "_compare",
    "BoundCheck": "_compare", "check_bounds": "_compare",
    "ConvergenceError": "_least_squares", "LeastSquaresResult": "_least_squares",
    "fit_least_squares": "_least_squares",
    "CalibrationInputError": "_parameters", "FreeParameter": "_parameters", "fittable_names": "_parameters",
    "make_parameters": "_parameters",
    "PosteriorResult": "_posterior", "ShortChainWarning": "_posterior", "sample_posterior": "_posterior",
    "Problem": "_problem", "build_problem": "_problem",
}
__all__ = sorted(_EXPORTS)


def __getattr__(name: str):
    if name in _EXPORTS:
        value = getattr(importlib.import_module(f".{_EXPORTS[name]}", __name__), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'fitting' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted([*globals(), *_EXPORTS])


if TYPE_CHECKING:  # pragma: no cover
    from ._bounds import BoundsAtSolution, physical_flags  # noqa: F401
    from ._calibrate import Calibration, calibrate  # noqa: F401
    from ._compare import BoundCheck, FileComparison, check_bounds, compare, write_comparison  # noqa: F401
    from ._data import Measurement, SweepRows, load_rows, read_measurement  # noqa: F401
    from ._least_squares import ConvergenceError, LeastSquaresResult, fit_least_squares  # noqa: F401
    from ._parameters import CalibrationInputError, FreeParameter, fittable_names, make_parameters  # noqa: F401
    from ._posterior import PosteriorResult, ShortChainWarning, sample_posterior  # noqa: F401
    from ._problem import Problem, build_problem  # noqa: F401
