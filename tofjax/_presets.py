"""Camera presets: public sensors described by what their publications state, with every source.

A preset is a partial configuration. Each value it sets names its source: a datasheet line or a
paper's abstract, quoted as stated, with the conditions it was stated under. Every key the sources
leave open keeps tofjax's default, which is the thesis' verification camera (thesis Tables 4.2-4.8).
The rendered TOML marks those keys "unknown" on their comment line, so nobody mistakes a default
for a measured value.

Interpretations, applied to every preset:
- A datasheet's *responsivity* in A/W is the pixel's own response: microlens and fill factor are
  already inside it. The preset therefore sets ``camera.fill_factor = 1`` so that the fill factor is
  not counted twice.
- A *demodulation (modulation) contrast* quoted at one frequency holds only there. The preset runs
  at that frequency, so that the contrast and the frequency belong together. The camera's own
  operating frequencies, and the contrast at each, are unknown unless a source gives them.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from typing import Any

from ._schema import SECTIONS, keys_of, suggest

UNKNOWN = "unknown for this camera: the default (thesis verification camera) is kept"


@dataclasses.dataclass(frozen=True)
class Preset:
    """A camera described by its publications.

    - ``name``: what ``tofjax config --preset NAME`` takes;
    - ``title``: the camera or sensor;
    - ``references``: tag -> full citation;
    - ``values``: dotted key -> (value, source note naming a reference tag);
    - ``section_sources``: section -> source note for every key of the section the preset does
      not set (the thesis preset: its tables). Sections not listed are unknown.
    """

    name: str
    title: str
    references: Mapping[str, str]
    values: Mapping[str, tuple[Any, str]]
    section_sources: Mapping[str, str] = dataclasses.field(default_factory=dict)

    def raw(self) -> dict[str, dict[str, Any]]:
        """The preset as a partial nested configuration (what a TOML file would hold)."""
        out: dict[str, dict[str, Any]] = {}
        for dotted, (value, _) in self.values.items():
            section, _, name = dotted.partition(".")
            out.setdefault(section, {})[name] = value
        return out

    def notes(self) -> dict[str, str]:
        """Dotted key -> the source note of its value, or the unknown mark."""
        out = {}
        for section in SECTIONS:
            for key in keys_of(section):
                dotted = f"{section}.{key.name}"
                if dotted in self.values:
                    out[dotted] = "source: " + self.values[dotted][1]
                else:
                    out[dotted] = ("source: " + self.section_sources[section] if section in self.section_sources
                                   else UNKNOWN)
        return out


_OPERATING_POINT = {"scene": "the operating point, not a property of the camera: set it to your measurement's "
                             "(default: thesis §5.5.1)"}
_THESIS = "Thesis 'Time-of-Flight 3D-Camera Performance Modeling' (Graz, 2018)"
_BAMJI = ("C. S. Bamji et al., 'A 0.13 um CMOS System-on-Chip for a 512 x 424 Time-of-Flight Image Sensor With "
          "Multi-Frequency Photo-Demodulation up to 130 MHz and 2 GS/s ADC', IEEE J. Solid-State Circuits 50(1), "
          "303-319, 2015 (abstract)")
_OPT8241 = "Texas Instruments, OPT8241 3D Time-of-Flight Sensor, datasheet SBAS704B (June 2015, revised October 2015)"
_VOXELSDK = ("Texas Instruments, Voxel SDK for the OPT8241-CDK-EVM ('Tintin' CDK; github.com/3dtof/voxelsdk, "
             "TI3DToF/boards/TintinCDK/*.conf): the camera's Short Range profile and its lens calibration")
#: What the OPT8241 datasheet states (the sensor preset, and the CDK camera built on it).
_OPT8241_VALUES = {
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
}
_SONY2017 = ("Sony Corporation, press release of 5 June 2017 on its back-illuminated ToF image sensor (as reported by "
             "AZoSensors, news 12001, 'Sony's Time-of-Flight Image Sensor Features 10-um Pixel Pitch')")
_LUCID = ("LUCID Vision Labs, tech brief 'Sony DepthSense 3D Sensor Explained: Better Time of Flight' "
          "(thinklucid.com/tech-briefs/sony-depthsense-how-it-works), its side note 'Sony IMX556 DepthSense ToF sensor "
          "specs' as quoted by 3D Vision Academy, 'ToF: Understand Current Assisted Photonic Demodulator (CAPD)'")
_BASLER = ("Basler AG, blaze documentation: 'Operating Mode' (docs.baslerweb.com/operating-mode), 'Fast Mode' "
           "(docs.baslerweb.com/fast-mode), 'Exposure Time (blaze)' (docs.baslerweb.com/exposure-time-(blaze))")
_AZURE = ("Microsoft, 'Azure Kinect DK hardware specifications' (learn.microsoft.com/azure/kinect-dk/hardware-"
          "specification; MicrosoftDocs/azure-docs, articles/kinect-dk/hardware-specification.md, 2020-02-14)")
_AZURE_DEPTH = ("Microsoft, 'Azure Kinect DK depth camera' (learn.microsoft.com/azure/kinect-dk/depth-camera; "
                "MicrosoftDocs/azure-docs, articles/kinect-dk/depth-camera.md, 2019-06-26)")
_FXTOF1 = ("Analog Devices, 'AD-FXTOF1-EBZ' reference design, 'High level specification' "
           "(analogdevicesinc.github.io/system-level/solutions/reference-designs/ad-fxtof1-ebz)")

PRESETS: dict[str, Preset] = {
    "thesis": Preset(
        name="thesis",
        title="The thesis' verification camera (pmd 2-tap PMD sensor, 224 x 172 pixels; thesis §5.5, Table A.1)",
        references={"thesis": _THESIS},
        values={"timing.frame_rate_hz": (5.0, "thesis Appendix A: the camera was configured to '5 Frames Per Second' "
                                              "(4 phases, 2 ms exposure, 25 % illumination duty)"),
                "pixel.collection_depth_m": (0.0, "thesis: one responsivity for every wavelength (Table 4.5's "
                                                  "photo_responsivity; 0: flat)"),
                "pixel.dark_reference_temperature_c": (25.0, "thesis: its dark slopes (Table 4.5) carry no temperature; "
                                                             "taken at the default sensor temperature"),
                "pixel.dark_doubling_temperature_c": (7.0, "thesis: no temperature scaling of the dark current; the "
                                                           "doubling acts only away from the reference temperature "
                                                           "(7 degC: A. Theuwissen, Harvest Imaging, 2009)"),
                "pixel.readout_noise_e": (0.0, "thesis: no read noise beyond the kTC noise in its model (§4.2.12-4.2.14)"),
                "pixel.readout_nonlinearity": (0.0, "thesis: a linear readout in its model"),
                "pixel.full_well_e": (0.0, "thesis: the full well follows from v_reset, v_saturated and the "
                                           "capacitances (§3.2.5; 0: derived)"),
                "pixel.phase_offset_rad": (0.0, "thesis: its model has no phase offset (0: none)"),
                "pixel.phase_drift_rad_per_c": (0.0, "thesis: no temperature drift in its model; it names temperature "
                                                     "effects as future work (§6.1.2; 0: none)")},
        section_sources={
            "illumination": "thesis Table 4.2",
            "scene": "thesis Table 4.3 (operating point of §5.5.1)",
            "camera": "thesis Table 4.4",
            "pixel": "thesis Table 4.5",
            "illumination_waveform": "thesis Table 4.6 and §5.5.1 (gauss_extended order 15, 25 % duty, "
                                     "80.32 MHz of Table A.1)",
            "reference_waveform": "thesis Table 4.7",
            "adc": "thesis Table 4.8",
        },
    ),
    "kinect-v2": Preset(
        name="kinect-v2",
        title="Microsoft Kinect for Xbox One (Kinect v2) time-of-flight sensor, 512 x 424 pixels",
        references={"bamji2015": _BAMJI},
        values={
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
        },
        section_sources=_OPERATING_POINT,
    ),
    "ti-opt8241": Preset(
        name="ti-opt8241",
        title="Texas Instruments OPT8241 3D time-of-flight sensor, 320 x 240 pixels",
        references={"opt8241": _OPT8241},
        values=_OPT8241_VALUES,
        section_sources=_OPERATING_POINT,
    ),
    "ti-opt8241-cdk": Preset(
        name="ti-opt8241-cdk",
        title="Texas Instruments OPT8241-CDK-EVM camera (OPT8241 sensor, TI's lens and Short Range profile)",
        references={"opt8241": _OPT8241, "voxelsdk": _VOXELSDK},
        values={
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
        },
        section_sources=_OPERATING_POINT,
    ),
    "sony-imx556": Preset(
        name="sony-imx556",
        title="Sony IMX556 DepthSense back-illuminated CAPD time-of-flight sensor, 640 x 480 pixels",
        references={"sony2017": _SONY2017, "lucid": _LUCID},
        values={
            "camera.pixel_pitch_m": ([10e-6, 10e-6], "lucid: '10.0um pixel size'; sony2017: 'a back-illuminated "
                                                     "time-of-flight (ToF) image sensor with a 10um pixel pitch'"),
            "camera.optical_area_m": ([6.4e-3, 4.8e-3], "lucid: '640 x 480 px' of 10.0 um ('1/2\" sensor size')"),
        },
        section_sources=_OPERATING_POINT,
    ),
    "basler-blaze-101": Preset(
        name="basler-blaze-101",
        title="Basler blaze-101 time-of-flight camera, Short Range operating mode (one frequency, Fast Mode)",
        references={"basler": _BASLER},
        values={
            "illumination_waveform.modulation_frequency_hz": (
                100e6, "basler Operating Mode: 'Four of these subframes are taken in Short Range (with a frequency of "
                       "100 MHz) and the other four subframes are taken in Long Range (with a frequency of 15 MHz)'; "
                       "Fast Mode takes only the four of the selected range (Long Range: set 15e6)"),
            "pixel.n_phases": (4, "basler Fast Mode: 'If the FastMode parameter is enabled, only four subframes are "
                                  "taken' (four phase images of one frequency: tofjax's reading)"),
            "timing.frame_rate_hz": (30.0, "basler Fast Mode: 'allows you to achieve the maximum frame rate of 30 fps'"),
        },
        section_sources=_OPERATING_POINT,
    ),
    "azure-kinect": Preset(
        name="azure-kinect",
        title="Microsoft Azure Kinect DK depth camera (1-megapixel ToF sensor of ISSCC 2018), NFOV unbinned mode",
        references={"azure": _AZURE, "azure_depth": _AZURE_DEPTH},
        values={
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
        },
        section_sources=_OPERATING_POINT,
    ),
    "adi-ad-fxtof1": Preset(
        name="adi-ad-fxtof1",
        title="Analog Devices AD-FXTOF1-EBZ VGA time-of-flight camera module (reference design)",
        references={"fxtof1": _FXTOF1},
        values={
            "illumination.wavelength_m": (940e-9, "fxtof1: 'Laser optics: 940nm VCSEL with 87° x 67° batwing profile "
                                                  "diffuser'"),
            "illumination.fov_deg": ([87.0, 67.0], "fxtof1: '940nm VCSEL with 87° x 67° batwing profile diffuser' "
                                                   "(a batwing profile evens the falloff; tofjax lights the "
                                                   "rectangle evenly)"),
            "camera.fov_deg": ([87.0, 67.0], "fxtof1: 'Receive lens: FoV 87° x 67° including 940nm BPF, F=1.2'"),
            "camera.f_number": (1.2, "fxtof1: 'Receive lens: FoV 87° x 67° including 940nm BPF, F=1.2'"),
            "timing.frame_rate_hz": (30.0, "fxtof1: 'Frame Rate: 30fps (depends on processor board, OS and interface "
                                           "to host computer)'"),
        },
        section_sources=_OPERATING_POINT,
    ),
}


def preset(name: str) -> Preset:
    """The preset called ``name``; a ``ValueError`` naming the allowed names otherwise."""
    if not isinstance(name, str) or name not in PRESETS:
        raise ValueError(f"preset = {name!r} is not known: allowed " + ", ".join(repr(p) for p in PRESETS)
                         + (suggest(name, PRESETS) if isinstance(name, str) else ""))
    return PRESETS[name]


def preset_config(name: str):
    """The validated :class:`tofjax.Config` of a preset (its values over the defaults)."""
    from ._config import config_from_dict

    return config_from_dict(preset(name).raw(), where=f"preset {name}")


def preset_text(name: str) -> str:
    """The full TOML of a preset: every key with its meaning and range, and then its source or
    the mark that the sources leave it unknown."""
    from ._config import render_toml

    p = preset(name)
    head = [f"# tofjax camera configuration, preset {p.name!r}: {p.title}.", "# References:"]
    head += [f"#   [{tag}] {citation}" for tag, citation in p.references.items()]
    head.append("# Every key names its source; 'unknown' keys keep the thesis camera's value and are guesses for "
                "this camera.")
    return render_toml(preset_config(name).values, notes=p.notes(), header=head)
