"""The camera's factory calibration of its systematic depth error (docs/model.md, "The camera's
processing").

A ToF camera's raw phase errs in two ways it can measure once and correct ever after: *wiggling*, the
periodic error of waveforms that are not sinusoids (the correlation's harmonics at k = 1 + n N alias
onto the fundamental, thesis §5.3), and *offset*, the delays of its drivers, illumination and cables
(``pixel.phase_offset_rad``, and each pixel's own, ``PixelPattern.phase_offset_rad``). A factory
calibration measures the phase against known distances at stated conditions (its ``temperature_c``)
and stores the correction; :class:`Calibration` is that correction.

The measured phase of a noise-free pixel is phi_m = W(psi), with psi = 2 pi (2 f d / c + delta) the
true phase plus the offset delta, and W(psi) = arg sum_j (2 a_j(psi) - 1) exp(i theta_j) the
demodulation of the mixer's correlation a_j (:mod:`tofjax._correlation`; the signal and the
background scale or cancel out of the argument). The calibration inverts W and removes the offset it
saw at its temperature: phi_c = W^-1(phi_m) - 2 pi delta(T_cal), tabulated once per camera on
:data:`TABLE_POINTS` phases (W is evaluated on a regular grid of psi, and the error e = W(psi) - psi is
interpolated as a function of phi_m: linear interpolation of a smooth periodic error, below 1e-5 of
its amplitude). The moments of the corrected phase are the correction averaged over the phase's
noise, taken as Gaussian: E[c(phi + x)] and its variance by Gauss-Hermite quadrature
(:data:`QUADRATURE_NODES` nodes; to first order, the noise passes with the inverse map's slope
1 / W'(psi), which the quadrature reproduces, and the mean moves with the map's curvature where the
correlation is far from a sinusoid).

What remains is what such a calibration cannot remove: the phase drift with the sensor's temperature
away from T_cal (``pixel.phase_drift_rad_per_c``), errors that depend on the signal (the ADC's offset
for two phases, its integral non-linearity, the readout's compression, the limits), multipath and
mixed pixels, and another camera's light.
"""

from __future__ import annotations

import math

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from ._depth import phase_weights
from ._processing import AbstractProcessing, wrap_phase
from ._stages import Moments, Samples, replace

#: Points of the calibration's table over one period.
TABLE_POINTS = 1024
#: Gauss-Hermite nodes of the corrected phase's moments.
QUADRATURE_NODES = 16


class Calibration(AbstractProcessing):
    """A factory calibration of wiggling and offset (module docstring).

    **Fields:** ``temperature_c`` (the sensor's temperature during the calibration, degC: the phase
    drift away from it remains), ``per_pixel`` (static: each pixel's own phase offset calibrated
    too, as cameras calibrate their fixed-pattern phase noise; ``False``: the camera's global offset
    only); bound when the chain is built: ``measured`` (W on the table's grid, rad), ``error``
    (W(psi) - psi there, rad), ``offset_rad`` (2 pi delta(T_cal), each pixel's where per pixel)."""

    temperature_c: Float[Array, ""] | float = 25.0
    per_pixel: bool = eqx.field(static=True, default=True)
    measured: Array | None = None
    error: Array | None = None
    offset_rad: Array | None = None

    def bind(self, params, correlation, sample) -> Calibration:
        n = correlation.n_phases
        psi = jnp.arange(TABLE_POINTS, dtype=jnp.result_type(params.pixel.v_reset_v)) * (2.0 * jnp.pi / TABLE_POINTS)
        a = correlation(psi / (2.0 * jnp.pi))  # (points, phases)
        cos, sin = phase_weights(n)
        z_re = jnp.sum((2.0 * a - 1.0) * jnp.asarray(cos)[None, :], axis=-1)
        z_im = jnp.sum((2.0 * a - 1.0) * jnp.asarray(sin)[None, :], axis=-1)
        measured = jnp.mod(jnp.arctan2(z_im, z_re), 2.0 * jnp.pi)
        error = wrap_phase(measured - psi)
        pixel = params.pixel
        offset = pixel.phase_offset_rad + pixel.phase_drift_rad_per_c * (
            jnp.asarray(self.temperature_c, dtype=psi.dtype) - pixel.dark_reference_temperature_c)
        if self.per_pixel and sample is not None:
            offset = offset + jnp.asarray(sample.phase_offset_rad)
        return Calibration(self.temperature_c, self.per_pixel, measured, error, offset)

    @property
    def pixelwise(self) -> bool:
        return self.offset_rad is not None and self.offset_rad.ndim > 0

    def _error(self, phase: Array) -> Array:
        return jnp.interp(jnp.mod(phase, 2.0 * jnp.pi), self.measured, self.error, period=2.0 * jnp.pi)

    def _offset(self, phase: Array) -> Array:
        """The offset against ``phase``: a frame's per-pixel offsets ``(rows, cols)`` broadcast over its
        frames, or flattened like its points."""
        off = self.offset_rad
        if off.ndim == 0:
            return off
        if phase.shape[-off.ndim:] != off.shape:
            off = off.reshape(-1)
        return off.reshape((1,) * (phase.ndim - off.ndim) + off.shape)

    def corrected(self, phase: Array) -> Array:
        """The calibrated phase in (-pi, pi] of measured ``phase`` (module docstring)."""
        return wrap_phase(phase - self._error(phase) - self._offset(phase))

    def reference(self, phase: Array) -> Array:
        return self.corrected(phase)

    def sample(self, s: Samples) -> Samples:
        return replace(s, phase=self.corrected(s.phase))

    def moments(self, m: Moments) -> Moments:
        centre = self.corrected(m.phase)
        sd = jnp.sqrt(jnp.maximum(m.var_phase, 0.0))
        x, w = np.polynomial.hermite.hermgauss(QUADRATURE_NODES)
        shape = (-1,) + (1,) * sd.ndim  # the nodes on a leading axis
        dev = wrap_phase(self.corrected(m.phase[None] + jnp.asarray(math.sqrt(2.0) * x).reshape(shape) * sd[None])
                         - centre[None])
        weights = jnp.asarray(w / math.sqrt(math.pi)).reshape(shape)
        mean, var = jnp.sum(weights * dev, axis=0), jnp.sum(weights * dev * dev, axis=0)
        var = jnp.maximum(var - mean * mean, 0.0)
        ratio = var / jnp.where(m.var_phase > 0, m.var_phase, 1.0)
        return replace(m, phase=jnp.mod(centre + mean, 2.0 * jnp.pi), var_phase=var, v_first=ratio * m.v_first)
