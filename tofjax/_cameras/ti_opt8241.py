"""The ``ti-opt8241`` preset (:mod:`tofjax._presets`)."""

from .._presets import Preset, quoted

_OPT8241 = "Texas Instruments, OPT8241 3D Time-of-Flight Sensor, datasheet SBAS704B (June 2015, revised October 2015)"
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
    name="ti-opt8241",
    title="Texas Instruments OPT8241 3D time-of-flight sensor, 320 x 240 pixels",
    references={"opt8241": _OPT8241},
    values=_OPT8241_VALUES,
)
