"""Result pytrees of :func:`tofjax.predict` and :func:`tofjax.simulate`."""

from __future__ import annotations

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Bool, Float, Int

from . import _jit
from ._reduce import mean_last

#: Bits of :attr:`Result.caveats` (analytic path): where the closed-form statistics are not what
#: frames would show, and why.
CAVEAT_NEAR_LIMIT = 1
CAVEAT_COARSE_QUANTIZATION = 2
CAVEAT_LOW_SNR = 4
CAVEATS = {
    CAVEAT_NEAR_LIMIT: "near a limit: saturation, the SBI floor or an ADC rail lies within 3 standard deviations of "
                "an expected tap charge or code, so some frames would be clipped or invalid; the analytic "
                "statistics assume none are (run the Monte Carlo there)",
    CAVEAT_COARSE_QUANTIZATION: "coarse quantisation: the noise of a phase image is below 0.5 LSB, too little to dither "
                         "the ADC's staircase; the analytic expected code and quantisation variance assume it is "
                         "dithered (run the Monte Carlo there)",
    CAVEAT_LOW_SNR: "low SNR: the phase noise exceeds 0.5 rad, so the depth wraps around the unambiguity range in "
             "many frames; the depth standard deviation is that of the wrapped (circular) deviation, bounded "
             "by d_u / sqrt(12) (a uniform phase), not a Gaussian width",
}


class NoiseBreakdown(eqx.Module):
    """Electron counts of one phase image (both taps) and the rms noise of each source in the
    differential A - B, per operating point (the photon transfer curve, Figs 5.12, 5.14, 5.17).

    - ``signal_e``, ``background_e``, ``dark_e``: photo-electrons from the illumination and from the
      background light, and dark electrons.
    - ``sources``: source name -> rms electrons (:data:`tofjax.chain.NOISE_SOURCES`: ``reset``, ``hold``,
      ``photon_shot``, ``dark_shot``; also as attributes ``reset_e``, ...).
    - ``read_e``: the read-noise sources (reset, hold and dark shot noise, §5.5.1) in quadrature.
    - ``quantization_e``: rms quantisation error (q / sqrt(12) for an ideal ADC, more with DNL)
      referred to electrons (0 without ADC).
    - ``total_e``: every source and the quantisation in quadrature.
    """

    signal_e: Float[Array, "*b"]
    background_e: Float[Array, "*b"]
    dark_e: Float[Array, "*b"]
    sources: dict[str, Float[Array, "*b"]]
    read_e: Float[Array, "*b"]
    quantization_e: Float[Array, "*b"]
    total_e: Float[Array, "*b"]
    #: The sources' names in the budget's order (a dict pytree comes back sorted from ``jit``).
    source_names: tuple[str, ...] = eqx.field(static=True, default=())

    def source_items(self) -> list[tuple[str, Array]]:
        """(name, rms electrons) of every source, in the budget's order."""
        return [(name, self.sources[name]) for name in self.source_names]

    @property
    def reset_e(self) -> Array:
        """kTC noise of the reset (both taps)."""
        return self.sources["reset"]

    @property
    def hold_e(self) -> Array:
        """kTC noise of the sample-and-hold (both taps)."""
        return self.sources["hold"]

    @property
    def photon_shot_e(self) -> Array:
        """Shot noise of the signal and background electrons."""
        return self.sources["photon_shot"]

    @property
    def dark_shot_e(self) -> Array:
        """Shot noise of the dark electrons."""
        return self.sources["dark_shot"]


class Result(eqx.Module):
    """Everything a sweep produced. Leading axes ``*b``: the operating points (the sweep's shape:
    a 1-D sweep, a 2-D image of distances, ...); ``frames`` = Monte Carlo frames kept per point;
    ``phases`` = phase images.

    The expected (noise-free) chain: ``tap_a_e``/``tap_b_e`` electrons each tap holds after SBI
    and saturation, ``tap_a_v``/``tap_b_v`` their voltages, ``differential_v`` = V_B - V_A (these
    three are computed on access from the held electrons, the taps' reset voltage ``tap_reset_v``
    and their conversion ``electrons_per_volt`` = C_int / e, per call; so are ``intensity_e``, the
    held electrons' mean, and ``snr_db``, from ``noise``),
    ``code_mean`` the expected raw code (Monte Carlo: the mean over all frames). Per frame (Monte
    Carlo with ``keep_frames``, else ``None``): the raw phase images, ``codes`` (the ADC codes of
    the taps' difference) and ``frames_tap_a_e``/``frames_tap_b_e`` (each tap's electrons as read:
    the held charge plus its own noise after the limit; docs/model.md "Raw phase images"), and what
    demodulation makes of them: ``phase_rad``, wrapped ``depth_m``, ``depth_unwrapped_m`` (along a
    1-D sweep), ``amplitude_lsb`` and ``valid``. Statistics: depth
    mean (wrapped and unwrapped) and standard deviation (circular), amplitude mean and standard
    deviation (LSB), SNR (Eq 5.1), and the fractions of frames that are valid, pixel-saturated,
    ADC-saturated and had SBI engaged, and ``full_well_fraction``: the expected charge of the
    fullest tap (before SBI and saturation) over the full well, the headroom to SBI/saturation
    (> 1: SBI engaged or saturated); ``headroom``: how far the expected charges lie from the nearest
    hard limit, as a fraction of its range (the limit stage's headroom over the full well, the ADC's
    distance to its nearer rail over its 2^N codes, the smallest over the phase images): > 0 where
    the hard model measures the expected point, <= 0 where it saturates (the calibration keeps every
    measured point above 0). ``caveats`` (analytic path only): bits of :data:`CAVEATS`
    where the closed form is not what frames would show (0: none). ``wrong_unwrap_fraction``: a
    fused frame of several frequencies' (:mod:`tofjax._multiframe`), else ``None``.

    In the hard mode, statistics of points without two valid frames (analytic: whose expected
    signal saturates) are NaN and flagged by ``valid_fraction``; never reported as 0 m.
    """

    method: str = eqx.field(static=True)
    sweep_variable: str = eqx.field(static=True)
    n_frames: int = eqx.field(static=True)
    sweep_values: Float[Array, "*b"]
    distance_m: Float[Array, "*b"]
    illuminance_lx: Float[Array, "*b"]
    integration_time_s: Float[Array, "*b"]
    temperature_c: Float[Array, "*b"]
    unambiguity_range_m: Float[Array, ""]
    tap_reset_v: Float[Array, ""]
    electrons_per_volt: Float[Array, ""]
    tap_a_e: Float[Array, "*b phases"]
    tap_b_e: Float[Array, "*b phases"]
    code_mean: Float[Array, "*b phases"]
    codes: Float[Array, "*b frames phases"] | None
    phase_rad: Float[Array, "*b frames"] | None
    depth_m: Float[Array, "*b frames"] | None
    depth_unwrapped_m: Float[Array, "*b frames"] | None
    amplitude_lsb: Float[Array, "*b frames"] | None
    valid: Bool[Array, "*b frames"] | None
    depth_mean_m: Float[Array, "*b"]
    depth_unwrapped_mean_m: Float[Array, "*b"]
    depth_std_m: Float[Array, "*b"]
    amplitude_mean_lsb: Float[Array, "*b"]
    amplitude_std_lsb: Float[Array, "*b"]
    noise: NoiseBreakdown
    valid_fraction: Float[Array, "*b"]
    pixel_saturated_fraction: Float[Array, "*b"]
    adc_saturated_fraction: Float[Array, "*b"]
    sbi_active_fraction: Float[Array, "*b"]
    full_well_fraction: Float[Array, "*b"]
    headroom: Float[Array, "*b"]
    caveats: Int[Array, "*b"] | None = None
    frames_tap_a_e: Float[Array, "*b frames phases"] | None = None
    frames_tap_b_e: Float[Array, "*b frames phases"] | None = None
    wrong_unwrap_fraction: Float[Array, "*b"] | None = None

    @property
    def tap_a_v(self) -> Float[Array, "*b phases"]:
        """Tap A's expected voltage, V_A = V_reset - n_A e / C_int (§3.2.4) of its held charge."""
        return _volts(self.tap_reset_v, self.electrons_per_volt, self.tap_a_e)

    @property
    def tap_b_v(self) -> Float[Array, "*b phases"]:
        """Tap B's expected voltage, V_B = V_reset - n_B e / C_int."""
        return _volts(self.tap_reset_v, self.electrons_per_volt, self.tap_b_e)

    @property
    def differential_v(self) -> Float[Array, "*b phases"]:
        """V_B - V_A = (n_A - n_B) e / C_int, the differential the ADC converts."""
        return _differential_v(self.electrons_per_volt, self.tap_a_e, self.tap_b_e)

    @property
    def intensity_e(self) -> Float[Array, "*b"]:
        """The expected electrons a tap holds, (n_A + n_B) / 2 averaged over the phase images (the
        camera's intensity image)."""
        return _intensity_e(self.tap_a_e, self.tap_b_e)

    @property
    def snr_db(self) -> Float[Array, "*b"]:
        """SNR = 20 log10(n_signal / n_total_noise) (Eq 5.1) of :attr:`noise`."""
        return _snr_db(self.noise.signal_e, self.noise.total_e)

    @property
    def relative_depth_std(self) -> Float[Array, "*b"]:
        """Depth standard deviation over the true distance (Figs 5.11b, 5.13, 5.16b)."""
        return _ratio(self.depth_std_m, self.distance_m)

    def caveat_lines(self) -> list[str]:
        """One line per caveat that applies somewhere: how many points, and why (empty: none)."""
        if self.caveats is None:
            return []
        codes = np.asarray(self.caveats).reshape(-1)
        lines = []
        for bit, text in CAVEATS.items():
            count = int(np.sum((codes & bit) != 0))
            if count:
                lines.append(f"{count} of {codes.size} points: {text}")
        return lines

    def caveat_summary(self) -> str:
        """Where the closed form does not hold, as text to print: :meth:`caveat_lines` one per line,
        or one sentence saying that it holds at every point (or, for a Monte Carlo result, that
        caveats are the analytic path's)."""
        lines = self.caveat_lines()
        if lines:
            return "\n".join(lines)
        if self.caveats is None:
            return "no caveats: a Monte Carlo result (caveats are the analytic path's, tj.predict)"
        return "no caveats: the closed form holds at every point"


def _per_call(x: Array, like: Array) -> Array:
    """A per-call scalar of a result (``tap_reset_v``, ...) against its per-point arrays ``like``: with
    trailing unit axes, so that a stacked result's leading axes (a ``vmap`` of calls) line up."""
    x = jnp.asarray(x)
    return x.reshape(x.shape + (1,) * (jnp.ndim(like) - x.ndim))


# The derived fields, computed on access (at 1e5 points, three stored per-phase arrays made
# :func:`tofjax.predict` 2 ms slower; docs/model.md, "Performance", measurement 24), each compiled, one
# program per shape: eagerly, each of their operations loaded or compiled a program of its own (a sweep
# file's columns: about ten; measurement 30). Under a transformation they are traced into the caller's.
@_jit.jit
def _volts(tap_reset_v: Array, electrons_per_volt: Array, held_e: Array) -> Array:
    """Voltages V = V_reset - n e / C_int of held charges ``held_e``."""
    return _per_call(tap_reset_v, held_e) - held_e / _per_call(electrons_per_volt, held_e)


@_jit.jit
def _differential_v(electrons_per_volt: Array, tap_a_e: Array, tap_b_e: Array) -> Array:
    return (tap_a_e - tap_b_e) / _per_call(electrons_per_volt, tap_a_e)


@_jit.jit
def _intensity_e(tap_a_e: Array, tap_b_e: Array) -> Array:
    return 0.5 * mean_last(tap_a_e + tap_b_e)


@_jit.jit
def _snr_db(signal_e: Array, total_e: Array) -> Array:
    return 20.0 * jnp.log10(signal_e / total_e)


@_jit.jit
def _ratio(a: Array, b: Array) -> Array:
    return a / b
