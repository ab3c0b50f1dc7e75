"""Optics and photometry, public: the helpers behind the camera equation (thesis §3.1, §4.2.2-4.2.8;
docs/model.md, "Optical path", "Background light").

- :func:`lens` (focal length, f-number, field of view of the camera section),
  :func:`spot_area_m2` (the illuminated spot at a distance, Eq 3.11);
- :func:`background_photon_irradiance` and :func:`background_irradiance_w_per_m2` (a lamp
  spectrum's photons and watts per square metre at an illuminance);
- :func:`phase_image_time_s`, :func:`phase_images_per_count` (what ``scene.integration_time_per``
  means for one phase image);
- :func:`frame_shape` (rows, cols), :func:`frame_rays` (each pixel's sub-pixel rays, through the
  lens' distortion), :func:`pixel_etendue_m2_sr` (each pixel's etendue), :func:`intrinsics` (OpenCV's
  camera matrix and distortion coefficients of the frame camera);
- :data:`SPEED_OF_LIGHT_M_PER_S`.
"""

from ._background import background_irradiance_w_per_m2, background_photon_irradiance
from ._constants import SPEED_OF_LIGHT_M_PER_S
from ._exposure import phase_image_time_s, phase_images_per_count
from ._framegeometry import frame_rays, frame_shape, intrinsics, pixel_etendue_m2_sr
from ._optics import lens, spot_area_m2

__all__ = ["SPEED_OF_LIGHT_M_PER_S", "background_irradiance_w_per_m2", "background_photon_irradiance", "frame_rays",
           "frame_shape", "intrinsics", "lens", "phase_image_time_s", "phase_images_per_count", "pixel_etendue_m2_sr", "spot_area_m2"]
