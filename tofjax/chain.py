"""The signal chain, public: what to subclass and compose to extend the model (docs/model.md, "The
composed chain", "Adding a stage", "Adding a noise source").

- :func:`build_chain` (a camera's :class:`Chain`: the exposure and the ordered tuple of stages);
- :class:`AbstractStage` (a stage: its rule for the moments and for a sample), the fold's states
  :class:`Moments` and :class:`Samples`, and the stages :class:`Noise`, :class:`ReadoutNonlinearity`;
- :class:`AbstractNoiseSource` (a temporal noise source), :data:`NOISE_SOURCES` (the camera's),
  :class:`NoiseBudget` (every source, for the breakdown and the estimates);
- :func:`mean_pattern` (every pixel the mean pixel, a :class:`tofjax.PixelPattern`).
"""

from ._chain import Chain, build_chain
from ._noise import NOISE_SOURCES, AbstractNoiseSource, Noise, NoiseBudget
from ._nonlinearity import ReadoutNonlinearity
from ._pattern import mean_pattern
from ._stages import AbstractStage, Moments, Samples

__all__ = ["NOISE_SOURCES", "AbstractNoiseSource", "AbstractStage", "Chain", "Moments", "Noise", "NoiseBudget",
           "ReadoutNonlinearity", "Samples", "build_chain", "mean_pattern"]
