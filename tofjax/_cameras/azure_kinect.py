"""The ``azure-kinect`` preset (:mod:`tofjax._presets`)."""

from .._presets import Preset, quoted

_AZURE = ("Microsoft, 'Azure Kinect DK hardware specifications' (learn.microsoft.com/azure/kinect-dk/hardware-"
          "specification; MicrosoftDocs/azure-docs, articles/kinect-dk/hardware-specification.md, 2020-02-14)")
_AZURE_DEPTH = ("Microsoft, 'Azure Kinect DK depth camera' (learn.microsoft.com/azure/kinect-dk/depth-camera; "
                "MicrosoftDocs/azure-docs, articles/kinect-dk/depth-camera.md, 2019-06-26)")

PRESET = Preset(
    name="azure-kinect",
    title="Microsoft Azure Kinect DK depth camera (1-megapixel ToF sensor of ISSCC 2018), NFOV unbinned mode",
    references={"azure": _AZURE, "azure_depth": _AZURE_DEPTH},
    values=quoted({
        "camera.pixel_pitch_m": ([3.5e-6, 3.5e-6], "azure_depth: 'The world's smallest ToF pixel, at 3.5um by "
                                                   "3.5um'"),
        "camera.optical_area_m": ([2.24e-3, 2.016e-3], "azure: 'NFOV unbinned | 640x576' of 3.5 um pixels"),
        "camera.fov_deg": ([75.0, 65.0], "azure: NFOV unbinned, 'FoI 75°x65°'"),
        "illumination.fov_deg": ([75.0, 65.0], "azure: 'Two NIR Laser diodes enabling near and wide field-of-view "
                                               "(FoV) depth modes'; the NFOV one lights the 75°x65° field of "
                                               "interest (tofjax's reading)"),
        "illumination.wavelength_m": (850e-9, "azure: '15% to 95% reflectivity at 850nm' (the reflectivity is "
                                              "stated at the camera's wavelength: tofjax's reading)"),
        "timing.readout_time_s": (1.45e-3, "azure, depth sensor raw timing, NFOV: '9 IR pulses, 125 us pulse "
                                           "width, 8 idle periods, 1450 us idle time, 12.8 ms exposure'"),
        "timing.frame_rate_hz": (30.0, "azure: NFOV unbinned, 'FPS 0, 5, 15, 30'"),
    }),
)
