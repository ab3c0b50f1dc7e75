"""The exposure: operating points to the expected electrons of each tap in each phase image
(thesis §3.1, §3.2.2, §4.2.2-4.2.9, §4.2.14, Eqs 3.19-3.28).

Per phase exposure, the active (illumination) electrons N_s and background electrons N_bg of the
pixel (:mod:`tofjax._optics`, :mod:`tofjax._background`) are split between the taps by the 2-tap
mixer: the demodulation contrast K sorts K N_s by phase, tap A taking the correlation fraction a_j
(:mod:`tofjax._correlation`) and tap B the rest (the pixel dumps no charge, Eq 3.20); the remaining
(1 - K) N_s and the background go half to each tap (Eqs 3.19, 3.21; the background is split, not
counted twice, see docs/model.md). Dark electrons are added per tap (§4.2.14).
"""

from __future__ import annotations

import equinox as eqx
from jaxtyping import Array, Float

from ._background import background_photon_irradiance
from ._charges import TapCharges
from ._correlation import Correlation
from ._noise import dark_electrons
from ._optics import active_electrons, background_electrons
from ._params import Params
from ._waveforms import waveform_mean


@eqx.filter_jit
def split_between_taps(fraction_a: Float[Array, "*b phases"], contrast: Float[Array, ""],
                       active_e: Float[Array, "*b"], background_e: Float[Array, "*b"]):
    """Photo-electrons of taps A and B per phase (Eqs 3.19-3.21): K N_s a_j plus the equally
    distributed (1 - K) N_s / 2 + N_bg / 2, and K N_s (1 - a_j) plus the same."""
    modulated = (contrast * active_e)[..., None]
    equal = (0.5 * (1.0 - contrast) * active_e + 0.5 * background_e)[..., None]
    return modulated * fraction_a + equal, modulated * (1.0 - fraction_a) + equal


def scene_photon_irradiance(params: Params, illuminance_lx: Float[Array, "*b"]) -> Float[Array, "*b"]:
    """Background photon irradiance on the target inside the filter's band, photons/s/m^2: the swept
    lamp at ``illuminance_lx`` plus the extra sources at theirs (a mixture: photon irradiances add)."""
    scene, ill, consts = params.scene, params.illumination, params.constants
    photon_irr = background_photon_irradiance(scene.background, illuminance_lx, ill.wavelength_m,
                                              scene.filter_half_width_m, consts)
    for k, lamp in enumerate(scene.extra_backgrounds):
        photon_irr = photon_irr + background_photon_irradiance(lamp, scene.extra_illuminances_lx[k], ill.wavelength_m,
                                                               scene.filter_half_width_m, consts)
    return photon_irr


def expose(params: Params, correlation: Correlation, distance_m: Float[Array, "*b"],
           illuminance_lx: Float[Array, "*b"], integration_time_s: Float[Array, "*b"],
           dark_slopes_v_per_s: tuple[Array, Array] | None = None) -> TapCharges:
    """Expected tap electrons at every operating point (module docstring).

    ``dark_slopes_v_per_s``: the taps' own dark slopes (a fixed-pattern pixel), else the mean slope.
    """
    consts = params.constants
    active = active_electrons(params, distance_m, integration_time_s, waveform_mean(params.illumination_waveform))
    background = background_electrons(params, distance_m, scene_photon_irradiance(params, illuminance_lx),
                                      integration_time_s)
    # The reflected phase 4 pi f d / c (Eq 3.22) in periods.
    delay = 2.0 * params.illumination_waveform.modulation_frequency_hz * distance_m / consts.speed_of_light_m_per_s
    photo_a, photo_b = split_between_taps(correlation(delay), params.pixel.demodulation_contrast, active, background)
    if dark_slopes_v_per_s is None:
        dark_a = dark_b = dark_electrons(params.pixel, integration_time_s, consts)
    else:
        dark_a = dark_electrons(params.pixel, integration_time_s, consts, dark_slopes_v_per_s[0])
        dark_b = dark_electrons(params.pixel, integration_time_s, consts, dark_slopes_v_per_s[1])
    return TapCharges(photo_a, photo_b, dark_a, dark_b, active, background)
