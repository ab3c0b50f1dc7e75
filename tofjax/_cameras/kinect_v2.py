"""The ``kinect-v2`` preset (:mod:`tofjax._presets`)."""

from .._presets import Preset, quoted

_BAMJI = ("C. S. Bamji et al., 'A 0.13 um CMOS System-on-Chip for a 512 x 424 Time-of-Flight Image Sensor With "
          "Multi-Frequency Photo-Demodulation up to 130 MHz and 2 GS/s ADC', IEEE J. Solid-State Circuits 50(1), "
          "303-319, 2015 (abstract)")

PRESET = Preset(
    name="kinect-v2",
    title="Microsoft Kinect for Xbox One (Kinect v2) time-of-flight sensor, 512 x 424 pixels",
    references={"bamji2015": _BAMJI},
    values=quoted({
        "camera.pixel_pitch_m": ([10e-6, 10e-6], "bamji2015: '10 um x 10 um pixel'"),
        "camera.optical_area_m": ([5.12e-3, 4.24e-3], "bamji2015: 512 x 424 pixels of 10 um"),
        "camera.fill_factor": (1.0, "bamji2015 quotes the pixel's responsivity (fill factor inside it; "
                                    "tofjax's reading, docs/model.md)"),
        "pixel.photo_responsivity_a_per_w": (0.14, "bamji2015: 'responsivity of 0.14 A/W at 860 nm'"),
        "illumination.wavelength_m": (860e-9, "bamji2015: the wavelength of the quoted responsivity"),
        "pixel.demodulation_contrast": (0.67, "bamji2015: 'modulation contrast of 67 % at 50 MHz'"),
        "illumination_waveform.modulation_frequency_hz": (
            50e6, "bamji2015: the frequency of the quoted contrast (the camera runs several frequencies up to "
                  "130 MHz; which, and their contrasts, the abstract does not say)"),
        "adc.resolution_bits": (10, "bamji2015: '2 GS/s 10 bit signal path'"),
    }),
)
