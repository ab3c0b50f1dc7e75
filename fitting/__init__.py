"""fitting: calibrate tofjax's sensor parameters against measured sweeps.

Least squares with optimistix (Levenberg-Marquardt) and posterior sampling with emcee, on the
whitened residuals of amplitude and depth noise rows of tofjax-sweep files. The command line is
``tofjax calibrate``; this package is its Python API.
"""

import tofjax as _tofjax  # noqa: F401  (float64 on)

from ._calibrate import Calibration as Calibration, calibrate as calibrate
from ._data import SweepRows as SweepRows, load_rows as load_rows
from ._least_squares import (
    ConvergenceError as ConvergenceError,
    LeastSquaresResult as LeastSquaresResult,
    fit_least_squares as fit_least_squares,
)
from ._parameters import (
    CalibrationInputError as CalibrationInputError,
    FreeParameter as FreeParameter,
    fittable_names as fittable_names,
    make_parameters as make_parameters,
)
from ._posterior import (
    PosteriorResult as PosteriorResult,
    ShortChainWarning as ShortChainWarning,
    sample_posterior as sample_posterior,
)
from ._problem import Problem as Problem, build_problem as build_problem
