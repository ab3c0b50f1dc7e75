"""The camera equation, written once (thesis §3.1, Eqs 3.1-3.18; docs/model.md, "One photometry"):
the electrons a pixel collects in one phase image from the illumination, per unit of a return's
radiance per watt of peak power, and from the background light, per unit reflectivity of what it
sees, through the pixel's etendue (:func:`tofjax.optics.pixel_etendue_m2_sr`).

The centre pixel's sweeps (:func:`tofjax._mixer.expose`: the pixel on the optical axis looking at a
wall) and the frames (:mod:`tofjax._frame`: every pixel, its returns) both expose through these.
The thesis' spot-area form (Eq 3.11: the illumination's flux spread over the spot, the lens'
collection (D / 2d)^2 of the Lambertian reflection of the pixel's footprint) is this equation's
closed form on the axis, tested (tests/test_optics.py), not a second implementation.
"""

from __future__ import annotations

import jax.numpy as jnp
from jaxtyping import Array, Float

from ._background import background_photon_irradiance
from ._optics import photon_energy_j, quantum_efficiency
from ._params import Params
from ._waveforms import waveform_mean


def scene_photon_irradiance(params: Params, illuminance_lx: Float[Array, "*b"]) -> Float[Array, "*b"]:
    """Background photon irradiance on the target inside the filter's band, photons/s/m^2: the swept
    lamp at ``illuminance_lx`` plus the extra sources at theirs (a mixture: photon irradiances add)."""
    scene, ill, consts = params.scene, params.illumination, params.constants
    depth = params.pixel.collection_depth_m
    photon_irr = background_photon_irradiance(scene.background, illuminance_lx, ill.wavelength_m,
                                              scene.filter_half_width_m, consts, depth)
    for k, lamp in enumerate(scene.extra_backgrounds):
        photon_irr = photon_irr + background_photon_irradiance(lamp, scene.extra_illuminances_lx[k], ill.wavelength_m,
                                                               scene.filter_half_width_m, consts, depth)
    return photon_irr


def active_e_per_radiance(params: Params, etendue_m2_sr: Array, integration_time_s: Array) -> Array:
    """Active electrons per phase image per unit of a return's ``radiance_per_w`` (W m^-2 sr^-1 per W
    of peak power): peak power x the waveform's mean (the energy emitted) x the etendue x t /
    (h c / lambda) x QE (Eqs 3.14-3.18)."""
    ill, consts = params.illumination, params.constants
    qe = quantum_efficiency(params.pixel, ill.wavelength_m, consts)
    emitted = ill.peak_power_w * waveform_mean(params.illumination_waveform)
    return emitted * etendue_m2_sr * (integration_time_s / photon_energy_j(ill.wavelength_m, consts) * qe)


def background_e_per_reflectivity(params: Params, etendue_m2_sr: Array, illuminance_lx: Array,
                                  integration_time_s: Array) -> Array:
    """Background electrons per phase image per unit reflectivity of what the pixel sees: the
    background photon irradiance / pi (the radiance of a Lambertian surface of reflectivity 1) x
    the etendue x t x QE (§4.2.4: the background goes through the same optics as the signal)."""
    ill = params.illumination
    qe = quantum_efficiency(params.pixel, ill.wavelength_m, params.constants)
    return scene_photon_irradiance(params, illuminance_lx) / jnp.pi * etendue_m2_sr * integration_time_s * qe
