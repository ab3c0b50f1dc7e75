"""The ``lucid-helios2`` preset (:mod:`tofjax._presets`): the LUCID Vision Labs Helios2 / Helios2+
time-of-flight camera (HLT003S / HTP003S; Sony IMX556, 640 x 480 pixels of 10 um, 850 nm) in its
3 m mode, Distance3000mmSingleFreq (50 MHz, four phase images of 0.98 ms, 30 fps, the default
1000 us exposure), with LUCID's flying-pixel filter at its recommended 20 mm, key by key.

What LUCID documents (modes, frequencies, exposure and readout timing, the flying-pixel filter) is
quoted; the sensor's keys are shared with the ``basler-blaze-101`` preset (``_imx556``: the same
sensor, the same sources, its read-noise floor fitted to Basler's daylight measurement). LUCID
publishes no accuracy or precision for the Helios2 in any source reached, so nothing here is
fitted to the camera's own performance and no specification file exists: the illumination's power
is the most a class 1 illumination emits in tofjax's (small-source) estimate at this mode.
docs/cameras/lucid-helios2.md gives every derivation and what stays open."""

from .._presets import Preset
from ._sources import FXTOF1, SBAA217, TOFJAX_CLASS1, typical_relative_illumination
from . import _imx556

_MIRROR = "1stvision.com/cameras/Lucid-Vision-Labs"

REFERENCES = {
    "l-h2p-tr": ("LUCID Vision Labs, 'Helios2+ Technical Reference (HTP003S)', Camera Features (mirror: "
                 f"{_MIRROR}/Helios2%2BTechnical-Reference/html/camera_features_helios2_plus.html): 'Operating Mode', "
                 "'High Speed Operating Mode', 'HDR Mode'"),
    "l-h2w-tr": ("LUCID Vision Labs, 'Helios2 Wide Technical Reference (HTW003S)', Camera Features (mirror: "
                 f"{_MIRROR}/Helios2-Wide-Technical-Reference/html/camera_features_helios2.html): 'Operating Mode', "
                 "'Flying Pixel Filter', 'Exposure Time', 'Gain' (the same sensor and mode table)"),
    "l-kb-multi": ("LUCID Vision Labs knowledge base, 'Using multiple Helios 2 cameras simultaneously' "
                   "(support.thinklucid.com/knowledgebase/using-multiple-helios-2-cameras-simultaneously): its timing "
                   "table and worked example"),
    "l-flex": ("LUCID Vision Labs, 'Helios Flex Camera Technical Manual' (LUCID's earlier IMX556 camera; copy at "
               "manualshive.com, page 25): its coordinate system and confidence data"),
    "arena-py": ("LUCID Vision Labs, Arena SDK for Python, Helios example ('Copyright (c) 2022, Lucid Vision Labs, "
                 "Inc.'; a public copy in the project's code index): set_nodes(), 'Sets some node to get smoth resutls'"),
    "h2-doc": ("a third party's project documentation, 'Image acquisition module', section 'Helios2 basics' (a public "
               "copy in the project's code index; its repository is not named by the index)"),
    "cdk": ("PointCloud.AI, libPointCloud, the profile of its Sony IMX556 camera kit, SonyCDKCameraNormal.conf "
            "(github.com/pointcloudAI/libPointCloud, libs/ubuntu/share/pointcloud-1.0.0/conf, commit ec2fea58), "
            "[calib] 'fx = 478', 'fy = 478', 'cx = 319', 'cy = 239', 'k1 = -0.0' ... 'p2 = 0.00'"),
    "opt8241": "Texas Instruments, 'OPT8241 3D Time-of-Flight Sensor', data sheet SBAS704B (2015), p. 1",
    "fxtof1": FXTOF1,
    "sbaa217": SBAA217,
    "tofjax": TOFJAX_CLASS1,
    "blaze": ("tofjax's basler-blaze-101 preset and docs/cameras/basler-blaze-101.md: the other camera on this sensor, "
              "whose maker documents what LUCID does not"),
    "docs": "this preset's page, docs/cameras/lucid-helios2.md (its derivations H1-H6)",
    **_imx556.REFERENCES,
}

#: H1: the 3 m mode's frequency and its phase images' integration ([l-kb-multi]: 'The laser integrate for 0.98 ms').
FREQUENCY_HZ = 50e6
INTEGRATION_S = 0.98e-3
#: H2: the illumination's peak power, 0.98 of tofjax's class 1 estimate at this mode.
PEAK_POWER_W = 2.06
#: H3: the field of view of the IMX556 kit's nominal lens, fx = fy = 478 px of 10 um ([cdk]).
FOV_DEG = [67.62, 53.32]
#: H4: LUCID's recommended flying-pixel threshold, and the confidence threshold derived from it.
FLYING_PIXEL_M = 0.020
_C = 299792458.0
MAX_PHASE_NOISE_RAD = round(4 * 3.141592653589793 * FREQUENCY_HZ * FLYING_PIXEL_M / _C, 4)

_NOT_READ = "derived: not read by the 'pulse' shape (no effect)"

PRESET = Preset(
    name="lucid-helios2",
    title="LUCID Vision Labs Helios2 / Helios2+ time-of-flight camera (HLT003S / HTP003S, Sony IMX556, 640 x 480), "
          "3 m mode Distance3000mmSingleFreq: 50 MHz, 4 x 0.98 ms, 30 fps, flying-pixel filter at 20 mm",
    references=REFERENCES,
    values={
        **_imx556.values(850e-9),
        # --- illumination -------------------------------------------------------------------------
        "illumination.wavelength_m": (
            850e-9, "quoted: [h2-doc] 'The Helios2 is a Time of Flight camera by the manufacturer Lucid Vision Labs "
                    "Inc. ... The cameras diodes work on a wavelength of 850nm which is not suitable for outdoor "
                    "operation' (a user's statement; LUCID's own pages reached say only 'VCSEL', [lucid-tb])"),
        "illumination.fov_deg": (
            FOV_DEG, "derived: not published in any source reached; matched to the lens (camera.fov_deg, [docs] H3); "
                     "the sweeps and the class 1 estimate depend on it only through the power per solid angle, and the "
                     "power is set at the class 1 estimate's limit (illumination.peak_power_w): degenerate with it"),
        "illumination.peak_power_w": (
            PEAK_POWER_W,
            "derived: [docs] H2, the most light a class 1 illumination emits in [tofjax]'s estimate at this mode (850 "
            "nm, C4 = 2.00; this field; 4 x 0.98 ms at 30 fps, lit 11.8 %, a 50 % square wave): the average power "
            "binds at 2.11 W; 2.06 W is 0.98 of the limit (small source, the strictest case; LUCID's laser class is not "
            "stated in any source reached). No published performance of the Helios2 constrains it"),
        "illumination_waveform.shape": (
            "pulse", "derived: [lucid-tb] 'modulated light is emitted from the VCSEL (Vertical Cavity Surface Emitting "
                     "Laser) diode'; the shape is not published: a square wave, its wiggling removed by the factory "
                     "calibration (processing.calibration)"),
        "illumination_waveform.duty_cycle": (0.5, "derived: a square wave of the pixel's two 180° taps "
                                                  "(reference_waveform.duty_cycle): 50 %"),
        "illumination_waveform.gauss_order": (15, _NOT_READ),
        "illumination_waveform.fourier_order": (5, _NOT_READ),
        "illumination_waveform.modulation_frequency_hz": (
            FREQUENCY_HZ, "quoted: [l-h2p-tr] and [l-h2w-tr], 'Operating Mode | Modulation Frequency': '3.0m | 50 MHz' "
                          "(c / (2 x 50 MHz) = 2.998 m); the mode LUCID's Arena example sets for the Helios2 "
                          "([arena-py] 'Scan3dOperatingMode ... Distance3000mmSingleFreq')"),
        "illumination_waveform.extra_modulation_frequencies_hz": (
            [], "quoted: [l-h2p-tr] the 3.0 m mode is one frequency ('3.0m | 50 MHz'; the two-frequency modes are "
                "'5.0m | 120 MHz + 90 MHz' and '8.3m | 90 MHz + 72 MHz')"),
        "illumination_waveform.frequency_fusion": ("inverse_variance", "derived: one frequency: nothing to fuse"),
        # --- camera and lens ----------------------------------------------------------------------
        "camera.fov_deg": (
            FOV_DEG, "derived: [docs] H3: not published for the Helios2 in any source reached (the camera stores its "
                     "unit's CalibFocalLengthX/Y, whose values are not); the nominal lens of an IMX556 camera kit "
                     "([cdk] 'fx = 478', 'fy = 478'): 2 atan(320 / 478) = 67.62°, 2 atan(240 / 478) = 53.32°; no sweep "
                     "depends on it, frames do"),
        "camera.f_number": (1.2, "derived: not published; a typical ToF lens: [fxtof1] 'Receive lens ... F=1.2', "
                                 "[sbaa217] Table 1 'F.No 1.2'; degenerate with the power for the signal"),
        "camera.k_lens": (0.85, "derived: not published; a typical ToF lens' transmission, [sbaa217] Table 1 "
                                "'Transmission efficiency >85% @ 850 nm', with the band-pass filter"),
        # --- pixel (the camera's side) --------------------------------------------------------------
        "pixel.n_phases": (4, "quoted: [l-kb-multi] 'The laser integrate for 0.98 ms / followed by the constant "
                              "readout time of 1.55 ms / Steps 1 & 2 are repeated 4 times ... T(total) = (0.98 + 1.55) "
                              "x 4 = 10.12 ms': four phase images"),
        "pixel.phase_drift_rad_per_c": (
            8.03e-4, "derived: LUCID documents no temperature compensation in any source reached; the sensor's own "
                     "drift, the analogous DepthSense pixel's ([mlx75027] Table 13 'Phase drift over temperature "
                     "0.046 deg/°C', 8.03e-4 rad/degC; its sign not stated); the emitter's adds, not published"),
        # --- the mode's exposure and the band-pass filter (kept in [scene]) ---------------------------
        "scene.integration_time_s": (
            INTEGRATION_S, "quoted: [l-kb-multi] 'The laser integrate for 0.98 ms' ('The duration of the laser "
                           "integration is slightly shorter than the user-selected ExposureTime') at Exp1000Us, "
                           "[l-h2w-tr] 'The 1000 us setting is the default exposure time and also the maximum "
                           "exposure time allowed'"),
        "scene.integration_time_per": ("phase_image", "derived: [l-kb-multi] one laser integration per phase image "
                                                      "(its timing table: integration, readout, four times)"),
        "scene.filter_half_width_m": (
            18.5e-9, "derived: [docs] H3: LUCID publishes no filter; an 850 nm ToF sensor's stated band-pass, [opt8241] "
                     "'Integrated Optical Band-Pass Filter (830 nm to 867 nm)': a half width of 18.5 nm (the same "
                     "sensor's camera, the blaze-101, passes 920-970 nm about its 940 nm, [blaze])"),
        # --- timing -----------------------------------------------------------------------------------
        "timing.readout_time_s": (1.55e-3, "quoted: [l-kb-multi] 'Readout | 1.55 ms | Always constant independent of "
                                           "operating mode on all Helios 2 variants'"),
        "timing.frame_rate_hz": (30.0, "quoted: [l-h2p-tr] 'In standard operating modes, the camera is capable of "
                                       "generating depth data at 30 FPS'; [l-kb-multi] '(1000 ms / 30 FPS)'"),
        # --- frame --------------------------------------------------------------------------------------
        "frame.illumination_falloff_exponent": (
            0.0, "derived: not published; the evenest profile tofjax models, as the class 1 estimate of "
                 "illumination.peak_power_w assumes"),
        "frame.baseline_m": ([0.0, 0.0], "derived: the emitters' position is not published; beside the lens their "
                                         "parallax matters only in the first tens of centimetres: coaxial"),
        "frame.relative_illumination_exponent": typical_relative_illumination("not published; "),
        "frame.vignetting": (0.0, "derived: the relative illumination (frame.relative_illumination_exponent) "
                                  "includes the lens' vignetting"),
        **dict.fromkeys(
            ("frame.distortion_k1", "frame.distortion_k2", "frame.distortion_k3", "frame.distortion_p1",
             "frame.distortion_p2"),
            (0.0, "derived: the camera computes its points with its unit's own calibration (CalibLensDistortionValue "
                  "k1, k2, p1, p2, k3, read by users of the Arena SDK; the values are not published): the delivered "
                  "image is that of a distortion-free lens ([cdk]'s nominal profile: 'k1 = -0.0' ... 'p2 = 0.00')")),
        "frame.max_phase_noise_rad": (
            MAX_PHASE_NOISE_RAD,
            "derived: [docs] H4, the confidence threshold (Scan3dConfidenceThresholdEnable, enabled by LUCID's example "
            "[arena-py]; [l-flex] 'The confidence value represents a measure of how reliable the depth data is. By "
            "analyzing the temporal variations of the light pulse signal, a 16-bit integer value per pixel is "
            "generated'; its default value is not published): a pixel whose own depth noise reaches the flying-pixel "
            "threshold (20 mm, processing.flying_pixel_m) is not reliable by LUCID's own measure: 4 pi x 50 MHz x "
            "20 mm / c = 0.0419 rad"),
        "frame.min_amplitude_lsb": (0.0, "derived: the confidence is a noise measure (frame.max_phase_noise_rad), not "
                                         "an amplitude: off"),
        # --- the camera's processing ------------------------------------------------------------------
        "processing.calibration": (
            True, "derived: the camera delivers calibrated coordinates in millimetres ([l-flex] 'The Z coordinate is "
                  "zero at the front of the camera housing'; Scan3dCoordinateScale), which a phase offset and a "
                  "square wave's wiggling would spoil by centimetres: a factory calibration of both"),
        "processing.calibration_temperature_c": (
            25.0, "derived: not published; room temperature, inside the sensor's 'Performance guarantee temperature : "
                  "-10 to +60 ̊C' ([deptheye]); the drift acts away from it (pixel.phase_drift_rad_per_c)"),
        "processing.spatial_filter": (
            "none", "derived: Scan3dSpatialFilterEnable is what LUCID's example turns on 'to get smoth resutls' and "
                    "restores afterwards ([arena-py]); its kernel is not published: off, the camera's state before"),
        "processing.spatial_filter_size": (3, "derived: not read (processing.spatial_filter none)"),
        "processing.temporal_average_frames": (
            1, "derived: Scan3dImageAccumulation, which LUCID's example sets to 4 'to get smoth resutls' and restores "
               "afterwards ([arena-py]): one frame, the camera's state before"),
        "processing.amplitude_threshold": (False, "derived: the confidence threshold is a noise threshold "
                                                  "(frame.max_phase_noise_rad)"),
        "processing.flying_pixel_m": (
            FLYING_PIXEL_M, "quoted: [l-h2w-tr] 'The flying pixel filter evaluates if a pixel has a large depth "
                            "discontinuity from its surrounding pixels. The center pixel is marked as invalid when the "
                            "distance from its surrounding pixels is larger than the defined threshold. To enable the "
                            "flying pixel filter: Set Flying Pixels Removal Enable = True; Set Flying Pixels Distance "
                            "Threshold = 20 (represented in mm)'"),
        "processing.flying_pixel_neighbours": (
            5, "derived: [docs] H4: 'the distance from its surrounding pixels' read as from most of them: a pixel "
               "beside a straight depth step differs from 3 of its 8 neighbours and is kept, a mixed pixel on the step "
               "from 6 and is removed; 5 is the majority"),
    },
    unpublished=("LUCID publishes no accuracy or precision for the Helios2 in any source reached (docs/cameras/lucid-helios2.md): its predictions have nothing to be checked against"),
)
