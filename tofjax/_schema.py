"""The configuration schema: one table of every user-facing key.

Each :class:`Key` carries its default, unit, meaning and physically allowed range. The TOML loader,
the commented default file (``tofjax config``), the parameter modules' ``__check_init__`` and the
calibration bounds all read this table, so a range is written down exactly once.

Defaults follow the thesis GUI (Figs 4.8-4.11) and the verification camera of §5.5.1; values the
thesis does not state (wavelength, FoVs, f-number, lens loss, fill factor, sensor area) are the
choices documented in docs/model.md.
"""

from __future__ import annotations

import dataclasses
import difflib
import sys
from collections.abc import Mapping, Sequence
from typing import Any

from ._constants import ELEMENTARY_CHARGE_C, PLANCK_J_S, SPEED_OF_LIGHT_M_PER_S

WAVEFORM_SHAPES = ("sine", "pulse", "fourier", "gauss_extended", "sawtooth", "triangle")
BACKGROUNDS = ("sunlight", "halogen", "incandescent", "fluorescent", "led")
#: How a camera's "exposure" or integration time is counted (docs/model.md, "Exposure definition").
EXPOSURE_DEFINITIONS = ("phase_image", "frequency", "frame")
#: How a multi-frequency camera combines its frequencies' distances (docs/model.md, "Frequency fusion").
FUSIONS = ("inverse_variance", "unambiguity_range", "equal", "highest_frequency", "phase_average")
#: The camera's spatial filters (``processing.spatial_filter``; ``tofjax.processing.SpatialFilter``).
SPATIAL_FILTERS = ("none", "box", "median")


@dataclasses.dataclass(frozen=True)
class SweepAxis:
    """One quantity a sweep varies: the one table of the sweep axes that the configuration, the
    sweeps, the command line, the plots, the reports, the explorer, the sweep files, the calibration
    and the recording read (:data:`SWEEP_AXES`).

    **Fields:** ``name`` (``"distance"``: ``tofjax simulate --sweep``, :class:`tofjax.Sweep`'s
    ``variable``, a sweep file's ``sweep``); ``column`` (``"distance_m"``: the operating point's
    field of :class:`tofjax.Scene`, :class:`tofjax.Sweep` and :class:`tofjax.Result`, and the sweep
    file's column); ``unit`` (SI, of the values everywhere: configuration, files, ``--from``);
    ``label`` (words for axes and tables); ``display_unit`` and ``display_scale`` (what plots and
    tables show: SI value x scale); ``title`` (the thesis GUI's name, §4.3); ``section`` (the
    configuration section of the nominal value: ``scene``, or ``pixel`` for the sensor's
    temperature)."""

    name: str
    column: str
    unit: str
    label: str
    display_unit: str
    display_scale: float
    title: str
    section: str = "scene"

    @property
    def key(self) -> str:
        """The configuration key of the nominal value, ``<section>.<column>`` (its range bounds the sweep)."""
        return f"{self.section}.{self.column}"

    @property
    def range_keys(self) -> tuple[str, str]:
        """The ``[scene]`` keys of the configured sweep's start and end (``distance_from_m``, ...,
        ``temperature_from_c``): the name, ``from``/``to`` and the column's unit suffix."""
        suffix = self.column[len(self.name) + 1:]
        return f"{self.name}_from_{suffix}", f"{self.name}_to_{suffix}"

    @property
    def axis_label(self) -> str:
        """``label [display_unit]``, for plot axes and table heads."""
        return f"{self.label} [{self.display_unit}]"


#: The sweep axes, by name (:class:`SweepAxis`), in the order of the command line's choices.
SWEEP_AXES: dict[str, SweepAxis] = {a.name: a for a in (
    SweepAxis("distance", "distance_m", "m", "distance", "m", 1.0, "Distance"),
    SweepAxis("illuminance", "illuminance_lx", "lx", "background illuminance", "lx", 1.0, "Background light"),
    SweepAxis("integration_time", "integration_time_s", "s", "integration time per phase image", "ms", 1e3,
              "Integration time"),
    SweepAxis("temperature", "temperature_c", "degC", "sensor temperature", "°C", 1.0, "Temperature", "pixel"),
)}
SWEEPS = tuple(SWEEP_AXES)
#: The operating point's columns (every sweep sets all four), in the axes' order.
OPERATING_POINT_COLUMNS = tuple(a.column for a in SWEEP_AXES.values())


class ConfigError(ValueError):
    """An invalid configuration value, key, type or file. The message names the key (or file,
    line and column), the offending value and what is allowed."""


@dataclasses.dataclass(frozen=True)
class Key:
    """One configuration key.

    ``kind`` is one of ``float``, ``int``, ``bool``, ``choice``, ``pair`` (two floats, x/y) and
    ``angle`` (a float, or two floats [horizontal, vertical]). Ranges apply to every element;
    ``lo_open``/``hi_open`` make a bound exclusive.
    """

    section: str
    name: str
    kind: str
    default: Any
    unit: str
    doc: str
    lo: float | None = None
    hi: float | None = None
    lo_open: bool = False
    hi_open: bool = False
    choices: tuple[str, ...] = ()

    @property
    def dotted(self) -> str:
        return f"{self.section}.{self.name}"

    def range_text(self) -> str:
        """Human-readable allowed range, e.g. ``0 < value <= 1``."""
        if self.kind == "bool":
            return "true or false"
        if self.kind == "choice":
            return "one of " + ", ".join(f'"{c}"' for c in self.choices)
        parts = []
        if self.lo is not None:
            parts.append(f"{self.lo:g} {'<' if self.lo_open else '<='} ")
        parts.append("value")
        if self.hi is not None:
            parts.append(f" {'<' if self.hi_open else '<='} {self.hi:g}")
        text = "".join(parts)
        if self.kind == "int":
            text = "integer " + text
        elif self.kind == "pair":
            text = "[x, y] with each " + text
        elif self.kind == "angle":
            text = "a number (diagonal, circular) or [horizontal, vertical], each " + text
        elif self.kind == "float_list":
            text = "a list of numbers, each " + text
        elif self.kind == "choice_list":
            return "a list of " + ", ".join(f'"{c}"' for c in self.choices)
        return text


def _k(section, name, kind, default, unit, doc, lo=None, hi=None, lo_open=False, hi_open=False, choices=()):
    return Key(section, name, kind, default, unit, doc, lo, hi, lo_open, hi_open, tuple(choices))


_PITCH_M = 17.5e-6
KEYS: tuple[Key, ...] = (
    # --- [illumination]  thesis Table 4.2
    _k("illumination", "peak_power_w", "float", 1.2, "W",
       "peak optical output power of the illumination (radiant flux at waveform value 1)", 0.0, 1e3, lo_open=True),
    _k("illumination", "wavelength_m", "float", 850e-9, "m",
       "illumination wavelength; centre of the optical band-pass filter", 300e-9, 1.1e-6),
    _k("illumination", "fov_deg", "angle", 75.0, "deg",
       "illumination field of view: a number = diagonal FoV onto a circular spot, [h, v] = rectangular spot",
       0.0, 180.0, lo_open=True, hi_open=True),
    # --- [scene]  thesis Table 4.3
    _k("scene", "reflectivity", "float", 0.9, "1", "Lambertian reflectivity of the target", 0.0, 1.0),
    _k("scene", "background", "choice", "sunlight", "-",
       "background light spectrum (led = white phosphor LED, CIE LED-B3)", choices=BACKGROUNDS),
    _k("scene", "extra_backgrounds", "choice_list", [], "-",
       "further background sources at constant illuminance (a mixture, e.g. [\"led\"] room light beside "
       "sunlight through a window); empty = one source", choices=BACKGROUNDS),
    _k("scene", "extra_illuminances_lx", "float_list", [], "lx",
       "illuminance on the target of each extra background source (same length as extra_backgrounds)", 0.0, 2e5),
    _k("scene", "filter_half_width_m", "float", 0.0, "m",
       "half width of the rectangular optical band-pass filter around wavelength_m; 0 = no filter", 0.0, 1e-6),
    _k("scene", "distance_m", "float", 1.0, "m", "nominal target distance", 0.0, 1e3, lo_open=True),
    _k("scene", "illuminance_lx", "float", 20.0, "lx", "nominal background illuminance on the target", 0.0, 2e5),
    _k("scene", "integration_time_s", "float", 2e-3, "s",
       "nominal integration (exposure) time, counted as integration_time_per says", 0.0, 1.0, lo_open=True),
    _k("scene", "integration_time_per", "choice", "phase_image", "-",
       "what the integration times count: one phase image (the model's unit), all phase images of one frequency, "
       "or all phase images of all frequencies of a frame", choices=EXPOSURE_DEFINITIONS),
    _k("scene", "distance_from_m", "float", 0.45, "m", "distance sweep start", 0.0, 1e3, lo_open=True),
    _k("scene", "distance_to_m", "float", 4.5, "m", "distance sweep end", 0.0, 1e3, lo_open=True),
    _k("scene", "illuminance_from_lx", "float", 0.0, "lx", "illuminance sweep start", 0.0, 2e5),
    _k("scene", "illuminance_to_lx", "float", 5000.0, "lx", "illuminance sweep end", 0.0, 2e5),
    _k("scene", "integration_time_from_s", "float", 0.2e-3, "s", "integration time sweep start",
       0.0, 1.0, lo_open=True),
    _k("scene", "integration_time_to_s", "float", 5e-3, "s", "integration time sweep end", 0.0, 1.0, lo_open=True),
    _k("scene", "temperature_from_c", "float", 0.0, "degC", "sensor temperature sweep start", -273.15, 200.0,
       lo_open=True),
    _k("scene", "temperature_to_c", "float", 70.0, "degC", "sensor temperature sweep end", -273.15, 200.0,
       lo_open=True),
    _k("scene", "samples", "int", 1000, "1", "number of sweep samples", 1, 1_000_000),
    # --- [camera]  thesis Table 4.4
    _k("camera", "k_lens", "float", 0.9, "1", "transmission of lens and filter (1 = lossless)", 0.0, 1.0, lo_open=True),
    _k("camera", "f_number", "float", 1.4, "1", "lens f-number (focal length / aperture diameter)", 0.5, 64.0),
    _k("camera", "fov_deg", "angle", 75.0, "deg",
       "camera field of view: a number = diagonal, [h, v] = horizontal/vertical (the lens uses the diagonal)",
       0.0, 180.0, lo_open=True, hi_open=True),
    _k("camera", "pixel_pitch_m", "pair", [_PITCH_M, _PITCH_M], "m", "pixel pitch [x, y]", 0.0, 1e-3, lo_open=True),
    _k("camera", "optical_area_m", "pair", [224 * _PITCH_M, 172 * _PITCH_M], "m",
       "dimensions [x, y] of the optically sensitive sensor area (224 x 172 pixels by default)",
       0.0, 0.1, lo_open=True),
    _k("camera", "fill_factor", "float", 1.0, "1", "light-sensitive fraction of the pixel area (with microlenses)",
       0.0, 1.0, lo_open=True),
    # --- [pixel]  thesis Table 4.5
    _k("pixel", "photo_responsivity_a_per_w", "float", 0.23, "A/W",
       "spectral responsivity at wavelength_m (quantum efficiency must stay <= 1)", 0.0, 1.0, lo_open=True),
    _k("pixel", "collection_depth_m", "float", 0.0, "m",
       "the photodiode's collection depth: the background light's photons count with silicon's relative spectral "
       "response for it (absorption of Green 2008), 1 at wavelength_m; 0 = a flat response, the thesis'",
       0.0, 1e-3),
    _k("pixel", "demodulation_contrast", "float", 0.42, "1",
       "fraction of photo-electrons sorted by phase; the rest go equally to both taps", 0.0, 1.0, lo_open=True),
    _k("pixel", "c_diode_f", "float", 7e-15, "F", "photodiode capacitance of one tap", 0.0, 1e-12, lo_open=True),
    _k("pixel", "c_sample_and_hold_f", "float", 7e-15, "F", "sample-and-hold capacitance of one tap",
       0.0, 1e-12, lo_open=True),
    _k("pixel", "n_phases", "int", 4, "1", "number of phase images (2 = 0/90 deg with the taps' complements)", 2, 5),
    _k("pixel", "v_reset_v", "float", 2.9, "V", "reset voltage of each tap", 0.0, 10.0, lo_open=True),
    _k("pixel", "v_saturated_v", "float", 2.0, "V", "saturation voltage = SBI threshold (must be < v_reset_v)",
       0.0, 10.0),
    _k("pixel", "temperature_c", "float", 25.0, "degC", "sensor temperature (kTC noise, dark current)", -273.15,
       200.0, lo_open=True),
    _k("pixel", "dark_slope_mean_v_per_s", "float", 1.4, "V/s", "mean single-ended dark slope of a tap (1.4 mV/ms)",
       0.0, 100.0),
    _k("pixel", "dark_slope_sigma_v_per_s", "float", 1.0, "V/s",
       "pixel-to-pixel (fixed-pattern) sigma of the single-ended dark slope (1 mV/ms)", 0.0, 100.0),
    _k("pixel", "dark_reference_temperature_c", "float", 25.0, "degC",
       "sensor temperature at which the dark slopes above hold, and from which phase_drift_rad_per_c counts",
       -273.15, 200.0, lo_open=True),
    _k("pixel", "dark_doubling_temperature_c", "float", 7.0, "degC",
       "temperature rise that doubles the dark current (5-8 degC for silicon image sensors)", 1.0, 50.0),
    _k("pixel", "phase_offset_rad", "float", 0.0, "rad",
       "offset of the demodulation phase (the drivers', the illumination's and the cables' delays): every "
       "distance reads longer by phi c / (4 pi f), a camera's constant depth offset; 0 = none (fit it to a "
       "measured file's depth_mean_m)", -3.141592653589793, 3.141592653589793),
    _k("pixel", "phase_drift_rad_per_c", "float", 0.0, "rad/degC",
       "temperature coefficient of the demodulation phase (the drivers' and the illumination's delays drift "
       "with temperature): every distance reads longer by k (T - T_ref) c / (4 pi f); 0 = none (unknown: "
       "measure your camera's warm-up)", -1.0, 1.0),
    _k("pixel", "readout_noise_e", "float", 0.0, "e-",
       "readout noise of one tap beyond kTC (source follower, column amplifier, ADC input), rms electrons; "
       "0 = none", 0.0, 1e5),
    _k("pixel", "readout_nonlinearity", "float", 0.0, "1",
       "gain compression of the readout chain: relative gain lost at a differential of one full well, "
       "y = x (1 - k (x / full well)^2); 0 = linear", 0.0, 0.25),
    _k("pixel", "full_well_e", "float", 0.0, "e-",
       "full well of one tap in electrons (a data sheet's value); 0 = from the voltage swing, "
       "(v_reset_v - v_saturated_v) C_int / e", 0.0, 1e8),
    _k("pixel", "sbi", "bool", True, "-", "suppression of background illumination circuit enabled"),
    _k("pixel", "noise", "bool", True, "-", "temporal noise enabled"),
    _k("pixel", "iterations", "int", 2000, "1", "Monte Carlo repetitions (frames) per sweep sample", 1, 10_000_000),
    # --- [illumination_waveform]  thesis Table 4.6
    _k("illumination_waveform", "shape", "choice", "gauss_extended", "-", "emitted waveform", choices=WAVEFORM_SHAPES),
    _k("illumination_waveform", "duty_cycle", "float", 0.25, "1", "on-time fraction of the period",
       0.0, 1.0, lo_open=True),
    _k("illumination_waveform", "gauss_order", "int", 15, "1", "super-Gaussian order of gauss_extended", 1, 100),
    _k("illumination_waveform", "fourier_order", "int", 5, "1", "harmonics in the fourier shape", 1, 200),
    _k("illumination_waveform", "modulation_frequency_hz", "float", 80.32e6, "Hz",
       "modulation frequency; a list [f1, f2, ...] is f1 plus extra_modulation_frequencies_hz", 0.0, 5e9, lo_open=True),
    _k("illumination_waveform", "extra_modulation_frequencies_hz", "float_list", [], "Hz",
       "further frequencies for range extension (e.g. [60.24e6]; empty = one frequency)", 0.0, 5e9, lo_open=True),
    _k("illumination_waveform", "frequency_fusion", "choice", "inverse_variance", "-",
       "how the frequencies' distances are combined into one: inverse_variance (default), unambiguity_range "
       "(weights 1/d_u^2), equal, highest_frequency (the others only unwrap), phase_average (weights 1/d_u: the "
       "mean of the unwrapped phases, libfreenect2's)", choices=FUSIONS),
    # --- [reference_waveform]  thesis Table 4.7
    _k("reference_waveform", "shape", "choice", "gauss_extended", "-", "pixel demodulation (reference) waveform",
       choices=WAVEFORM_SHAPES),
    _k("reference_waveform", "duty_cycle", "float", 0.5, "1", "on-time fraction of the period",
       0.0, 1.0, lo_open=True),
    _k("reference_waveform", "gauss_order", "int", 15, "1", "super-Gaussian order of gauss_extended", 1, 100),
    _k("reference_waveform", "fourier_order", "int", 5, "1", "harmonics in the fourier shape", 1, 200),
    # --- [adc]  thesis Table 4.8 and GUI Fig 4.11
    _k("adc", "enabled", "bool", True, "-", "quantise with the ADC (false: ideal continuous readout in LSB)"),
    _k("adc", "v_ref_pos_v", "float", 1.075, "V", "positive reference voltage", -10.0, 10.0),
    _k("adc", "v_ref_neg_v", "float", 0.275, "V", "negative reference voltage (must be < v_ref_pos_v)", -10.0, 10.0),
    _k("adc", "resolution_bits", "int", 12, "bit", "ADC resolution", 2, 24),
    _k("adc", "offset_error_lsb", "float", 30.0, "LSB", "offset error", -1e4, 1e4),
    _k("adc", "gain_error_percent_fsr", "float", 5.0, "% FSR", "gain error", -50.0, 50.0),
    _k("adc", "integral_nonlinearity_lsb", "float", 10.0, "LSB", "peak integral non-linearity (bow at mid-scale)",
       -1e4, 1e4),
    _k("adc", "differential_nonlinearity_lsb", "float", 0.8, "LSB",
       "peak step-width deviation (< 1: no missing codes)", 0.0, 1.0, hi_open=True),
    # --- [timing]  how a frame's phase images follow each other (docs/model.md "Frame timing and eye safety")
    _k("timing", "readout_time_s", "float", 1e-3, "s",
       "readout time of one phase image: from the end of its integration to the start of the next one (a choice: "
       "unknown for the thesis camera)", 0.0, 1.0),
    _k("timing", "frame_rate_hz", "float", 5.0, "Hz",
       "frames per second (the thesis camera ran at 5, Appendix A); 0 = as fast as the phase images and their "
       "readout allow", 0.0, 1e4),
    # --- [interference]  another camera's illumination in the scene (docs/model.md "Interference"; thesis §6.1.3)
    _k("interference", "enabled", "bool", False, "-",
       "another camera of this model lights the scene too (its light reaches every pixel, sweeps and frames)"),
    _k("interference", "peak_power_w", "float", 1.2, "W", "its peak optical power (same waveform and FoV as this camera's)",
       0.0, 1e3),
    _k("interference", "baseline_m", "pair", [0.1, 0.0], "m",
       "its position [x, y] in this camera's lens plane (x right, y up; its axis parallel to this camera's)",
       -10.0, 10.0),
    _k("interference", "frequency_offset_hz", "float", 0.0, "Hz",
       "its modulation frequency minus this camera's (0: the same frequency, a phase-dependent bias; |offset| x "
       "integration time >> 1: it averages out, adding shot noise)", -1e9, 1e9),
    _k("interference", "phase_rad", "float", 0.0, "rad",
       "its modulation phase relative to this camera's reference at the frame's start", -100.0, 100.0),
    _k("interference", "duty", "float", 1.0, "1",
       "the fraction of this camera's integration during which it emits (its own frame timing, on average)", 0.0,
       1.0),
    # --- [frame]  the whole pixel array (thesis §6.1.1-6.1.2, future work; docs/model.md "Full frames")
    _k("frame", "subpixel_samples", "int", 3, "1",
       "rays per pixel along each axis (s x s sub-pixel samples): a pixel straddling a depth edge mixes both "
       "surfaces (flying pixels)", 1, 16),
    _k("frame", "illumination_falloff_exponent", "float", 0.0, "1",
       "the illumination's irradiance on a plane perpendicular to its axis falls as cos^n of the off-axis angle "
       "inside its FoV (0 = flat top, the thesis' spot); the FoV still holds peak_power_w", 0.0, 50.0),
    _k("frame", "baseline_m", "pair", [0.0, 0.0], "m",
       "position [x, y] of the illumination relative to the lens centre (x right, y up; axes parallel)", -1.0, 1.0),
    _k("frame", "relative_illumination_exponent", "float", 4.0, "1",
       "lens relative illumination cos^n of the field angle (4 = the cos^4 law; 0 = none)", 0.0, 8.0),
    _k("frame", "vignetting", "float", 0.0, "1",
       "fraction of the light lost at the image corner by mechanical vignetting, growing with the squared "
       "image height (0 = none)", 0.0, 1.0, hi_open=True),
    _k("frame", "distortion_k1", "float", 0.0, "1",
       "lens distortion, radial r^2 coefficient (Brown-Conrady, OpenCV's k1: what cv2.calibrateCamera reports; "
       "the rays, depth and points follow it, the intrinsics file carries it)", -100.0, 100.0),
    _k("frame", "distortion_k2", "float", 0.0, "1", "lens distortion, radial r^4 coefficient (OpenCV's k2)",
       -100.0, 100.0),
    _k("frame", "distortion_p1", "float", 0.0, "1",
       "lens distortion, tangential coefficient (OpenCV's p1; OpenCV's image y runs down)", -1.0, 1.0),
    _k("frame", "distortion_p2", "float", 0.0, "1", "lens distortion, tangential coefficient (OpenCV's p2)",
       -1.0, 1.0),
    _k("frame", "distortion_k3", "float", 0.0, "1", "lens distortion, radial r^6 coefficient (OpenCV's k3)",
       -100.0, 100.0),
    _k("frame", "prnu_sigma", "float", 0.01, "1",
       "photo-response non-uniformity: pixel-to-pixel relative sigma of the responsivity (log-normal, mean 1)",
       0.0, 0.5),
    _k("frame", "phase_offset_sigma_rad", "float", 0.0, "rad",
       "fixed-pattern phase offset: pixel-to-pixel sigma of the demodulation phase (0 = none)", 0.0, 1.0),
    _k("frame", "tap_asymmetry_sigma", "float", 0.0, "1",
       "pixel-to-pixel sigma of the taps' gain mismatch e (tap A collects 1 + e, tap B 1 - e of the photo charge)",
       0.0, 0.15),
    _k("frame", "threshold_sigma", "float", 0.0, "1",
       "pixel-to-pixel relative sigma of the SBI threshold and full well", 0.0, 0.15),
    _k("frame", "seed", "int", 0, "1",
       "seed of the fixed-pattern draw: the same seed gives the same camera", 0, 2**31 - 1),
    _k("frame", "max_phase_noise_rad", "float", 0.3, "rad",
       "confidence threshold: a pixel whose expected (analytic) phase noise exceeds this is flagged low signal",
       0.0, 3.15, lo_open=True),
    _k("frame", "min_amplitude_lsb", "float", 0.0, "LSB",
       "confidence threshold: a pixel whose expected amplitude is below this is flagged low amplitude (0 = off)",
       0.0, 1e6),
    _k("frame", "mixed_spread_fraction", "float", 0.01, "1",
       "a pixel whose light comes from distances spread (light-weighted standard deviation) over more than this "
       "fraction of the unambiguity range is flagged mixed: it averages several surfaces (a flying pixel) or multipath",
       0.0, 1.0,
       lo_open=True),
    # --- [processing]  the camera's own depth processing after the demodulation (docs/model.md "The camera's
    # processing"; tofjax.processing), in this order: calibration, spatial filter, temporal average, invalidation
    _k("processing", "calibration", "bool", False, "-",
       "the camera's factory calibration of its systematic error: the wiggling of its waveforms and its phase offset "
       "(each pixel's own, with a pattern) are measured at calibration_temperature_c and removed from every reading; "
       "what remains is the drift away from that temperature, signal-dependent errors and multipath"),
    _k("processing", "calibration_temperature_c", "float", 25.0, "degC",
       "the sensor's temperature during the factory calibration", -273.15, 200.0, lo_open=True),
    _k("processing", "spatial_filter", "choice", "none", "-",
       "the camera's spatial filter of the depth over spatial_filter_size^2 pixels (a sweep's point: the centre of "
       "a uniform patch)", choices=SPATIAL_FILTERS),
    _k("processing", "spatial_filter_size", "int", 3, "1", "side of the spatial filter's neighbourhood (odd)", 3, 7),
    _k("processing", "temporal_average_frames", "int", 1, "1",
       "raw frames the camera averages into each delivered frame (1 = none)", 1, 64),
    _k("processing", "amplitude_threshold", "bool", False, "-",
       "the camera invalidates a frame's pixel whose amplitude is below frame.min_amplitude_lsb (its confidence "
       "threshold, per frame; the low-amplitude flag reads the expected amplitude against the same value)"),
    _k("processing", "flying_pixel_m", "float", 0.0, "m",
       "the camera's flying-pixel filter: a pixel whose depth differs by more than this from flying_pixel_neighbours "
       "of its 8 neighbours is invalidated; 0 = off", 0.0, 10.0),
    _k("processing", "flying_pixel_neighbours", "int", 1, "1",
       "how many of a pixel's 8 neighbours must differ by more than flying_pixel_m", 1, 8),
)

SECTIONS: tuple[str, ...] = tuple(dict.fromkeys(k.section for k in KEYS))
KEY_BY_DOTTED: dict[str, Key] = {k.dotted: k for k in KEYS}


def keys_of(section: str) -> tuple[Key, ...]:
    return tuple(k for k in KEYS if k.section == section)


def suggest(name: str, options) -> str:
    """A ``did you mean`` suffix for an unknown name, or an empty string.

    Ranked by meaning before spelling: the shortest option the name begins (``pixel.demod`` ->
    ``pixel.demodulation_contrast``), then the shortest containing it, then the closest spelling
    (difflib).
    """
    options = [str(o) for o in options]
    low = name.lower()
    if low:
        for hits in ([o for o in options if o.lower().startswith(low)], [o for o in options if len(low) >= 3 and low in o.lower()]):
            if hits:
                return f' (did you mean "{min(hits, key=len)}"?)'
    close = difflib.get_close_matches(name, options, n=1, cutoff=0.6)
    return f' (did you mean "{close[0]}"?)' if close else ""


def _is_tracer(x) -> bool:
    jax = sys.modules.get("jax")  # nothing can be a tracer before JAX is imported
    return jax is not None and isinstance(x, jax.core.Tracer)


def _fmt(value) -> str:
    try:
        import numpy as np

        arr = np.asarray(value)
        if arr.ndim == 0:
            return f"{arr.item()!r}"
        return repr(arr.tolist())
    except Exception:  # pragma: no cover - repr fallback
        return repr(value)


def in_range(key: Key, x):
    """Whether ``x`` lies in ``key``'s allowed range (NaN never does): a bool for a number, a
    boolean array element by element for a NumPy array."""
    ok = x == x  # False for NaN only
    if key.lo is not None:
        ok = ok & ((x > key.lo) if key.lo_open else (x >= key.lo))
    if key.hi is not None:
        ok = ok & ((x < key.hi) if key.hi_open else (x <= key.hi))
    return ok


def coerce(key: Key, value: Any, where: str = "") -> Any:
    """Check the type and range of one value and return it in canonical Python form.

    Raises :class:`ConfigError` naming the key, the value and the allowed range.
    """
    loc = f"{where}: " if where else ""
    bad_type = f"{loc}{key.dotted} = {_fmt(value)} has the wrong type: expected {key.range_text()} [{key.unit}]"
    if key.kind == "bool":
        if not isinstance(value, bool):
            raise ConfigError(bad_type)
        return value
    if key.kind == "choice":
        if not isinstance(value, str):
            raise ConfigError(bad_type)
        if value not in key.choices:
            raise ConfigError(
                f"{loc}{key.dotted} = {value!r} is not allowed: expected {key.range_text()}"
                + suggest(value, key.choices)
            )
        return value
    if key.kind == "int":
        if isinstance(value, bool) or not isinstance(value, int):
            raise ConfigError(bad_type)
        elements = [value]
    elif key.kind == "float":
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise ConfigError(bad_type)
        value = float(value)
        elements = [value]
    elif key.kind == "choice_list":
        if not isinstance(value, (list, tuple)) or not all(isinstance(v, str) for v in value):
            raise ConfigError(bad_type)
        for v in value:
            if v not in key.choices:
                raise ConfigError(f"{loc}{key.dotted} = {_fmt(list(value))}: {v!r} is not allowed: expected "
                                  f"{key.range_text()}" + suggest(v, key.choices))
        return list(value)
    elif key.kind == "float_list":
        if not isinstance(value, (list, tuple)) or not all(
                isinstance(v, (int, float)) and not isinstance(v, bool) for v in value):
            raise ConfigError(bad_type)
        value = [float(v) for v in value]
        elements = value
    else:  # pair / angle
        if key.kind == "angle" and isinstance(value, (int, float)) and not isinstance(value, bool):
            value = float(value)
            elements = [value]
        elif (
            isinstance(value, Sequence)
            and not isinstance(value, str)
            and len(value) == 2
            and all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in value)
        ):
            value = [float(v) for v in value]
            elements = value
        else:
            raise ConfigError(bad_type)
    for x in elements:
        if not in_range(key, x):
            raise ConfigError(
                f"{loc}{key.dotted} = {_fmt(value)} is out of range: allowed {key.range_text()} [{key.unit}]"
            )
    return value


def check_array(section: str, name: str, value) -> None:
    """Range-check a (possibly array-valued) parameter leaf when it is concrete.

    Used by the parameter modules' ``__check_init__``; traced values (inside ``jit``/``vmap``/
    ``grad``) are skipped, because their values are not known when the module is built.
    """
    if _is_tracer(value):
        return
    import numpy as np

    key = KEY_BY_DOTTED[f"{section}.{name}"]
    arr = np.asarray(value, dtype=float)
    flat = arr.reshape(-1)
    ok = in_range(key, flat)  # every element at once, not a Python loop (docs/model.md, "Performance", measurement 7)
    if not ok.all():
        i = int(np.argmin(ok))  # the first element out of range
        # One value in the message, not the whole array (a sweep may hold a million).
        index = [int(j) for j in np.unravel_index(i, arr.shape)]
        where = "" if arr.ndim == 0 else f" (element {index} of an array of shape {arr.shape})"
        raise ValueError(f"{key.dotted} = {float(flat[i])!r}{where} is out of range: allowed {key.range_text()} "
                         f"[{key.unit}]")


def checked_range(value, what: str, lo: float | None = None, hi: float | None = None, *, lo_open: bool = False,
                  hi_open: bool = False, unit: str = "", allow_inf: bool = False, exempt=None, note: str = ""):
    """``value`` (a number or an array) if every element lies in its range, named ``what`` in the
    message (``"tofjax.scenes.wall: distance_m"``). Concrete values that do not raise ``ValueError``
    at once, naming the first bad element; traced ones (inside the caller's ``jit``, ``vmap`` or
    ``grad``) come back wrapped in ``equinox.error_if``, which raises when the program runs. NaN is
    never in range; ``allow_inf``: +inf is (\"no surface\"). ``exempt(x, xp)``: a mask of the
    elements that mean something else and are not checked (``xp`` is NumPy or ``jax.numpy``; a
    depth map's misses); ``note``: said after the range, in parentheses."""
    import numpy as np

    def bad_of(x, xp):
        ok = xp.isfinite(x)  # finite values within the range, or +inf where allowed
        if lo is not None:
            ok = ok & ((x > lo) if lo_open else (x >= lo))
        if hi is not None:
            ok = ok & ((x < hi) if hi_open else (x <= hi))
        ok = ok | (allow_inf & xp.isposinf(x))
        return ~ok if exempt is None else ~ok & ~exempt(x, xp)

    parts = []
    if lo is not None:
        parts.append(f"{lo:g} {'<' if lo_open else '<='} ")
    parts.append("value")
    if hi is not None:
        parts.append(f" {'<' if hi_open else '<='} {hi:g}")
    allowed = "".join(parts) + (" or inf" if allow_inf else "") + (f" [{unit}]" if unit else "") \
        + (f" ({note})" if note else "")
    if _is_tracer(value):
        import equinox as eqx
        import jax.numpy as jnp

        try:
            return eqx.error_if(value, jnp.any(bad_of(value, jnp)), f"{what} is out of range: allowed {allowed}")
        except TypeError:  # inside jax.shard_map equinox (0.13) cannot build its check: unchecked there
            return value
    arr = np.asarray(value, dtype=float)
    bad = bad_of(arr, np)
    if np.any(bad):
        index = [int(j) for j in np.argwhere(bad)[0]]
        shown = f"{what}{index if arr.ndim else ''} = {float(arr[tuple(index)])!r}"
        raise ValueError(f"{shown} is out of range: allowed {allowed}")
    return value


def check_less(a_name: str, a, b_name: str, b) -> None:
    """Check the cross-key constraint ``a < b`` when both are concrete."""
    if _is_tracer(a) or _is_tracer(b):
        return
    import numpy as np

    if not np.all(np.asarray(a) < np.asarray(b)):
        raise ValueError(f"{a_name} = {_fmt(a)} must be less than {b_name} = {_fmt(b)}")


def check_quantum_efficiency(responsivity, wavelength, collection_depth=0.0) -> None:
    """Responsivity may not exceed the ideal-detector limit e*lambda/(h*c) (quantum efficiency 1,
    thesis Eq 3.16). With a collection depth d > 0 the quantum efficiency elsewhere is QE(lambda_0)
    q(lambda) (``tofjax._background.relative_response``), which stays at most 1 at every wavelength
    only if QE(lambda_0) is at most the fraction 1 - exp(-alpha(lambda_0) d) that depth absorbs
    (q(lambda) reaches 1 / that fraction where silicon absorbs everything within d): the responsivity
    and the collection depth must agree."""
    if _is_tracer(responsivity) or _is_tracer(wavelength) or _is_tracer(collection_depth):
        return
    import numpy as np

    limit = ELEMENTARY_CHARGE_C * np.asarray(wavelength) / (PLANCK_J_S * SPEED_OF_LIGHT_M_PER_S)
    if not np.all(np.asarray(responsivity) <= limit):
        raise ValueError(
            f"pixel.photo_responsivity_a_per_w = {_fmt(responsivity)} implies a quantum efficiency above 1 at "
            f"illumination.wavelength_m = {_fmt(wavelength)}: allowed 0 < value <= {float(np.max(limit)):.4g} A/W"
        )
    depth = np.asarray(collection_depth, dtype=float)
    if np.all(depth == 0.0):
        return
    from ._tables import silicon_absorption_per_m

    table_m, alpha = silicon_absorption_per_m()
    a = np.exp(np.interp(np.asarray(wavelength, dtype=float), table_m, np.log(alpha)))
    absorbed = -np.expm1(-a * depth)
    if not np.all(np.asarray(responsivity) <= limit * absorbed):
        qe = float(np.max(np.asarray(responsivity) / limit))
        raise ValueError(
            f"pixel.photo_responsivity_a_per_w = {_fmt(responsivity)} (quantum efficiency {qe:.3g} at "
            f"illumination.wavelength_m = {_fmt(wavelength)}) is more than pixel.collection_depth_m = {_fmt(collection_depth)} "
            f"absorbs there ({float(np.min(absorbed)):.3g}): the quantum efficiency would exceed 1 at shorter "
            f"wavelengths; allowed 0 < value <= {float(np.min(limit * absorbed)):.4g} A/W, or a deeper collection depth")


def defaults() -> dict[str, dict[str, Any]]:
    """The default configuration as a nested ``{section: {key: value}}`` dict."""
    out: dict[str, dict[str, Any]] = {s: {} for s in SECTIONS}
    for k in KEYS:
        out[k.section][k.name] = list(k.default) if isinstance(k.default, list) else k.default
    return out


def validate(raw: Mapping[str, Any], where: str = "") -> dict[str, dict[str, Any]]:
    """Merge a partial nested mapping over the defaults and validate every value.

    Unknown sections and keys are errors with a did-you-mean suggestion; cross-key constraints
    (v_saturated < v_reset, v_ref_neg < v_ref_pos, sweep start < end, quantum efficiency <= 1) are
    checked on the merged result.
    """
    loc = f"{where}: " if where else ""
    merged = defaults()
    if not isinstance(raw, Mapping):
        raise ConfigError(f"{loc}a configuration must be a table of sections, got {type(raw).__name__}")
    for section, table in raw.items():
        if section not in merged:
            homes = [k.section for k in KEYS if k.name == section]
            if homes and not isinstance(table, Mapping):  # a key written above every section header
                raise ConfigError(f"{loc}key {section} = {_fmt(table)} is outside any section: write it under "
                                  f"[{homes[0]}] ({homes[0]}.{section})")
            raise ConfigError(
                f"{loc}unknown section [{section}]; allowed: "
                + ", ".join(f"[{s}]" for s in SECTIONS)
                + suggest(section, SECTIONS)
            )
        if not isinstance(table, Mapping):
            raise ConfigError(f"{loc}[{section}] must be a table of keys, got {_fmt(table)}")
        names = [k.name for k in keys_of(section)]
        table = dict(table)
        frequencies = table.get("modulation_frequency_hz") if section == "illumination_waveform" else None
        if isinstance(frequencies, list):  # a list of frequencies: the first, plus the extras (range extension)
            if not frequencies:
                raise ConfigError(f"{loc}illumination_waveform.modulation_frequency_hz = [] is empty: give a number "
                                  "or a list of numbers > 0")
            if "extra_modulation_frequencies_hz" in table:
                raise ConfigError(f"{loc}give either a list in illumination_waveform.modulation_frequency_hz or "
                                  "extra_modulation_frequencies_hz, not both")
            table["modulation_frequency_hz"], table["extra_modulation_frequencies_hz"] = frequencies[0], frequencies[1:]
        for name, value in table.items():
            if name not in names:
                raise ConfigError(f"{loc}unknown key {section}.{name}" + suggest(name, names))
            merged[section][name] = coerce(KEY_BY_DOTTED[f"{section}.{name}"], value, where)
    p, a, s = merged["pixel"], merged["adc"], merged["scene"]
    if not p["v_saturated_v"] < p["v_reset_v"]:
        raise ConfigError(
            f"{loc}pixel.v_saturated_v = {p['v_saturated_v']!r} must be less than pixel.v_reset_v = {p['v_reset_v']!r}"
        )
    if not a["v_ref_neg_v"] < a["v_ref_pos_v"]:
        raise ConfigError(
            f"{loc}adc.v_ref_neg_v = {a['v_ref_neg_v']!r} must be less than adc.v_ref_pos_v = {a['v_ref_pos_v']!r}"
        )
    w = merged["illumination_waveform"]
    freqs = [w["modulation_frequency_hz"], *w["extra_modulation_frequencies_hz"]]
    if len(set(freqs)) != len(freqs):
        raise ConfigError(f"{loc}illumination_waveform.extra_modulation_frequencies_hz = "
                          f"{w['extra_modulation_frequencies_hz']!r} repeats a frequency: all must differ")
    if len(s["extra_backgrounds"]) != len(s["extra_illuminances_lx"]):
        raise ConfigError(f"{loc}scene.extra_backgrounds = {s['extra_backgrounds']!r} names "
                          f"{len(s['extra_backgrounds'])} source(s) but scene.extra_illuminances_lx = "
                          f"{s['extra_illuminances_lx']!r} gives {len(s['extra_illuminances_lx'])} illuminance(s): "
                          "give one illuminance per source")
    for axis in SWEEP_AXES.values():
        lo_key, hi_key = axis.range_keys
        lo, hi = s[lo_key], s[hi_key]
        if not lo < hi:
            raise ConfigError(f"{loc}scene.{lo_key} = {lo!r} must be less than scene.{hi_key} = {hi!r}")
    size = merged["processing"]["spatial_filter_size"]
    if size % 2 == 0:
        raise ConfigError(f"{loc}processing.spatial_filter_size = {size!r} is out of range: allowed an odd integer "
                          "3 <= value <= 7")
    try:
        check_quantum_efficiency(p["photo_responsivity_a_per_w"], merged["illumination"]["wavelength_m"],
                                 p["collection_depth_m"])
    except ValueError as err:
        raise ConfigError(f"{loc}{err}") from None
    return merged
