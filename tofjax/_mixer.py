"""The centre pixel's exposure: operating points to the expected electrons of each tap in each phase
image (thesis §3.1, §3.2.2, §4.2.2-4.2.9, §4.2.14, Eqs 3.19-3.28).

The centre pixel is the frame's pixel on the optical axis, looking at a wall that faces the camera
at the operating point's distance: one return (:func:`tofjax._returns.axis_return`) through the one
camera equation (:mod:`tofjax._photometry`, with the pixel's etendue on the axis), the same
:class:`~tofjax._charges.Exposure` as a frame's pixel, and its one tap split (Eqs 3.19-3.21: the
demodulation contrast K sorts K N_s by phase, tap A taking the correlation fraction a_j of
:mod:`tofjax._correlation` and tap B the rest; (1 - K) N_s and the background go half to each tap).
Dark electrons are added per tap (§4.2.14). The sweeps take the frame settings' default optics,
the thesis' uniform spot (``illumination_falloff_exponent = 0``) and the illumination at the lens
(no baseline), so they are the thesis' Eq 3.11 (tests/test_optics.py).
"""

from __future__ import annotations

import jax.numpy as jnp
from jaxtyping import Array, Float

from ._charges import Exposure
from ._correlation import Correlation
from ._framegeometry import FrameSettings, pixel_etendue_m2_sr
from ._noise import dark_electrons
from ._params import Params
from ._pattern import PixelPattern
from ._photometry import active_e_per_radiance, background_e_per_reflectivity
from ._returns import axis_return
from ._scene import PixelField


def axis_etendue_m2_sr(params: Params, settings: FrameSettings) -> Array:
    """The etendue of the pixel on the optical axis (field angle 0, image height 0), m^2 sr."""
    one = jnp.ones(())
    return pixel_etendue_m2_sr(params, settings, PixelField(one, 0.0 * one))


def phase_drift_periods(pixel, temperature_c=None) -> Float[Array, "*b"]:
    """The demodulation phase's offset and its drift with the sensor's temperature, in periods:
    (phi_0 + k (T - T_ref)) / 2 pi (``pixel.phase_offset_rad``, ``pixel.phase_drift_rad_per_c`` from
    ``pixel.dark_reference_temperature_c``); it adds to every light's delay, as a pixel's own phase
    offset does (docs/model.md, "Dark current and temperature"). ``temperature_c``: the sensor's
    temperature per operating point (``None``: ``pixel.temperature_c``)."""
    t = pixel.temperature_c if temperature_c is None else temperature_c
    return (pixel.phase_offset_rad + pixel.phase_drift_rad_per_c * (t - pixel.dark_reference_temperature_c)) \
        / (2.0 * jnp.pi)


def expose(params: Params, correlation: Correlation, distance_m: Float[Array, "*b"],
           illuminance_lx: Float[Array, "*b"], integration_time_s: Float[Array, "*b"],
           dark_slopes_v_per_s: tuple[Array, Array] | None = None, sample: PixelPattern | None = None,
           drift: Correlation | None = None, temperature_c: Float[Array, "*b"] | None = None) -> Exposure:
    """What the pixel collects at every operating point (module docstring), before the taps split it
    (:meth:`tofjax._charges.Exposure.charges`, with the same ``temperature_c``).

    ``temperature_c``: the sensor's temperature at each point (a temperature sweep; ``None``:
    ``pixel.temperature_c``): it sets the dark current, the phase drift, and travels with the charges
    to the kTC noise sources (:class:`tofjax._noise.AbstractThermalNoise`).

    ``drift``: the correlation's antiderivative, given when ``interference.enabled``: the interfering
    camera's light is added (:mod:`tofjax._interference`).

    ``dark_slopes_v_per_s``: the taps' own dark slopes (``simulate(..., fixed_pattern=True)``);
    ``sample``: the pixel's own parameters (:class:`tofjax.PixelPattern` of scalars or of the
    sweep's shape), as a frame's pixel has them: its gain on the etendue, its phase offset on the
    delay, its tap asymmetry and dark slopes (its full well is the chain's). ``None``: the mean pixel.
    """
    settings = FrameSettings()  # the thesis' centre pixel: a uniform spot
    consts, reflectivity = params.constants, params.scene.reflectivity
    etendue = axis_etendue_m2_sr(params, settings)
    if sample is not None:
        etendue = etendue * sample.gain
        dark_slopes_v_per_s = (sample.dark_slope_a_v_per_s, sample.dark_slope_b_v_per_s)
    radiance, path_m = axis_return(params.illumination, settings.illumination_falloff_exponent, reflectivity,
                                   distance_m)
    signal = radiance * active_e_per_radiance(params, etendue, integration_time_s)
    background = reflectivity * background_e_per_reflectivity(params, etendue, illuminance_lx, integration_time_s)
    # The reflected phase 2 pi f path / c (Eq 3.22: 4 pi f d / c on the axis) in periods.
    warm = phase_drift_periods(params.pixel, temperature_c)  # the temperature's phase drift, on every light
    delay = params.illumination_waveform.modulation_frequency_hz * path_m / consts.speed_of_light_m_per_s + warm
    if sample is not None:  # the pixel's demodulation phase offset, as a frame's pixel has it
        delay = delay + sample.phase_offset_rad / (2.0 * jnp.pi)
    contrast = params.pixel.demodulation_contrast
    if dark_slopes_v_per_s is None:
        dark_a = dark_b = dark_electrons(params.pixel, integration_time_s, consts, temperature_c=temperature_c)
    else:
        dark_a = dark_electrons(params.pixel, integration_time_s, consts, dark_slopes_v_per_s[0], temperature_c)
        dark_b = dark_electrons(params.pixel, integration_time_s, consts, dark_slopes_v_per_s[1], temperature_c)
    modulated = contrast * signal[..., None] * correlation(delay)
    if drift is not None:  # another camera's light (tofjax._interference)
        from . import _interference as interference

        radiance_i, path_i = interference.axis_return(params, reflectivity, distance_m)
        signal_i = radiance_i * active_e_per_radiance(params, etendue, integration_time_s) \
            * interference.electrons_scale(params)
        delay_i = interference.delay_periods(params, path_i) + warm
        if sample is not None:
            delay_i = delay_i + sample.phase_offset_rad / (2.0 * jnp.pi)
        fractions = interference.averaged_fractions(correlation, drift, delay_i, params.interference.frequency_offset_hz,
                                                    integration_time_s, params.timing.readout_time_s)
        modulated = modulated + contrast * signal_i[..., None] * fractions
        signal = signal + signal_i
    asymmetry = jnp.zeros(()) if sample is None else sample.tap_asymmetry
    return Exposure(modulated, signal, background, contrast, asymmetry, dark_a, dark_b)
