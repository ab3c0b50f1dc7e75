"""Optical path: the illumination's spot, the lens, photons and quantum efficiency (thesis §3.1.1,
§3.1.3-3.1.5, §4.2.2, §4.2.5-4.2.8). The camera equation that turns them into electrons is
:mod:`tofjax._photometry` (one photometry for the centre pixel and the frames)."""

from __future__ import annotations

import equinox as eqx
import jax.numpy as jnp
from jaxtyping import Array, Float

from ._params import Illumination, Optics, PhysicalConstants, Pixel


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


class Lens(eqx.Module):
    """Focal length and aperture diameter of the camera lens (§4.2.5), m."""

    focal_length_m: Float[Array, ""]
    diameter_m: Float[Array, ""]


def lens(camera: Optics) -> Lens:
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


def photon_energy_j(wavelength_m: Array, constants: PhysicalConstants) -> Array:
    """E_photon = h c / lambda (Eqs 3.12-3.13)."""
    return constants.planck_j_s * constants.speed_of_light_m_per_s / wavelength_m


def quantum_efficiency(pixel: Pixel, wavelength_m: Array, constants: PhysicalConstants) -> Array:
    """eta = S h c / (e lambda) (Eq 3.16)."""
    return pixel.photo_responsivity_a_per_w * photon_energy_j(wavelength_m, constants) / constants.elementary_charge_c
