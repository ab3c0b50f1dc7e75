"""The ``basler-blaze-101`` preset (:mod:`tofjax._presets`): the Basler blaze-101 time-of-flight
camera (Sony IMX556, 640 x 480 pixels of 10 um, 940 nm) in its default acquisition, Fast Mode off
(eight subframes: four at 100 MHz, four at 15 MHz), Long Range (1 ms per subframe), 20 fps, key by
key.

What Basler documents (modes, frequencies, exposure, filters, the accuracy and precision test, the
daylight measurement) is quoted; the sensor's keys are shared with the ``lucid-helios2`` preset
(``_imx556``: the same sensor, the same sources). The illumination's power is the most a class 1
illumination emits in tofjax's (small-source) estimate at this mode; the pixel's read-noise floor
is fitted to Basler's daylight measurement. The derivations D1-D7 and every number are in
docs/cameras/basler-blaze-101.md."""

from .._presets import Preset
from ._sources import FXTOF1, SBAA217, TOFJAX_CLASS1, typical_relative_illumination
from . import _imx556

_DOCS = "docs.baslerweb.com"


def _basler(title: str, page: str) -> str:
    return f"Basler AG, blaze documentation, '{title}' ({_DOCS}/{page})"


REFERENCES = {
    "b-opmode": _basler("Operating Mode", "operating-mode"),
    "b-opmode-101": ("Basler AG, an earlier version of the same page, 'Operating Mode' for 'the blaze-101 camera' "
                     f"({_DOCS}/operating-mode, the copy stored by the project's pages index)"),
    "b-fast": _basler("Fast Mode", "fast-mode"),
    "b-roi": _basler("ROI (blaze)", "roi-(blaze)"),
    "b-acc": _basler("Accuracy and Precision (Temporal Noise)", "accuracy-and-precision"),
    "b-exp": _basler("Exposure Time (blaze)", "exposure-time-(blaze)"),
    "b-infl": _basler("Influencing Factors", "influencing-factors"),
    "b-day": _basler("Daylight Robustness", "daylight-robustness"),
    "b-mcc": _basler("Multi-Camera Channel", "multi-camera-channel"),
    "b-spat": _basler("Spatial Filter", "spatial-filter"),
    "b-temp": (_basler("Temporal Filter", "temporal-filter.html") + "; knowledge article 'Additional Information on "
               f"the blaze Spatial and Temporal Filters' ({_DOCS}/knowledge/additional-information-on-the-blaze-"
               "spatial-and-temporal-filters.html)"),
    "b-out": _basler("Outlier Removal", "outlier-removal"),
    "b-conf": _basler("Confidence Threshold", "confidence-threshold"),
    "b-amb": _basler("Ambiguity Filter", "ambiguity-filter"),
    "pylon-blaze": ("Basler AG, pylon SDK, generated header BlazeCameraParams.h, 'A parameter class containing all "
                    "parameters ... available for blaze-101', fw-4.1.0-20210519153005 (a public copy in the project's "
                    "code index)"),
    "pylon-ros": ("Basler AG, pylon ROS 2 camera driver (github.com/basler/pylon-ros-camera), its blaze services, e.g. "
                  "'enable_distortion_correction', 'enable_thermal_drift_correction'"),
    "lucid-kb": ("LUCID Vision Labs knowledge base, 'Using multiple Helios 2 cameras simultaneously' "
                 "(support.thinklucid.com/knowledgebase/using-multiple-helios-2-cameras-simultaneously): the "
                 "IMX556's readout, the same sensor"),
    "cdk": ("PointCloud.AI, libPointCloud, the profile of its Sony IMX556 camera kit, SonyCDKCameraNormal.conf "
            "(github.com/pointcloudAI/libPointCloud, libs/ubuntu/share/pointcloud-1.0.0/conf, commit ec2fea58), "
            "[calib] 'fx = 478', 'fy = 478', 'cx = 319', 'cy = 239', 'k1 = -0.0' ... 'p2 = 0.00'"),
    "fxtof1": FXTOF1,
    "sbaa217": SBAA217,
    "tofjax": TOFJAX_CLASS1,
    "docs": "this preset's page, docs/cameras/basler-blaze-101.md (its derivations D1-D7)",
    **_imx556.REFERENCES,
}

#: D1: the default acquisition: four subframes at each of 100 and 15 MHz (Fast Mode off).
FREQUENCIES_HZ = (100e6, 15e6)
#: D3: the illumination's peak power, 0.98 of tofjax's class 1 estimate at this mode.
PEAK_POWER_W = 2.3
#: D4: the field of view of the IMX556 kit's nominal lens, fx = fy = 478 px of 10 um ([cdk]).
FOV_DEG = [67.62, 53.32]
#: D2: the band-pass filter, 920-970 nm.
FILTER_HALF_WIDTH_M = 25e-9

_NOT_READ = "derived: not read by the 'pulse' shape (no effect)"

PRESET = Preset(
    name="basler-blaze-101",
    title="Basler blaze-101 time-of-flight camera (Sony IMX556, 640 x 480), default acquisition: Fast Mode off, "
          "100 + 15 MHz, Long Range (1 ms per subframe), 20 fps",
    references=REFERENCES,
    values={
        **_imx556.values(940e-9),
        # --- illumination -------------------------------------------------------------------------
        "illumination.wavelength_m": (
            940e-9, "quoted: [b-infl] 'blaze cameras have an optical bandpass filter. This filter only allows light of "
                    "the same spectrum as the camera's light source (940 nm) to pass through to the sensor'; [b-day] "
                    "'Target illuminated by 940 nm LED ... using the same wavelength as the camera'"),
        "illumination.fov_deg": (
            FOV_DEG, "derived: not published in any source reached; matched to the lens (camera.fov_deg, [docs] D4); "
                     "the sweeps and the class 1 estimate depend on it only through the power per solid angle, and the "
                     "power is set at the class 1 estimate's limit (illumination.peak_power_w): degenerate with it"),
        "illumination.peak_power_w": (
            PEAK_POWER_W,
            "derived: [docs] D3, the most light a class 1 illumination emits in [tofjax]'s estimate at this mode (940 "
            "nm, C4 = 3.02; this field; 8 subframes of 1 ms at 20 fps, lit 16 %, a 50 % square wave): the average "
            "power binds at 2.34 W; 2.3 W is 0.98 of the limit (small source, the strictest case; Basler's laser "
            "class is not stated in any source reached). It keeps a 90 % target at 0.3 m below the full well in "
            "Long Range's 1 ms (0.88 of it; the specification's range starts there, [b-fast] '0.3–10 m'), and with the "
            "fitted noise floor every specification row holds for 0.5-2.6 W ([docs] D6)"),
        "illumination_waveform.shape": (
            "pulse", "derived: a VCSEL driven by the camera's modulation (LastError 'Indicates a problem with the "
                     "VCSELs', [pylon-blaze]); the shape is not published: a square wave, its wiggling removed by the "
                     "factory calibration (processing.calibration)"),
        "illumination_waveform.duty_cycle": (0.5, "derived: a square wave of the pixel's two 180° taps "
                                                  "(reference_waveform.duty_cycle): 50 %"),
        "illumination_waveform.gauss_order": (15, _NOT_READ),
        "illumination_waveform.fourier_order": (5, _NOT_READ),
        "illumination_waveform.modulation_frequency_hz": (
            FREQUENCIES_HZ[0],
            "quoted: [b-opmode] 'each frame is composed of eight subframes. Four of these subframes are taken in Short "
            "Range (with a frequency of 100 MHz) and the other four subframes are taken in Long Range (with a frequency "
            "of 15 MHz)'; [b-fast] 'By default, the FastMode parameter is disabled'"),
        "illumination_waveform.extra_modulation_frequencies_hz": (
            [FREQUENCIES_HZ[1]], "quoted: [b-opmode] '... the other four subframes are taken in Long Range (with a "
                                 "frequency of 15 MHz)'; their common range c / (2 x 5 MHz) = 29.98 m is [b-roi]'s "
                                 "'the non-ambiguity range in these modes is from 0–30 m'"),
        "illumination_waveform.frequency_fusion": (
            "highest_frequency",
            "derived: [docs] D1: [b-opmode] 'This combines the higher accuracy of the Short Range mode with the longer "
            "range of the Long Range mode': the depth is the 100 MHz phase's, the 15 MHz one chooses its period; "
            "[b-fast]'s temporal noise of Long Range '<1 mm (up to 5.5 m)' against Long Range with Fast Mode (15 MHz "
            "only) '<6 mm' is the frequency ratio, 100 / 15 = 6.7 (inverse_variance would weight 100 MHz by 0.978: "
            "the same within 1 %)"),
        # --- camera and lens ----------------------------------------------------------------------
        "camera.fov_deg": (
            FOV_DEG, "derived: [docs] D4: not published for the blaze-101 in any source reached; the nominal lens of "
                     "an IMX556 camera kit ([cdk] 'fx = 478', 'fy = 478', 'cx = 319', 'cy = 239'): 2 atan(320 / 478) = "
                     "67.62°, 2 atan(240 / 478) = 53.32°; no sweep depends on it (the centre pixel's etendue is "
                     "A_pixel / (4 N^2)), frames do"),
        "camera.f_number": (1.2, "derived: not published; a typical ToF lens: [fxtof1] 'Receive lens: FoV 87° x 67° "
                                 "including 940nm BPF, F=1.2', [sbaa217] Table 1 'F.No 1.2'; degenerate with the power "
                                 "for the signal (P k_lens / N^2) and fitted out with it through pixel.c_diode_f"),
        "camera.k_lens": (0.85, "derived: not published; a typical ToF lens' transmission, [sbaa217] Table 1 "
                                "'Transmission efficiency >85% @ 850 nm', with the band-pass filter; degenerate with "
                                "the power for the signal"),
        # --- pixel (the camera's side) --------------------------------------------------------------
        "pixel.n_phases": (4, "quoted: [b-opmode] 'Four of these subframes are taken in Short Range (with a frequency "
                              "of 100 MHz) and the other four subframes ... (with a frequency of 15 MHz)': four phase "
                              "images per frequency"),
        "pixel.phase_drift_rad_per_c": (
            0.0, "derived: compensated: the camera measures its 'Illumination' and 'Sensorboard' temperatures and "
                 "'Activates the correction of the thermal drift' (ThermalDriftCorrection, [pylon-blaze]; "
                 "[pylon-ros] 'enable_thermal_drift_correction'); [b-acc] specifies after '20 minutes camera warm-up "
                 "time' (a transient, not modelled). The sensor's own drift is the analogous pixel's 0.046 deg/degC "
                 "([mlx75027] Table 13)"),
        # --- the mode's exposure and the band-pass filter (kept in [scene]) ---------------------------
        "scene.integration_time_s": (
            1e-3, "quoted: [b-opmode-101] 'When changing to Long Range, the exposure time is set to the maximum value "
                  "(1 ms)'; [b-exp] 'The maximum exposure time is always 1000 µs'"),
        "scene.integration_time_per": (
            "phase_image", "derived: the exposure time is each subframe's: [b-mcc] 'Each subframe can be viewed as a "
                           "separate exposure because after exposing each subframe the illumination is switched off "
                           "and the sensor is reset'"),
        "scene.filter_half_width_m": (
            FILTER_HALF_WIDTH_M,
            "derived: [docs] D2: the filter passes 'light of the same spectrum as the camera's light source (940 nm)' "
            "([b-infl]) and Basler measured its robustness 'for ambient light sources between 920–970 nm' ([b-day]): "
            "920-970 nm, a half width of 25 nm about 940 nm"),
        # --- timing -----------------------------------------------------------------------------------
        "timing.readout_time_s": (
            1.55e-3, "derived: the sensor's readout of one subframe, the same IMX556: [lucid-kb] 'Readout | 1.55 ms | "
                     "Always constant independent of operating mode on all Helios 2 variants'; 8 x (1 ms + 1.55 ms) = "
                     "20.4 ms fits the 50 ms of 20 fps, and Fast Mode's 4 x 2.55 ms its '30 fps' ([b-fast])"),
        "timing.frame_rate_hz": (20.0, "quoted: [b-opmode-101] 'In normal operating mode, the blaze-101 camera achieves "
                                       "a frame rate of 20 fps'"),
        # --- frame --------------------------------------------------------------------------------------
        "frame.illumination_falloff_exponent": (
            0.0, "derived: not published; the evenest profile tofjax models (a flood illuminator shaped to its "
                 "field), as the class 1 estimate of illumination.peak_power_w assumes"),
        "frame.baseline_m": ([0.0, 0.0], "derived: the emitters' position is not published; beside the lens their "
                                         "parallax matters only in the first tens of centimetres: coaxial"),
        "frame.relative_illumination_exponent": typical_relative_illumination("not published; "),
        "frame.vignetting": (0.0, "derived: the relative illumination (frame.relative_illumination_exponent) "
                                  "includes the lens' vignetting"),
        **dict.fromkeys(
            ("frame.distortion_k1", "frame.distortion_k2", "frame.distortion_k3", "frame.distortion_p1",
             "frame.distortion_p2"),
            (0.0, "derived: the camera corrects its lens' distortion before it delivers depth and points (a "
                  "DistortionCorrection control, [pylon-ros] 'enable_distortion_correction'; calibrated per unit); the "
                  "delivered image is that of a distortion-free lens ([cdk]'s nominal profile: 'k1 = -0.0' ... 'p2 = "
                  "0.00')")),
        "frame.max_phase_noise_rad": (
            3.15, "derived: the confidence threshold ([b-conf] 'You can specify a confidence threshold value between 0 "
                  "and 255 ... there is no general guideline for choosing a value'; no default published) is taken "
                  "off: 3.15 rad flags no pixel. The ambiguity filter ([b-amb]) is tofjax's unwrapping over 30 m; its "
                  "removal of ambiguous pixels is not modelled ([docs] D7)"),
        "frame.min_amplitude_lsb": (0.0, "derived: off, as the confidence threshold (frame.max_phase_noise_rad)"),
        # --- the camera's processing ------------------------------------------------------------------
        "processing.calibration": (True, "quoted: [b-acc] 'blaze cameras are calibrated at the factory and tested to "
                                         "guarantee a reliable accuracy'"),
        "processing.calibration_temperature_c": (
            22.0, "derived: [b-acc]'s test condition, '22 °C room temperature' after '20 minutes camera warm-up time'; "
                  "no effect: the thermal drift is corrected (pixel.phase_drift_rad_per_c 0)"),
        "processing.spatial_filter": (
            "box", "derived: [docs] D7: [b-spat] 'This filter uses the values of neighboring pixels to filter out "
                   "spatial noise ... The basis for this is the raw image data from the sensor (gray values). This "
                   "helps to flatten bumps in planes and create smoother surfaces. Object edges are left intact': on a "
                   "plane an average of the neighbours (tofjax's box; its edge-keeping is not modelled); on by default: "
                   "[b-day]'s 'usable images' at seven times the noise need it (D5)"),
        "processing.spatial_filter_size": (3, "derived: [docs] D7: the 'neighboring pixels' are the eight adjacent ones "
                                              "(the 3 x 3 neighbourhood of [b-out]'s filter); its size is not "
                                              "published"),
        "processing.temporal_average_frames": (
            9, "derived: [docs] D7: [b-temp] 'This is a recursive filter ... OUT = (k / 255) * STATE + (1 – k / 255) * "
               "IN', 'As a rule of thumb, ten frames should be good enough to reach a stable picture': a = k / 255 with "
               "a^10 = 0.1 (k = 203); for a static scene its noise is that of (1 + a) / (1 - a) = 8.7 averaged frames, "
               "9; on by default as the spatial filter ([docs] D5)"),
        "processing.amplitude_threshold": (False, "derived: off, as the confidence threshold "
                                                  "(frame.max_phase_noise_rad)"),
        "processing.flying_pixel_m": (
            0.0, "derived: [b-out]'s outlier removal ('the number of inliers (good data values) in a 3x3 neighborhood "
                 "required', 'the maximum permissible relative distance') publishes no default threshold or tolerance: "
                 "off; on the specification's flat target it would remove nothing"),
        "processing.flying_pixel_neighbours": (1, "derived: not read (processing.flying_pixel_m off)"),
    },
)
