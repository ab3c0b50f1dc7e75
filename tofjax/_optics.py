"""Optical path: probing function, lens, Lambertian scene response, photons and electrons
(thesis §3.1.1, §3.1.3-3.1.5, §4.2.2, §4.2.5-4.2.8)."""

from __future__ import annotations

import equinox as eqx
import jax.numpy as jnp
from jaxtyping import Array, Float

from ._params import Camera, Illumination, Params, PhysicalConstants, Pixel, Scene


def _half_angle_tan(fov_deg: Array) -> Array:
    return jnp.tan(jnp.deg2rad(fov_deg) / 2.0)


def spot_area_m2(illumination: Illumination, distance_m: Float[Array, "*b"]) -> Float[Array, "*b"]:
    """Area A_scene lit by the illumination at ``distance_m`` (Eq 3.1, Table 4.2).

    A scalar FoV is the diagonal of a circular cone: A = pi (d tan(FoV/2))^2. A [h, v] FoV lights
    a rectangle (2 d tan(h/2)) x (2 d tan(v/2)).
    """
    t = _half_angle_tan(illumination.fov_deg)
    if illumination.fov_deg.shape == ():
        return jnp.pi * (t * distance_m) ** 2
    return 4.0 * t[0] * t[1] * distance_m**2


def scene_irradiance_w_per_m2(illumination: Illumination, distance_m: Float[Array, "*b"]) -> Float[Array, "*b"]:
    """Peak irradiance of the illumination on the target, E_eScene = Phi_eIllu / A_scene (Eq 3.2)."""
    return illumination.peak_power_w / spot_area_m2(illumination, distance_m)


class Lens(eqx.Module):
    """Focal length and aperture diameter of the camera lens (§4.2.5), m."""

    focal_length_m: Float[Array, ""]
    diameter_m: Float[Array, ""]


def lens(camera: Camera) -> Lens:
    """Lens from the diagonal FoV, the optical area and the f-number (§4.2.5, Eq 3.10).

    The sensor half-diagonal subtends half the diagonal FoV: f = (diag / 2) / tan(FoV_d / 2). A
    [h, v] camera FoV is turned into its diagonal, tan(FoV_d/2) = hypot(tan(h/2), tan(v/2)),
    because "the lens parameters are always calculated with the diagonal FoV" (§4.3).
    """
    t = _half_angle_tan(camera.fov_deg)
    t_diag = t if camera.fov_deg.shape == () else jnp.hypot(t[0], t[1])
    half_diagonal = 0.5 * jnp.hypot(camera.optical_area_m[0], camera.optical_area_m[1])
    focal = half_diagonal / t_diag
    return Lens(focal_length_m=focal, diameter_m=focal / camera.f_number)


def collection_gain_m2(scene: Scene, camera: Camera, distance_m: Float[Array, "*b"]) -> Float[Array, "*b"]:
    """Flux reaching one pixel per unit irradiance on the target, Phi_ePixel / E_e, m^2 (Eq 3.11).

    A_activeScene = (d / f)^2 A_PixelActive (Eq 3.5) with A_PixelActive = pitch_x pitch_y FF
    (Eq 3.6) is reflected with reflectivity p (Eq 3.7); a Lambertian surface sends the fraction
    (D / 2d)^2 of it into the aperture (Eq 3.8), and the lens transmits k_lens (Eq 3.9). The
    distance cancels: the result is p FF pitch_x pitch_y k_lens / (4 f_number^2).
    """
    geo = lens(camera)
    pixel_active = camera.pixel_pitch_m[0] * camera.pixel_pitch_m[1] * camera.fill_factor  # Eq 3.6
    active_scene = (distance_m / geo.focal_length_m) ** 2 * pixel_active  # Eq 3.5
    into_lens = (geo.diameter_m / (2.0 * distance_m)) ** 2  # Eq 3.8
    return scene.reflectivity * active_scene * into_lens * camera.k_lens  # Eqs 3.7, 3.9


def photon_energy_j(wavelength_m: Array, constants: PhysicalConstants) -> Array:
    """E_photon = h c / lambda (Eqs 3.12-3.13)."""
    return constants.planck_j_s * constants.speed_of_light_m_per_s / wavelength_m


def quantum_efficiency(pixel: Pixel, wavelength_m: Array, constants: PhysicalConstants) -> Array:
    """eta = S h c / (e lambda) (Eq 3.16)."""
    return pixel.photo_responsivity_a_per_w * photon_energy_j(wavelength_m, constants) / constants.elementary_charge_c


def active_electrons(
    params: Params,
    distance_m: Float[Array, "*b"],
    integration_time_s: Float[Array, "*b"],
    mean_power_fraction: Float[Array, ""],
) -> Float[Array, "*b"]:
    """Photo-electrons from the illumination in one phase exposure (both taps together).

    Peak flux on the pixel times the waveform's mean (the energy actually emitted), times the
    integration time, over the photon energy (Eqs 3.14-3.15), times the quantum efficiency
    (Eq 3.18).
    """
    ill = params.illumination
    flux_peak_w = scene_irradiance_w_per_m2(ill, distance_m) * collection_gain_m2(params.scene, params.camera,
                                                                                   distance_m)
    energy_j = flux_peak_w * mean_power_fraction * integration_time_s  # Eq 3.14
    photons = energy_j / photon_energy_j(ill.wavelength_m, params.constants)  # Eq 3.15
    return photons * quantum_efficiency(params.pixel, ill.wavelength_m, params.constants)  # Eq 3.18


def background_electrons(
    params: Params,
    distance_m: Float[Array, "*b"],
    photon_irradiance: Float[Array, "*b"],
    integration_time_s: Float[Array, "*b"],
) -> Float[Array, "*b"]:
    """Photo-electrons from the background light in one phase exposure (both taps together).

    The background photon irradiance on the target goes through the same Lambertian scene
    response as the illumination (§4.2.6 is called twice), then the quantum efficiency (Eq 3.18).
    """
    photons = photon_irradiance * collection_gain_m2(params.scene, params.camera, distance_m) * integration_time_s
    return photons * quantum_efficiency(params.pixel, params.illumination.wavelength_m, params.constants)
