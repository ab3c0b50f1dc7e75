"""Sources and derivations several presets share, written once (each preset's ``references`` takes
them by these names; their notes cite them by tag)."""

from __future__ import annotations

#: [sbaa217]: TI's example lens for 3D ToF sensors, the source of typical ToF optics.
SBAA217 = ("Texas Instruments, S. C. Sadhu, 'Lenses for 3D Time-of-Flight (ToF) Image Sensors', application report "
           "SBAA217, July 2016 (for OPT8241, OPT8320, OPT9221), Table 1 'an example lens specification which works "
           "well for a 3D ToF system' (TI document viewer, lit/html/SBAA217)")
#: [fxtof1]: ADI's VGA ToF reference design, the source of typical optics only.
FXTOF1 = ("Analog Devices, 'AD-FXTOF1-EBZ' reference design, 'High level specification' "
          "(analogdevicesinc.github.io/system-level/solutions/reference-designs/ad-fxtof1-ebz): a VGA 940 nm "
          "time-of-flight camera, here the source of typical optics only")
#: [tofjax]: the eye-safety estimate the illumination powers are bounded by.
TOFJAX_CLASS1 = ("tofjax's class 1 estimate against IEC 60825-1:2014 (docs/model.md, 'Frame timing and eye safety'; "
                 "tofjax._timing.eye_safety): small source, 7 mm aperture at 100 mm, time base 100 s")


def typical_relative_illumination(lead: str = "") -> tuple[float, str]:
    """``frame.relative_illumination_exponent`` of a typical ToF lens ([sbaa217]), its note starting
    with ``lead`` (why this camera takes it)."""
    return (1.03, f"derived: {lead}a typical ToF lens' relative illumination, [sbaa217] Table 1 'Relative "
                  "Illumination (Ref.) 70%' at its 'Diagonal (deg) 90°' field: cos^n(45°) = 0.70, n = 1.03")
