"""A frame in time and the illumination's power over it, and an eye-safety estimate of that
illumination (docs/model.md, "Frame timing and eye safety").

**Timing.** A frame is N = phases x frequencies phase images, each integrating for the phase image
time t (``scene.integration_time_s`` per phase image) and read out for t_ro
(``timing.readout_time_s``) before the next starts. Its exposure runs from the first start to the
last end, N t + (N - 1) t_ro; the frame rate is ``timing.frame_rate_hz``, at most 1 / (N (t +
t_ro)) (0: that maximum). The illumination is lit only while a phase image integrates, modulated
by its waveform: its mean power while lit is P_peak c_0 (c_0 the waveform's mean), its average over
the frame that times the lit fraction N t / T_frame.

**Eye safety: an estimate, not a classification.** The accessible emission against the class 1
limits of IEC 60825-1:2014 (Table 3) for 700-1050 nm, the retinal thermal hazard of a small source
(apparent source alpha <= 1.5 mrad: C6 = 1, T2 = 10 s; the most restrictive case, since a diffuser's
larger apparent source only raises the limit), measured through a 7 mm aperture at 100 mm from the
source (measurement condition 3), time base 100 s:

- correction factor C4 = 10^(0.002 (lambda - 700 nm)) (Table 9; ICNIRP 2013's C_A);
- one pulse of duration t (5 us <= t <= T2): AEL = 7e-4 t^0.75 C4 J; beyond T2 the power limit x t;
- the average power over the time base: AEL = 7e-4 C4 T2^-0.25 W = 3.9e-4 C4 W;
- the modulation (tens of MHz) lies far inside the pulse-grouping time T_i = 5 us, so each phase
  image is one pulse of its integration time (rule 1), and the frame's N phase images are checked
  again as one pulse of the exposure's duration; rule 3's C5 is 1 for a small source (2014 edition).

The aperture collects the illumination's radiant intensity at its brightest direction in the field
(the thesis' flat spot is brightest at its rim, cos^-3) over the aperture's solid angle. Not
modelled: an extended apparent source (C6 > 1), single-fault conditions, several emitters, and
wavelengths outside 700-1050 nm (reported as not estimated).
"""

from __future__ import annotations

import equinox as eqx
import jax
import jax.numpy as jnp
from jaxtyping import Array, Bool, Float

from . import _jit
from ._params import Params
from ._returns import _tan_half, intensity_per_w
from ._waveforms import waveform_mean

#: IEC 60825-1 measurement condition 3: a 7 mm aperture at 100 mm from the source, time base 100 s.
APERTURE_DIAMETER_M = 7e-3
APERTURE_DISTANCE_M = 0.1
TIME_BASE_S = 100.0
#: The small source's T2 (alpha <= alpha_min = 1.5 mrad), s, and the limits' wavelength band, m.
T2_S = 10.0
BAND_M = (700e-9, 1050e-9)


class FrameTiming(eqx.Module):
    """A frame's timing and the illumination's power over it (module docstring).

    **Fields:** ``phase_images`` (static: N per frame); ``phase_image_time_s``; ``readout_time_s``;
    ``exposure_time_s`` (first start to last end); ``frame_rate_hz`` and ``max_frame_rate_hz``;
    ``lit_fraction`` (N t / T_frame); ``peak_power_w``; ``lit_power_w`` (mean while lit);
    ``average_power_w`` (over the frame). Each a scalar, or one per operating point of a sweep of the
    integration time."""

    phase_images: int = eqx.field(static=True)
    phase_image_time_s: Float[Array, "*b"]
    readout_time_s: Float[Array, ""]
    exposure_time_s: Float[Array, "*b"]
    frame_rate_hz: Float[Array, "*b"]
    max_frame_rate_hz: Float[Array, "*b"]
    lit_fraction: Float[Array, "*b"]
    peak_power_w: Float[Array, ""]
    lit_power_w: Float[Array, ""]
    average_power_w: Float[Array, "*b"]

    @property
    def frame_time_s(self) -> Float[Array, "*b"]:
        """1 / frame rate, s."""
        return 1.0 / self.frame_rate_hz


class EyeSafety(eqx.Module):
    """The class 1 estimate of :func:`eye_safety` (module docstring): accessible emissions (AE)
    through the aperture against their limits (AEL).

    **Fields:** ``in_band`` (the wavelength within 700-1050 nm: otherwise the numbers are not an
    estimate); ``c4``; ``aperture_fraction`` (of the peak power, at the brightest direction);
    ``average_w`` / ``average_limit_w`` (the time base's average power); ``pulse_j`` /
    ``pulse_limit_j`` (one phase image); ``burst_j`` / ``burst_limit_j`` (a frame's phase images as one
    pulse)."""

    in_band: Bool[Array, ""]
    c4: Float[Array, ""]
    aperture_fraction: Float[Array, ""]
    average_w: Float[Array, "*b"]
    average_limit_w: Float[Array, ""]
    pulse_j: Float[Array, "*b"]
    pulse_limit_j: Float[Array, "*b"]
    burst_j: Float[Array, "*b"]
    burst_limit_j: Float[Array, "*b"]

    @property
    def ratios(self) -> dict[str, Array]:
        """AE / AEL of each check: ``average`` (rule 2), ``pulse`` and ``burst`` (rule 1)."""
        return {"average": self.average_w / self.average_limit_w, "pulse": self.pulse_j / self.pulse_limit_j,
                "burst": self.burst_j / self.burst_limit_j}

    @property
    def ratio(self) -> Float[Array, "*b"]:
        """The largest AE / AEL: <= 1 meets the class 1 estimate."""
        r = self.ratios
        return jnp.maximum(jnp.maximum(r["average"], r["pulse"]), r["burst"])


# frame_timing and eye_safety are compiled, one program each: run eagerly, each of their few dozen
# operations loaded a program of its own from the compilation cache, 0.9 s of every warm `tofjax
# simulate` and `render`, which print them (docs/model.md, "Performance", measurement 30).
@_jit.jit
def frame_timing(params: Params, n_frequencies: int = 1) -> FrameTiming:
    """The :class:`FrameTiming` of ``params`` (``n_frequencies`` modulation frequencies per frame).
    A configured frame rate above the maximum is not clamped: :func:`check_frame_rate` refuses it."""
    n = params.pixel.n_phases * n_frequencies
    t = params.scene.integration_time_s
    t_ro = params.timing.readout_time_s
    fastest = 1.0 / (n * (t + t_ro))
    rate = jnp.where(params.timing.frame_rate_hz > 0.0, params.timing.frame_rate_hz, fastest)
    lit_fraction = n * t * rate
    peak = params.illumination.peak_power_w
    lit = peak * waveform_mean(params.illumination_waveform)
    return FrameTiming(n, t, t_ro, n * t + (n - 1) * t_ro, rate, fastest, lit_fraction, peak, lit, lit * lit_fraction)


def check_frame_rate(timing: FrameTiming) -> None:
    """``ValueError`` naming ``timing.frame_rate_hz`` when the frame's phase images do not fit in its
    frame time (concrete values; the first operating point that does not)."""
    import numpy as np

    rate, most = np.broadcast_arrays(np.asarray(timing.frame_rate_hz), np.asarray(timing.max_frame_rate_hz))
    bad = np.flatnonzero((rate > most * (1.0 + 1e-12)).ravel())
    if bad.size:
        i = bad[0]
        t = float(np.broadcast_to(np.asarray(timing.phase_image_time_s), rate.shape).ravel()[i])
        raise ValueError(f"timing.frame_rate_hz = {float(rate.ravel()[i]):g} is out of range: {timing.phase_images} "
                         f"phase images of {1e3 * t:.4g} ms, each read out in "
                         f"{1e3 * float(timing.readout_time_s):.4g} ms, allow at most {float(most.ravel()[i]):.4g} Hz "
                         "(0 = that)")


def _pulse_limit_j(t_s, c4):
    """AEL of one pulse of duration t, J: 7e-4 t^0.75 C4 up to T2, the power limit x t beyond."""
    return jnp.where(t_s <= T2_S, 7e-4 * t_s**0.75 * c4, 7e-4 * c4 * T2_S**-0.25 * t_s)


def brightest_intensity_per_w(params: Params, falloff_exponent) -> Float[Array, ""]:
    """The illumination's largest radiant intensity per watt of peak power, W/sr/W: cos^(n-3)(theta) /
    S (:func:`tofjax._returns.intensity_per_w`) is monotonic in tan^2 theta, so its largest value
    is on the axis or at the rim (the corner of a rectangular field)."""
    ill = params.illumination
    t = _tan_half(ill.fov_deg)
    rim = jnp.stack([t, jnp.zeros(()), jnp.ones(())]) if ill.fov_deg.shape == () else jnp.stack([t[0], t[1],
                                                                                                  jnp.ones(())])
    axis = jnp.array([0.0, 0.0, 1.0])
    return jnp.maximum(intensity_per_w(ill, falloff_exponent, axis), intensity_per_w(ill, falloff_exponent, rim))


@_jit.jit
def eye_safety(params: Params, timing: FrameTiming, falloff_exponent=0.0) -> EyeSafety:
    """The class 1 estimate of the illumination of ``params`` run as ``timing`` (module docstring);
    ``falloff_exponent``: ``frame.illumination_falloff_exponent`` (0: the thesis' flat spot)."""
    wavelength_nm = 1e9 * params.illumination.wavelength_m
    in_band = (params.illumination.wavelength_m >= BAND_M[0]) & (params.illumination.wavelength_m <= BAND_M[1])
    c4 = 10.0 ** (0.002 * (jnp.clip(wavelength_nm, 700.0, 1050.0) - 700.0))
    r = 0.5 * APERTURE_DIAMETER_M
    solid_angle = 2.0 * jnp.pi * (1.0 - APERTURE_DISTANCE_M / jnp.hypot(APERTURE_DISTANCE_M, r))
    fraction = brightest_intensity_per_w(params, falloff_exponent) * solid_angle
    lit_w = fraction * timing.lit_power_w
    n = timing.phase_images
    return EyeSafety(in_band, c4, fraction, fraction * timing.average_power_w, 7e-4 * c4 * T2_S**-0.25,
                     lit_w * timing.phase_image_time_s, _pulse_limit_j(timing.phase_image_time_s, c4),
                     lit_w * n * timing.phase_image_time_s, _pulse_limit_j(timing.exposure_time_s, c4))


def describe(params: Params, timing: FrameTiming, safety: EyeSafety) -> list[str]:
    """Two lines for summaries and reports: the frame's timing and power, and the eye-safety estimate
    (concrete scalars: the nominal operating point)."""
    f = {k: float(v) for k, v in (("t", timing.phase_image_time_s), ("ro", timing.readout_time_s),
                                   ("exp", timing.exposure_time_s), ("rate", timing.frame_rate_hz),
                                   ("most", timing.max_frame_rate_hz), ("lit", timing.lit_fraction),
                                   ("peak", timing.peak_power_w), ("on", timing.lit_power_w),
                                   ("avg", timing.average_power_w))}
    lines = [f"frame: {timing.phase_images} phase images of {1e3 * f['t']:.4g} ms, each read out in "
             f"{1e3 * f['ro']:.4g} ms: exposure {1e3 * f['exp']:.4g} ms; {f['rate']:.4g} frames/s (at most "
             f"{f['most']:.4g}); illumination lit {100 * f['lit']:.3g} % of the time: peak {f['peak']:.4g} W, "
             f"{f['on']:.4g} W while lit, {1e3 * f['avg']:.4g} mW average"]
    wavelength_nm = 1e9 * float(params.illumination.wavelength_m)
    if not bool(safety.in_band):
        lines.append(f"eye safety: not estimated: the wavelength {wavelength_nm:.0f} nm is outside the 700-1050 nm "
                     "this estimate covers")
        return lines
    ratios = {k: float(v) for k, v in jax.device_get(safety).ratios.items()}  # NumPy: no program per division
    worst = max(ratios, key=ratios.get)
    what = {"average": "the average power", "pulse": "one phase image", "burst": "a frame's phase images"}[worst]
    verdict = "within" if ratios[worst] <= 1.0 else "ABOVE"
    lines.append(f"eye safety (an estimate against IEC 60825-1:2014 class 1 at {wavelength_nm:.0f} nm, small source, "
                 f"7 mm at 100 mm): {verdict} the limit, {ratios[worst]:.3g} of it for {what} (average "
                 f"{1e3 * float(safety.average_w):.3g} of {1e3 * float(safety.average_limit_w):.3g} mW)")
    return lines


def summary_lines(camera) -> list[str]:
    """:func:`describe` of a :class:`tofjax.Camera` at its nominal operating point, after
    :func:`check_frame_rate` (what ``simulate``, ``render`` and their reports print)."""
    timing = camera.timing
    check_frame_rate(timing)
    return describe(camera.params, timing, camera.eye_safety)
