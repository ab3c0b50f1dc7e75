"""Waveforms, public: the emitted and reference waveforms' shapes and what the mixer reads of them
(thesis §3.2.1, §4.2.3, Fig 4.2; docs/model.md, "Waveforms").

- :class:`AbstractWaveform` (a waveform's parameters), :data:`SHAPES` (shape name -> its class:
  a new waveform is one class there);
- :func:`waveform` (samples of one period), :func:`waveform_mean` (its mean),
  :func:`fourier_coefficients` (its complex Fourier series), :func:`phase_steps` (the N phase
  images' reference delays, rad).
"""

from ._params import AbstractWaveform
from ._waveforms import SHAPES, fourier_coefficients, phase_steps, waveform, waveform_mean

__all__ = ["SHAPES", "AbstractWaveform", "fourier_coefficients", "phase_steps", "waveform", "waveform_mean"]
