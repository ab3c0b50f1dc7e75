"""The ``adi-ad-fxtof1`` preset (:mod:`tofjax._presets`)."""

from .._presets import Preset, quoted

_FXTOF1 = ("Analog Devices, 'AD-FXTOF1-EBZ' reference design, 'High level specification' "
           "(analogdevicesinc.github.io/system-level/solutions/reference-designs/ad-fxtof1-ebz)")


PRESET = Preset(
    name="adi-ad-fxtof1",
    title="Analog Devices AD-FXTOF1-EBZ VGA time-of-flight camera module (reference design)",
    references={"fxtof1": _FXTOF1},
    values=quoted({
        "illumination.wavelength_m": (940e-9, "fxtof1: 'Laser optics: 940nm VCSEL with 87° x 67° batwing profile "
                                              "diffuser'"),
        "illumination.fov_deg": ([87.0, 67.0], "fxtof1: '940nm VCSEL with 87° x 67° batwing profile diffuser' "
                                               "(a batwing profile evens the falloff; tofjax lights the "
                                               "rectangle evenly)"),
        "camera.fov_deg": ([87.0, 67.0], "fxtof1: 'Receive lens: FoV 87° x 67° including 940nm BPF, F=1.2'"),
        "camera.f_number": (1.2, "fxtof1: 'Receive lens: FoV 87° x 67° including 940nm BPF, F=1.2'"),
        "timing.frame_rate_hz": (30.0, "fxtof1: 'Frame Rate: 30fps (depends on processor board, OS and interface "
                                       "to host computer)'"),
    }),
)
