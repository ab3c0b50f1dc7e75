"""The ``ti-opt8241-cdk`` preset (:mod:`tofjax._presets`)."""

from .._presets import Preset, quoted

_OPT8241 = "Texas Instruments, OPT8241 3D Time-of-Flight Sensor, datasheet SBAS704B (June 2015, revised October 2015)"
_VOXELSDK = ("Texas Instruments, Voxel SDK for the OPT8241-CDK-EVM ('Tintin' CDK; github.com/3dtof/voxelsdk, "
             "TI3DToF/boards/TintinCDK/*.conf): the camera's Short Range profile and its lens calibration")
#: What the OPT8241 datasheet states (the sensor preset, and the CDK camera built on it).
_OPT8241_VALUES = quoted({
    "camera.pixel_pitch_m": ([15e-6, 15e-6], "opt8241 Features: 'Pixel Pitch: 15 um'"),
    "camera.optical_area_m": ([4.8e-3, 3.6e-3], "opt8241 Features: '320 x 240 Array' of 15 um"),
    "camera.fill_factor": (1.0, "opt8241 quotes the pixel's responsivity (fill factor inside it; "
                                "tofjax's reading, docs/model.md)"),
    "pixel.photo_responsivity_a_per_w": (0.35, "opt8241 Features: 'Responsivity: 0.35 A/W at 850 nm'"),
    "illumination.wavelength_m": (850e-9, "opt8241: the wavelength of the quoted responsivity"),
    "pixel.demodulation_contrast": (0.45, "opt8241 Features: 'Demodulation Contrast: 45% at 50 MHz'"),
    "illumination_waveform.modulation_frequency_hz": (
        50e6, "opt8241: the frequency of the quoted contrast (allowed: 'Demodulation Frequency: 10 MHz to "
              "100 MHz')"),
    "adc.resolution_bits": (12, "opt8241 Features: '12-Bit Phase Correlation Data'"),
})

PRESET = Preset(
    name="ti-opt8241-cdk",
    title="Texas Instruments OPT8241-CDK-EVM camera (OPT8241 sensor, TI's lens and Short Range profile)",
    references={"opt8241": _OPT8241, "voxelsdk": _VOXELSDK},
    values=quoted({
        **_OPT8241_VALUES,
        "illumination_waveform.modulation_frequency_hz": (
            299792458.0 / (2 * 4.0), "voxelsdk TintinCDKCameraShortRange.conf: 'unambiguous_range = 4' (m), "
                                     "f = c / (2 x 4 m); the contrast quoted at 50 MHz (opt8241) is kept: a "
                                     "contrast falls with frequency, so it is a floor here"),
        "timing.frame_rate_hz": (60.0, "voxelsdk TintinCDKCameraShortRange.conf: 'frame_rate = 60.00'"),
        "camera.fov_deg": ([69.89, 55.24], "voxelsdk TintinCDKCameraLensOnly.conf: 'fx = 228.973245816', "
                                          "'fy = 229.365392955' (pixels) over 320 x 240 pixels: "
                                          "2 atan(160 / fx), 2 atan(120 / fy)"),
        "frame.distortion_k1": (-0.186367327989, "voxelsdk TintinCDKCameraLensOnly.conf [calib]: "
                                                 "'k1 = -0.186367327989' (OpenCV's coefficients)"),
        "frame.distortion_k2": (0.186886972881, "voxelsdk TintinCDKCameraLensOnly.conf [calib]: 'k2 = 0.186886972881'"),
        "frame.distortion_k3": (-0.0838070075746, "voxelsdk TintinCDKCameraLensOnly.conf [calib]: "
                                                  "'k3 = -0.0838070075746'"),
        "frame.distortion_p1": (0.00128792508541, "voxelsdk TintinCDKCameraLensOnly.conf [calib]: "
                                                  "'p1 = 0.00128792508541'"),
        "frame.distortion_p2": (0.00177329655628, "voxelsdk TintinCDKCameraLensOnly.conf [calib]: "
                                                  "'p2 = 0.00177329655628'"),
    }),
)
