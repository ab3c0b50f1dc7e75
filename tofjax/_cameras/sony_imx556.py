"""The ``sony-imx556`` preset (:mod:`tofjax._presets`)."""

from .._presets import Preset, quoted

_SONY2017 = ("Sony Corporation, press release of 5 June 2017 on its back-illuminated ToF image sensor (as reported by "
             "AZoSensors, news 12001, 'Sony's Time-of-Flight Image Sensor Features 10-um Pixel Pitch')")
_LUCID = ("LUCID Vision Labs, tech brief 'Sony DepthSense 3D Sensor Explained: Better Time of Flight' "
          "(thinklucid.com/tech-briefs/sony-depthsense-how-it-works), its side note 'Sony IMX556 DepthSense ToF sensor "
          "specs' as quoted by 3D Vision Academy, 'ToF: Understand Current Assisted Photonic Demodulator (CAPD)'")

PRESET = Preset(
    name="sony-imx556",
    title="Sony IMX556 DepthSense back-illuminated CAPD time-of-flight sensor, 640 x 480 pixels",
    references={"sony2017": _SONY2017, "lucid": _LUCID},
    values=quoted({
        "camera.pixel_pitch_m": ([10e-6, 10e-6], "lucid: '10.0um pixel size'; sony2017: 'a back-illuminated "
                                                 "time-of-flight (ToF) image sensor with a 10um pixel pitch'"),
        "camera.optical_area_m": ([6.4e-3, 4.8e-3], "lucid: '640 x 480 px' of 10.0 um ('1/2\" sensor size')"),
    }),
)
