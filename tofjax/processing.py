"""The camera's own depth processing, public: the stages a product runs after its pixels'
demodulation, to compose into :attr:`tofjax.Camera.processing` (docs/model.md, "The camera's
processing").

- :class:`Calibration`: the factory correction of wiggling and offset at a calibration temperature;
- :class:`SpatialFilter`: a k x k box mean or median of the depth;
- :class:`TemporalAverage`: the mean of n raw frames per delivered frame;
- :class:`Invalidation`: the camera's amplitude threshold and flying-pixel filter;
- :class:`AbstractProcessing`: what to subclass for a stage of one's own (its rules for the moments
  and for the samples, :mod:`tofjax.chain`);
- :func:`median_variance`: the variance of the median of n standard normals (the median filter's
  closed form).

Example::

    camera = tj.Camera(tj.Params(), processing=(tj.processing.Calibration(),
                                                tj.processing.SpatialFilter("median", 3),
                                                tj.processing.Invalidation(min_amplitude_lsb=20.0)))
"""

from ._factory_calibration import Calibration
from ._filters import SpatialFilter, TemporalAverage, median_variance
from ._invalidation import Invalidation
from ._processing import AbstractProcessing

__all__ = ["AbstractProcessing", "Calibration", "Invalidation", "SpatialFilter", "TemporalAverage", "median_variance"]
