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

The aperture collects the largest share of the beam it can (:func:`aperture_fraction`): the beam's
radiant intensity integrated over the aperture's cone, placed where it collects most (the thesis'
flat spot is brightest at its rim, cos^-3: just inside it), at most the whole beam (a beam narrower
than the aperture's cone). Not modelled: an extended apparent source (C6 > 1), single-fault
conditions, several emitters, and wavelengths outside 700-1050 nm (reported as not estimated).
"""

from __future__ import annotations

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Bool, Float

from . import _jit
from ._params import Params
from ._returns import _real, _tan_half
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
    estimate); ``c4``; ``aperture_fraction`` (the largest share of the peak power the aperture
    collects, at most 1: :func:`aperture_fraction`);
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


def frame_phase_images(params: Params, n_frequencies: int = 1) -> int:
    """N, a frame's phase images: ``pixel.n_phases`` of each of ``n_frequencies`` frequencies, each
    frequency's in turn (the frame's phase image j is phase j mod n of frequency j // n)."""
    return params.pixel.n_phases * n_frequencies


# frame_timing and eye_safety are compiled, one program each: run eagerly, each of their few dozen
# operations loaded a program of its own from the compilation cache, 0.9 s of every warm `tofjax
# simulate` and `render`, which print them (docs/model.md, "Performance", measurement 30).
@_jit.jit
def frame_timing(params: Params, n_frequencies: int = 1) -> FrameTiming:
    """The :class:`FrameTiming` of ``params`` (``n_frequencies`` modulation frequencies per frame).
    A configured frame rate above the maximum is not clamped: :func:`check_frame_rate` refuses it."""
    n = frame_phase_images(params, n_frequencies)
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


#: Gauss-Legendre nodes of the aperture's integrals (:func:`aperture_fraction`): each integrand is smooth
#: on its interval, so 16 nodes are exact to rounding.
_GL_X, _GL_W = np.polynomial.legendre.leggauss(16)
#: Azimuths of the integral over the aperture's cone (the periodic trapezoid rule: exact to rounding).
_AZIMUTHS = 32


def _nodes(lo, hi) -> tuple[Array, Array]:
    """Gauss-Legendre nodes and weights on ``[lo, hi]`` (arrays of the same leading shape)."""
    half = (0.5 * (hi - lo))[..., None]
    shape = (1,) * (half.ndim - 1) + (-1,)
    x, w = jnp.asarray(_GL_X).reshape(shape), jnp.asarray(_GL_W).reshape(shape)
    return (0.5 * (hi + lo))[..., None] + half * x, half * w


def _radial_power(rho, n):
    """The integral of (1 + r^2)^(-n/2) r dr from 0 to ``rho``: the power per watt within a radius
    ``rho`` of the axis on the plane at 1 m, times S / (2 pi) (:func:`tofjax._returns.footprint_integral`)."""
    u = jnp.log1p(rho * rho)
    m = 1.0 - 0.5 * n
    small = jnp.abs(m) < 1e-8
    m_safe = jnp.where(small, 1.0, m)
    return jnp.where(small, 0.5 * u, jnp.expm1(m_safe * u) / (2.0 * m_safe))


def _field_integrals(fov_deg, n, a) -> tuple[Array, Array]:
    """The integrals of the irradiance cos^n over the field on the plane at 1 m, within the disc of
    radius ``a`` about the axis and over the whole field (S, :func:`tofjax._returns.footprint_integral`).
    Round field: closed form; rectangular: by azimuth over one quarter (symmetry), in pieces on which
    each integrand is smooth. The first never exceeds the second: the same nodes, a smaller integrand."""
    t = _tan_half(fov_deg)
    if fov_deg.shape == ():
        return 2.0 * jnp.pi * _radial_power(jnp.minimum(a, t), n), 2.0 * jnp.pi * _radial_power(t, n)
    corner = jnp.arctan2(t[1], t[0])
    cx, cy = t[0] / a, t[1] / a  # where the disc meets the edges x = t0 and y = t1
    meets_x = jnp.where(cx < 1.0, jnp.arccos(jnp.where(cx < 1.0, cx, 0.0)), 0.0)
    meets_y = jnp.where(cy < 1.0, jnp.arcsin(jnp.where(cy < 1.0, cy, 0.0)), 0.5 * jnp.pi)
    cuts = jnp.stack([0.0 * corner, jnp.clip(meets_x, 0.0, corner), corner,
                      jnp.clip(meets_y, corner, 0.5 * jnp.pi), 0.5 * jnp.pi + 0.0 * corner])
    phi, w = _nodes(cuts[:-1], cuts[1:])
    first = phi < corner  # against x = t0, else y = t1 (a piece of zero length has its nodes at 0)
    edge = jnp.where(first, t[0] / jnp.cos(jnp.where(first, phi, 0.0)), t[1] / jnp.sin(jnp.where(first, 1.0, phi)))
    return 4.0 * jnp.sum(w * _radial_power(jnp.minimum(a, edge), n)), 4.0 * jnp.sum(w * _radial_power(edge, n))


def _cone_integral(n, centre, alpha) -> Array:
    """The integral of cos^(n-3) (the radiant intensity times S, :func:`tofjax._returns.intensity_per_w`)
    over the cone of half-angle ``alpha`` about each unit direction ``centre`` (``(k, 3)``, each cone
    inside the field), ``(k,)``."""
    x, z = centre[:, 0], centre[:, 2]
    e1 = jnp.stack([z, 0.0 * z, -x], axis=-1) / jnp.hypot(z, x)[:, None]  # perpendicular to the centre (z > 0)
    e2 = jnp.cross(centre, e1)
    beta, w = _nodes(jnp.zeros(()), alpha)  # (nodes,)
    phi = jnp.asarray(2.0 * np.pi * np.arange(_AZIMUTHS) / _AZIMUTHS)
    ring = (jnp.cos(phi)[None, :, None] * e1[:, None, :] + jnp.sin(phi)[None, :, None] * e2[:, None, :])  # (k, phi, 3)
    v = (jnp.cos(beta)[None, :, None, None] * centre[:, None, None, :]
         + jnp.sin(beta)[None, :, None, None] * ring[:, None, :, :])  # (k, beta, phi, 3)
    weight = (w * jnp.sin(beta))[:, None] * (2.0 * jnp.pi / _AZIMUTHS)  # (beta, 1)
    tan2 = (v[..., 0] ** 2 + v[..., 1] ** 2) / v[..., 2] ** 2
    return jnp.sum(jnp.exp((1.5 - 0.5 * n) * jnp.log1p(tan2)) * weight[None], axis=(-2, -1))


def aperture_fraction(params: Params, falloff_exponent) -> Float[Array, ""]:
    """The largest share of the peak power the aperture (:data:`APERTURE_DIAMETER_M` at
    :data:`APERTURE_DISTANCE_M` from the source, facing it; a cone of half-angle alpha) collects,
    at most 1 (docs/model.md, "Frame timing and eye safety"): the larger of two placements, each
    integrated over the beam's profile (cos^(n-3) / S per steradian, :func:`tofjax._returns.intensity_per_w`):

    - centred on the axis: the beam's power within alpha of the axis (the whole beam, 1, when the
      beam is narrower than the aperture's cone);
    - at the brightest direction whose cone lies wholly inside the field (the intensity grows towards
      the rim for n < 3: the thesis' flat spot at 75 degrees is twice as bright there as on the
      axis): its intensity integrated over the cone. Towards the corner of a rectangular field, or
      along its wider axis when the narrower one is too narrow for the cone.

    Where the cone straddles the field's edge, neither placement is it: the larger of the two is
    then a lower bound of the largest share, within 0.1 % of it for a cone much smaller than the
    field (a cone shifted out past the edge gains intensity linearly and loses area faster)."""
    ill = params.illumination
    n = _real(falloff_exponent)
    a = 0.5 * APERTURE_DIAMETER_M / APERTURE_DISTANCE_M  # tan alpha
    alpha = jnp.arctan(jnp.asarray(a))
    within, total = _field_integrals(ill.fov_deg, n, a)
    half = jnp.deg2rad(ill.fov_deg) / 2.0
    if ill.fov_deg.shape == ():
        fits = half > alpha
        inner = jnp.where(fits, half - alpha, 0.0)
        centres = jnp.stack([jnp.sin(inner), 0.0 * inner, jnp.cos(inner)])[None]
        valid = fits[None]
    else:
        s, (s0, s1), (c0, c1) = jnp.sin(alpha), jnp.sin(half), jnp.cos(half)
        # The corner: the direction at angle alpha from both edge planes (x = t0 z, y = t1 z), on the sphere.
        qa = c1 * c1 * s0 * s0 + c0 * c0 * s1 * s1 + c0 * c0 * c1 * c1
        qb = -2.0 * s * (c1 * c1 * s0 + c0 * c0 * s1)
        qc = s * s * (c0 * c0 + c1 * c1) - c0 * c0 * c1 * c1
        disc = qb * qb - 4.0 * qa * qc
        z = (-qb + jnp.where(disc > 0.0, jnp.sqrt(jnp.where(disc > 0.0, disc, 1.0)), 0.0)) / (2.0 * qa)
        corner = jnp.stack([(s0 * z - s) / c0, (s1 * z - s) / c1, z])
        corner_ok = (disc > 0.0) & (corner[0] >= 0.0) & (corner[1] >= 0.0) & (half[0] > alpha) & (half[1] > alpha)
        # Along one axis, at angle alpha from that axis' edge, where the other axis' edges leave room.
        along = [jnp.maximum(half[i] - alpha, 0.0) for i in (0, 1)]
        on_x = jnp.stack([jnp.sin(along[0]), 0.0 * s, jnp.cos(along[0])])
        on_y = jnp.stack([0.0 * s, jnp.sin(along[1]), jnp.cos(along[1])])
        x_ok = (half[0] > alpha) & (s1 * jnp.cos(along[0]) >= s)
        y_ok = (half[1] > alpha) & (s0 * jnp.cos(along[1]) >= s)
        valid = jnp.stack([corner_ok, x_ok, y_ok])
        centres = jnp.stack([jnp.where(corner_ok, corner, jnp.array([0.0, 0.0, 1.0])), on_x, on_y])  # unit vectors
    inside = jnp.where(valid, _cone_integral(n, centres, alpha), 0.0)
    return jnp.maximum(within, jnp.max(inside)) / total


@_jit.jit
def eye_safety(params: Params, timing: FrameTiming, falloff_exponent=0.0) -> EyeSafety:
    """The class 1 estimate of the illumination of ``params`` run as ``timing`` (module docstring);
    ``falloff_exponent``: ``frame.illumination_falloff_exponent`` (0: the thesis' flat spot)."""
    wavelength_nm = 1e9 * params.illumination.wavelength_m
    in_band = (params.illumination.wavelength_m >= BAND_M[0]) & (params.illumination.wavelength_m <= BAND_M[1])
    c4 = 10.0 ** (0.002 * (jnp.clip(wavelength_nm, 700.0, 1050.0) - 700.0))
    fraction = aperture_fraction(params, falloff_exponent)
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
    """:func:`describe` of a :class:`tofjax.Camera` at its nominal operating point (what ``simulate``,
    ``render`` and their reports print); ``camera.timing`` refuses a frame rate its phase images do
    not fit (:func:`check_frame_rate`)."""
    timing = camera.timing
    return describe(camera.params, timing, camera.eye_safety)
