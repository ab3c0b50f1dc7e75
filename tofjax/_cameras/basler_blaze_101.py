"""The ``basler-blaze-101`` preset (:mod:`tofjax._presets`)."""

from .._presets import Preset, quoted

_BASLER = ("Basler AG, blaze documentation: 'Operating Mode' (docs.baslerweb.com/operating-mode), 'Fast Mode' "
           "(docs.baslerweb.com/fast-mode), 'Exposure Time (blaze)' (docs.baslerweb.com/exposure-time-(blaze))")

PRESET = Preset(
    name="basler-blaze-101",
    title="Basler blaze-101 time-of-flight camera, Short Range operating mode (one frequency, Fast Mode)",
    references={"basler": _BASLER},
    values=quoted({
        "illumination_waveform.modulation_frequency_hz": (
            100e6, "basler Operating Mode: 'Four of these subframes are taken in Short Range (with a frequency of "
                   "100 MHz) and the other four subframes are taken in Long Range (with a frequency of 15 MHz)'; "
                   "Fast Mode takes only the four of the selected range (Long Range: set 15e6)"),
        "pixel.n_phases": (4, "basler Fast Mode: 'If the FastMode parameter is enabled, only four subframes are "
                              "taken' (four phase images of one frequency: tofjax's reading)"),
        "timing.frame_rate_hz": (30.0, "basler Fast Mode: 'allows you to achieve the maximum frame rate of 30 fps'"),
    }),
)
