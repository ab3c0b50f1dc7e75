"""Parameter pytrees, grouped as thesis §4.2.1.

Every physical float is a float64 array leaf (so ``jax.grad`` reaches it and a new value does not
recompile); every choice (waveform shape, number of phases, enable switches, background lamp, ADC
resolution) is a static field, so the modules work under plain ``jax.jit`` as well as
``equinox.filter_jit``. Field names, units and defaults are those of the TOML configuration
(:mod:`tofjax._schema`), and concrete values are range-checked when a module is built.
"""

from __future__ import annotations

import dataclasses

import equinox as eqx
import jax.numpy as jnp
from jaxtyping import Array, Float

from . import _constants as const
from ._schema import KEY_BY_DOTTED, check_array, check_less, check_quantum_efficiency, coerce

Scalar = Float[Array, ""]


def _f64(x) -> Array:
    return jnp.asarray(x, dtype=float)


def _default(dotted: str):
    value = KEY_BY_DOTTED[dotted].default
    return tuple(value) if isinstance(value, list) else value


def _float(section: str, name: str):
    """A traced float field whose default comes from the schema."""
    return eqx.field(converter=_f64, default=_default(f"{section}.{name}"))


def _static(section: str, name: str):
    return eqx.field(static=True, default=_default(f"{section}.{name}"))


def _check(module: eqx.Module, section: str) -> None:
    """Range-check every schema field of ``module`` (concrete values only)."""
    for f in dataclasses.fields(module):
        dotted = f"{section}.{f.name}"
        if dotted not in KEY_BY_DOTTED:
            continue
        value = getattr(module, f.name)
        if f.metadata.get("static", False):
            try:
                coerce(KEY_BY_DOTTED[dotted], value)
            except ValueError as err:
                raise ValueError(str(err)) from None
        else:
            check_array(section, f.name, value)


class PhysicalConstants(eqx.Module):
    """Physical constants, thesis Table 4.1 (exact SI values, see :mod:`tofjax._constants`)."""

    boltzmann_j_per_k: Scalar = eqx.field(converter=_f64, default=const.BOLTZMANN_J_PER_K)
    elementary_charge_c: Scalar = eqx.field(converter=_f64, default=const.ELEMENTARY_CHARGE_C)
    speed_of_light_m_per_s: Scalar = eqx.field(converter=_f64, default=const.SPEED_OF_LIGHT_M_PER_S)
    planck_j_s: Scalar = eqx.field(converter=_f64, default=const.PLANCK_J_S)
    luminous_efficacy_lm_per_w: Scalar = eqx.field(converter=_f64, default=const.LUMINOUS_EFFICACY_LM_PER_W)


class Illumination(eqx.Module):
    """The illumination unit, thesis Table 4.2.

    **Fields:**
    - ``peak_power_w``: peak radiant flux (emitted when the waveform is 1), W.
    - ``wavelength_m``: emission wavelength, m.
    - ``fov_deg``: field of view, degrees: shape ``()`` = diagonal FoV onto a circular spot;
      shape ``(2,)`` = [horizontal, vertical] onto a rectangular spot (§3.1.1).
    """

    peak_power_w: Scalar = _float("illumination", "peak_power_w")
    wavelength_m: Scalar = _float("illumination", "wavelength_m")
    fov_deg: Float[Array, "*fov"] = _float("illumination", "fov_deg")

    def __check_init__(self):
        _check(self, "illumination")


class Scene(eqx.Module):
    """The scene, thesis Table 4.3: target, background light and the nominal operating point.

    ``background`` is the lamp whose illuminance is ``illuminance_lx`` (the swept one);
    ``extra_backgrounds`` are further sources at the constant illuminances ``extra_illuminances_lx``
    (a mixture: the photon irradiances add).

    ``distance_m``, ``illuminance_lx`` and ``integration_time_s`` are the nominal values; a
    :class:`tofjax.Sweep` replaces one of them by its sample values.
    """

    reflectivity: Scalar = _float("scene", "reflectivity")
    background: str = _static("scene", "background")
    extra_backgrounds: tuple[str, ...] = eqx.field(static=True, converter=tuple,
                                                   default=_default("scene.extra_backgrounds"))
    extra_illuminances_lx: Float[Array, " extra"] = _float("scene", "extra_illuminances_lx")
    filter_half_width_m: Scalar = _float("scene", "filter_half_width_m")
    distance_m: Scalar = _float("scene", "distance_m")
    illuminance_lx: Scalar = _float("scene", "illuminance_lx")
    integration_time_s: Scalar = _float("scene", "integration_time_s")

    def __check_init__(self):
        _check(self, "scene")
        if len(self.extra_backgrounds) != self.extra_illuminances_lx.size:
            raise ValueError(f"scene.extra_backgrounds = {list(self.extra_backgrounds)!r} and "
                             f"scene.extra_illuminances_lx (size {self.extra_illuminances_lx.size}) must have one "
                             "illuminance per source")


class Optics(eqx.Module):
    """The camera's optics: lens, field of view and the pixel array's geometry, thesis Table 4.4 (the
    ``[camera]`` section; :class:`tofjax.Camera` is the whole camera).

    ``pixel_pitch_m`` and ``optical_area_m`` are [x, y]; ``fov_deg`` is a diagonal FoV (shape
    ``()``) or [horizontal, vertical] (shape ``(2,)``); the lens uses the diagonal (§4.3).
    """

    k_lens: Scalar = _float("camera", "k_lens")
    f_number: Scalar = _float("camera", "f_number")
    fov_deg: Float[Array, "*fov"] = _float("camera", "fov_deg")
    pixel_pitch_m: Float[Array, "2"] = _float("camera", "pixel_pitch_m")
    optical_area_m: Float[Array, "2"] = _float("camera", "optical_area_m")
    fill_factor: Scalar = _float("camera", "fill_factor")

    def __check_init__(self):
        _check(self, "camera")


class Pixel(eqx.Module):
    """The 2-tap PMD pixel, thesis Table 4.5.

    The integration capacitance of a tap is ``c_diode_f + c_sample_and_hold_f`` (14 fF by default,
    the value of the thesis' kTC example, §4.2.12).
    """

    photo_responsivity_a_per_w: Scalar = _float("pixel", "photo_responsivity_a_per_w")
    collection_depth_m: Scalar = _float("pixel", "collection_depth_m")
    demodulation_contrast: Scalar = _float("pixel", "demodulation_contrast")
    c_diode_f: Scalar = _float("pixel", "c_diode_f")
    c_sample_and_hold_f: Scalar = _float("pixel", "c_sample_and_hold_f")
    n_phases: int = _static("pixel", "n_phases")
    v_reset_v: Scalar = _float("pixel", "v_reset_v")
    v_saturated_v: Scalar = _float("pixel", "v_saturated_v")
    temperature_c: Scalar = _float("pixel", "temperature_c")
    dark_slope_mean_v_per_s: Scalar = _float("pixel", "dark_slope_mean_v_per_s")
    dark_slope_sigma_v_per_s: Scalar = _float("pixel", "dark_slope_sigma_v_per_s")
    dark_reference_temperature_c: Scalar = _float("pixel", "dark_reference_temperature_c")
    dark_doubling_temperature_c: Scalar = _float("pixel", "dark_doubling_temperature_c")
    phase_offset_rad: Scalar = _float("pixel", "phase_offset_rad")
    phase_drift_rad_per_c: Scalar = _float("pixel", "phase_drift_rad_per_c")
    readout_noise_e: Scalar = _float("pixel", "readout_noise_e")
    readout_nonlinearity: Scalar = _float("pixel", "readout_nonlinearity")
    full_well_e: Scalar = _float("pixel", "full_well_e")
    sbi: bool = _static("pixel", "sbi")
    noise: bool = _static("pixel", "noise")

    def __check_init__(self):
        _check(self, "pixel")
        check_less("pixel.v_saturated_v", self.v_saturated_v, "pixel.v_reset_v", self.v_reset_v)

    @property
    def integration_capacitance_f(self) -> Array:
        """C_integration = C_diode + C_sample&hold of one tap, F."""
        return self.c_diode_f + self.c_sample_and_hold_f



class AbstractWaveform(eqx.Module):
    """A periodic waveform of peak 1 on one period (thesis §3.2.1, §4.2.3, Fig 4.2)."""

    shape: eqx.AbstractVar[str]
    duty_cycle: eqx.AbstractVar[Array]
    gauss_order: eqx.AbstractVar[int]
    fourier_order: eqx.AbstractVar[int]


class IlluminationWaveform(AbstractWaveform):
    """The emitted waveform and the modulation frequency, thesis Table 4.6."""

    shape: str = _static("illumination_waveform", "shape")
    duty_cycle: Scalar = _float("illumination_waveform", "duty_cycle")
    gauss_order: int = _static("illumination_waveform", "gauss_order")
    fourier_order: int = _static("illumination_waveform", "fourier_order")
    modulation_frequency_hz: Scalar = _float("illumination_waveform", "modulation_frequency_hz")

    def __check_init__(self):
        _check(self, "illumination_waveform")


class ReferenceWaveform(AbstractWaveform):
    """The pixel's demodulation (reference) waveform, thesis Table 4.7."""

    shape: str = _static("reference_waveform", "shape")
    duty_cycle: Scalar = _float("reference_waveform", "duty_cycle")
    gauss_order: int = _static("reference_waveform", "gauss_order")
    fourier_order: int = _static("reference_waveform", "fourier_order")

    def __check_init__(self):
        _check(self, "reference_waveform")


class ADC(eqx.Module):
    """The analogue-to-digital converter, thesis Table 4.8 (§3.3.1, §4.2.15)."""

    enabled: bool = _static("adc", "enabled")
    v_ref_pos_v: Scalar = _float("adc", "v_ref_pos_v")
    v_ref_neg_v: Scalar = _float("adc", "v_ref_neg_v")
    resolution_bits: int = _static("adc", "resolution_bits")
    offset_error_lsb: Scalar = _float("adc", "offset_error_lsb")
    gain_error_percent_fsr: Scalar = _float("adc", "gain_error_percent_fsr")
    integral_nonlinearity_lsb: Scalar = _float("adc", "integral_nonlinearity_lsb")
    differential_nonlinearity_lsb: Scalar = _float("adc", "differential_nonlinearity_lsb")

    def __check_init__(self):
        _check(self, "adc")
        check_less("adc.v_ref_neg_v", self.v_ref_neg_v, "adc.v_ref_pos_v", self.v_ref_pos_v)

    @property
    def v_ref_v(self) -> Array:
        """V_ref = VrefPos - VrefNeg, half the full-scale range (Eq 3.32)."""
        return self.v_ref_pos_v - self.v_ref_neg_v

    @property
    def lsb_v(self) -> Array:
        """q = FSR / 2^N with FSR = 2 V_ref (Eqs 3.33-3.34), V."""
        return 2.0 * self.v_ref_v / 2.0**self.resolution_bits


class Timing(eqx.Module):
    """How a frame's phase images follow each other in time (the ``[timing]`` section; docs/model.md,
    "Frame timing and eye safety"): each phase image's readout time and the frame rate (0: as fast
    as they allow). :attr:`tofjax.Camera.timing` makes a frame's timing of them."""

    readout_time_s: Scalar = _float("timing", "readout_time_s")
    frame_rate_hz: Scalar = _float("timing", "frame_rate_hz")

    def __check_init__(self):
        _check(self, "timing")


class Interference(eqx.Module):
    """Another camera's illumination in the scene (the ``[interference]`` section; docs/model.md,
    "Interference"): ``enabled`` (static), its peak power, position, frequency offset, phase and duty."""

    enabled: bool = _static("interference", "enabled")
    peak_power_w: Scalar = _float("interference", "peak_power_w")
    baseline_m: Float[Array, "2"] = _float("interference", "baseline_m")
    frequency_offset_hz: Scalar = _float("interference", "frequency_offset_hz")
    phase_rad: Scalar = _float("interference", "phase_rad")
    duty: Scalar = _float("interference", "duty")

    def __check_init__(self):
        _check(self, "interference")


class Params(eqx.Module):
    """Every parameter of the camera model, as one pytree.

    ``Params()`` is the default camera (thesis GUI defaults and the verification camera of §5.5.1);
    replace parts with ``eqx.tree_at`` or build from TOML with :func:`tofjax.load_config`.
    """

    illumination: Illumination = eqx.field(default_factory=Illumination)
    scene: Scene = eqx.field(default_factory=Scene)
    camera: Optics = eqx.field(default_factory=Optics)
    pixel: Pixel = eqx.field(default_factory=Pixel)
    illumination_waveform: IlluminationWaveform = eqx.field(default_factory=IlluminationWaveform)
    reference_waveform: ReferenceWaveform = eqx.field(default_factory=ReferenceWaveform)
    adc: ADC = eqx.field(default_factory=ADC)
    timing: Timing = eqx.field(default_factory=Timing)
    interference: Interference = eqx.field(default_factory=Interference)
    constants: PhysicalConstants = eqx.field(default_factory=PhysicalConstants)

    def __check_init__(self):
        check_quantum_efficiency(self.pixel.photo_responsivity_a_per_w, self.illumination.wavelength_m,
                                 self.pixel.collection_depth_m)

    @property
    def unambiguity_range_m(self) -> Array:
        """d_u = c / (2 f_mod), thesis Eq 2.5."""
        return self.constants.speed_of_light_m_per_s / (2.0 * self.illumination_waveform.modulation_frequency_hz)


#: Section name -> parameter module class, for building from the configuration.
SECTION_CLASSES: dict[str, type[eqx.Module]] = {
    "illumination": Illumination,
    "scene": Scene,
    "camera": Optics,
    "pixel": Pixel,
    "illumination_waveform": IlluminationWaveform,
    "reference_waveform": ReferenceWaveform,
    "adc": ADC,
    "timing": Timing,
    "interference": Interference,
}
