"""Another camera's illumination in the scene: interference (issue 36 item 2; thesis §6.1.3, future
work there; docs/model.md, "Interference").

An interfering camera of this model (``[interference]``) lights the scene with its own peak power
from its own position (``baseline_m`` in this camera's lens plane, its axis parallel), modulated at
this camera's frequency plus ``frequency_offset_hz`` with its own phase ``phase_rad`` (relative to
this camera's reference at the frame's start), emitting for the fraction ``duty`` of this camera's
integration (its own frame timing, on average). Its direct light reaches each pixel as returns like
this camera's own, tagged as the interferer's (:attr:`tofjax.Returns.source`); the centre pixel's
wall gets one such return (:func:`axis_return`).

The pixel sorts that light with its own correlation a_j (the same waveforms: a camera of the same
model). At a frequency offset df the light's phase relative to this camera's reference drifts: its
delay in periods is delta(t) = f tau + phase / 2 pi - df t (tau its path's delay). Over phase image
j's integration [t_j, t_j + T] (t_j = j (T + t_ro), :mod:`tofjax._timing`) the tap therefore
collects the average of a_j over the delays the light sweeps, an interval of width w = df T around
delta at the window's centre c_j = t_j + T / 2:

    abar_j = (1/w) int a_j over [delta(c_j) - w/2, delta(c_j) + w/2] = P_0 + (G_j(. + w/2) - G_j(. - w/2)) / w,

G_j the periodic part of a_j's antiderivative (:func:`tofjax._correlation.drift_correlation`); per
harmonic k that is its value at c_j times sinc(pi k df T). With df = 0 it is a_j(delta): the
interferer is one more return, at the delay of its path and phase (a bias that depends on its
phase). With |df| T >> 1 only P_0 is left: its light splits as background light does, adding shot
noise and no bias. Between the two the drift between phase images makes the bias differ from
phase image to phase image.
"""

from __future__ import annotations

import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from ._correlation import Correlation
from ._params import Params
from ._returns import intensity_per_w

#: Below this width of the swept delay (periods) the average is the correlation at the centre (the
#: difference quotient would lose digits; the average differs from the centre value by O(w^2)).
SMALL_SWEEP_PERIODS = 1e-6


def _diagonal(x: Float[Array, "*b phases phases"]) -> Float[Array, "*b phases"]:
    """x[..., j, j]: each phase image's own step of a lookup made at every phase image's delay."""
    return jnp.einsum("...jj->...j", x)


def averaged_fractions(correlation: Correlation, drift: Correlation, delay_periods: Float[Array, "*b"],
                       offset_hz: Float[Array, ""], window_s: Float[Array, "*w"], readout_s: Float[Array, ""]
                       ) -> Float[Array, "*b phases"]:
    """abar_j (module docstring) of light at ``delay_periods`` (f tau + phase / 2 pi at the frame's
    start), ``offset_hz`` df, integration ``window_s`` T (broadcasting with the delays) and readout
    ``readout_s``: the tap-A fraction of each phase image."""
    n = correlation.n_phases
    delay = jnp.asarray(delay_periods)
    t = jnp.asarray(window_s)
    t = t.reshape(t.shape + (1,) * (delay.ndim - t.ndim))  # (*b) against the delays' trailing axes
    j = jnp.arange(n, dtype=float).reshape((1,) * delay.ndim + (n,))
    centres = j * (t + readout_s)[..., None] + 0.5 * t[..., None]  # (*b, phases), s
    at_centre = delay[..., None] - offset_hz * centres  # (*b, phases), periods
    width = (offset_hz * t)[..., None]  # (*b, 1), periods
    small = jnp.abs(width) < SMALL_SWEEP_PERIODS
    half = 0.5 * jnp.where(small, 1.0, width)
    p0 = jnp.real(correlation.coefficients[0])
    swept = p0 + (_diagonal(drift(at_centre + half)) - _diagonal(drift(at_centre - half))) / (2.0 * half)
    return jnp.where(small, _diagonal(correlation(at_centre)), swept)


def electrons_scale(params: Params) -> Float[Array, ""]:
    """The interferer's electrons per electron this camera's own light of the same return would
    make: its peak power over this camera's, times its duty (the same waveform)."""
    i = params.interference
    return i.duty * i.peak_power_w / params.illumination.peak_power_w


def axis_return(params: Params, reflectivity: Array, distance_m: Float[Array, "*b"]) -> tuple[Array, Array]:
    """The interferer's return on the centre pixel's wall at ``distance_m`` (facing the camera): the
    radiance per watt of its peak power, rho I cos(beta) / (pi r^2), and the path r + d, r from the
    interferer to the wall's point on the axis (the thesis' flat spot, as the sweeps take it)."""
    b = params.interference.baseline_m
    d = jnp.asarray(distance_m, dtype=float)
    v = jnp.stack([jnp.broadcast_to(-b[0], d.shape), jnp.broadcast_to(-b[1], d.shape), d], axis=-1)
    r = jnp.sqrt(b[0] ** 2 + b[1] ** 2 + d * d)
    intensity = intensity_per_w(params.illumination, 0.0, v)
    return reflectivity * intensity * (d / r) / (jnp.pi * r * r), r + d


def delay_periods(params: Params, path_m: Array) -> Array:
    """The interferer's light's delay at the frame's start, periods of this camera's modulation: f
    path / c + phase / 2 pi."""
    f = params.illumination_waveform.modulation_frequency_hz
    return f * path_m / params.constants.speed_of_light_m_per_s + params.interference.phase_rad / (2.0 * np.pi)
