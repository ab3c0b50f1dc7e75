"""The ``pmd-pico-flexx`` preset (:mod:`tofjax._presets`): pmd's CamBoard pico flexx in Royale's default use
case MODE_9_5FPS_2000 with Royale's default processing (docs/cameras/pmd-pico-flexx.md).

Royale, pmd's SDK, states the camera's operation: its use cases, illumination duty, imager timing, raw
range and every processing parameter. The pixel's electro-optical keys are not published for the pico
flexx. They come from a sibling sensor: the thesis' verification platform's Infineon REAL3 IRS1645C (thesis
§4.1.3), which Royale lists as imager M2452 beside the pico flexx's M2450 (IRS1020C, IRS1010C, IRS1115C,
IRS1125C). It is the same pmd/Infineon 224 x 172 pixel family, and the thesis characterises it (Tables
4.2-4.8). With those values tofjax matches its measured distance sweep within 11 % (docs/fitting.md). The
pico flexx's prediction is that pixel plus the pico flexx's own two-frequency depth and processing."""

import math

from .._presets import Preset

_ROYALE = ("pmdtechnologies ag / Infineon Technologies, Royale SDK v3.31.0 source (CHANGELOG: 'v3.31.0 - "
           "2020-03-27'; 'Royale officially supports the CamBoard pico flexx'), with the Spectre processing "
           "library's headers and changelog it ships; public copy: github.com/biabiaRun/Originsl_pmd-neato-platform, "
           "folder royale/ (files named in each note)")
_ASTROBEE = ("NASA, Astrobee flight software (github.com/nasa/astrobee): hardware/pico_driver/readme.md ('The PMD "
             "PicoFlexx camera ... comes factory calibrated with camera intrinsics and distortion parameters'; perch "
             "and haz cameras run 'MODE_9_5FPS_2000') and astrobee/config/robots/bumble.config (two pico flexx "
             "units' intrinsics and distortion)")
_THESIS = ("'Time-of-Flight 3D-Camera Performance Modeling', master's thesis, Institute for Technical Informatics, "
           "Graz University of Technology, in cooperation with Infineon Technologies Austria AG, Graz, May 2018 "
           "(tofjax's specification; its verification camera is the 'thesis' preset)")

#: The pixel's keys come from the sibling sensor (module docstring).
_SIBLING = ("derived: the sibling sensor's value, not the pico flexx's own: the thesis' verification platform "
            "(Infineon REAL3 IRS1645C, 224 x 172 pixels, [thesis] §4.1.3; the 'thesis' preset, Tables 4.2-4.8), "
            "which [royale] doc/imager_dev_codes.md lists as M2452 'IRS1645C, IRS1615C' beside the pico flexx's "
            "M2450 'IRS1020C, IRS1010C, IRS1115C, IRS1125C' (ModuleConfigPicoFlexxCommon.hpp: "
            "ImagerType::M2450_A12_AIO). No pmd or Infineon document states the pico flexx's pixel; with these "
            "values tofjax matches the sibling's measured distance sweep within 11 % (docs/fitting.md)")
#: The optics enter the depth noise only through their product with the illumination's power.
_LUMPED = ("derived: degenerate with illumination.peak_power_w: the signal depends on the optics only through "
           "P k_lens FF pitch^2 / N^2 (docs/model.md, 'Optical path'), and the sibling platform's product (the "
           "'thesis' preset's values) reproduces its measured sweep within 11 % (docs/fitting.md); the pico "
           "flexx's lens and pixel pitch are not published")

#: The pico flexx's lens from one unit's calibration ([astrobee] bumble.config, perch_cam): fx, fy (pixels).
_FX, _FY = 209.21199, 207.62067
#: Its 224 x 171 delivered pixels ([royale] ModuleConfigDataPicoFlexxU6.cpp line 29).
_COLS, _ROWS = 224, 171
#: The sibling's pixel pitch (the 'thesis' preset; degenerate with the power).
_PITCH = 17.5e-6
#: Royale's NoiseThreshold (m) and the first frequency (Hz): the confidence threshold as a phase.
_NOISE_THRESHOLD_M, _F1 = 0.07, 80.32e6
_C = 299_792_458.0

PRESET = Preset(
    name="pmd-pico-flexx",
    title="pmd CamBoard pico flexx (224 x 171 pixels), Royale's default use case MODE_9_5FPS_2000 (80.32 + 60.24 "
          "MHz, 4 phases each, 2000 us per phase image, 5 fps) with Royale's default processing",
    references={"royale": _ROYALE, "astrobee": _ASTROBEE, "thesis": _THESIS},
    values={
        # [illumination]
        "illumination.peak_power_w": (
            1.2, "derived: the sibling platform's illumination ([thesis] Table 4.2 via the 'thesis' preset; a VCSEL, "
                 "§4.1.3), which with the sibling pixel reproduces its measured sweep within 11 %: no pmd document "
                 "states the pico flexx's power. It keeps the pico flexx within laser class 1, which Royale states "
                 "for its standard access levels ([royale] ICameraDevice.hpp: 'Level 1: Standard users (Laser "
                 "Class 1 guaranteed)'): tofjax's IEC 60825-1 estimate (camera.eye_safety, small source) puts this "
                 "preset's frame (8 phase images of 2 ms, 0.93 ms apart) at 0.414 of the class 1 limit, so the limit "
                 "bounds the power at 2.9 W (3.8 W with USB 2's raw-frame spacing)"),
        "illumination.wavelength_m": (
            850e-9, "derived: the sibling's wavelength, at which its responsivity was matched; with the "
                    "responsivity given, the signal electrons (P R / e) do not depend on it, only the background's "
                    "photons and the class 1 limit do. No pmd document in reach states the pico flexx's; Royale "
                    "names the same family's pico monstar modules at 850 and 940 nm ([royale] "
                    "PicoMonstar850nmGlass, PicoMonstar940nm), and 850 nm is the stricter for class 1"),
        "illumination.fov_deg": (
            [62.06, 47.51], "derived: the illumination lights the lens' whole field: the image edges of one pico "
                            "flexx unit ([astrobee] bumble.config perch_cam, fx = 209.21, fy = 207.62 px, OpenCV "
                            "distortion k1 = -0.366735, k2 = 0.182027, p1 = 0.00218105, p2 = 0.0114682) at +-112 "
                            "and +-85.5 px from the array's centre, undistorted: 62.06 x 47.51 deg. No source "
                            "states the emitter's own field"),
        # [camera]
        "camera.fov_deg": (
            [round(2.0 * math.degrees(math.atan(0.5 * _COLS / _FX)), 2),
             round(2.0 * math.degrees(math.atan(0.5 * _ROWS / _FY)), 2)],
            "derived: the focal length of one pico flexx unit's calibration ([astrobee] bumble.config perch_cam: "
            "'209.21199, 0.0, 94.688486, / 0.0, 207.62067, 84.04047') over its 224 x 171 pixels: 2 atan(112 / "
            "fx), 2 atan(85.5 / fy) = 56.32 x 44.76 deg (pinhole; the distortion is in [frame]). A second unit "
            "(haz_cam) has fx = fy = 215.89 px, 3 % longer"),
        "camera.f_number": (1.4, _LUMPED),
        "camera.k_lens": (0.9, _LUMPED),
        "camera.fill_factor": (1.0, _LUMPED),
        "camera.pixel_pitch_m": ([_PITCH, _PITCH], _LUMPED),
        "camera.optical_area_m": (
            [_COLS * _PITCH, _ROWS * _PITCH],
            "derived: [royale] ModuleConfigDataPicoFlexxU6.cpp line 29: '{ 224, 171 },' (the delivered image; "
            "the imager reads one pseudo-data line more, ImagerM2450.cpp adjustRowCount) of the sibling's pitch"),
        # [pixel]: the sibling's (section_sources), except
        "pixel.n_phases": (4, "quoted: [royale] UseCaseEightPhase.cpp: 'MODULATED_4PH_CW' (four phase images per "
                              "frequency; MODE_9_5FPS_2000 is 1 grey + 4 + 4 raw frames)"),
        "pixel.sbi": (True, "quoted: [royale] ProcessingFlag.hpp: 'UseFlagSBI_Bool, ///< Enable/Disable the "
                            "flagging of pixels where the SBI was active' (the pixel has a suppression of "
                            "background illumination; its threshold is the sibling's)"),
        "pixel.phase_offset_rad": (
            0.0, "derived: the factory calibration removes the constant offset from the delivered depth "
                 "([royale] Spectre Changelog 2.3.0: 'Combined calcPhase2Distance/correctTemperature/"
                 "correctFPPN'); the raw offset is not published and does not reach Royale's depth"),
        "pixel.phase_drift_rad_per_c": (
            0.0, "derived: Royale compensates the temperature: it hands Spectre the illumination's temperature "
                 "every frame ([royale] ProcessingSpectre.cpp: 'input.setTemperature (capturedCase->"
                 "getIlluminationTemperature());', two TMP102 sensors, ModuleConfigPicoFlexxCommon.hpp) for "
                 "correctTemperature; no residual drift is published, so none is modelled"),
        # [illumination_waveform]
        "illumination_waveform.shape": (
            "gauss_extended", "derived: the sibling platform's emitted waveform ([thesis] Table 4.6, §5.5.1), a "
                              "pulse of the same 25 % duty; the pico flexx's optical edges are not published"),
        "illumination_waveform.gauss_order": (15, "derived: the sibling platform's ([thesis] §5.5.1, order 15)"),
        "illumination_waveform.fourier_order": (5, "derived: not read by gauss_extended (the sibling's)"),
        "illumination_waveform.duty_cycle": (
            0.25, "quoted: [royale] ModuleConfigPicoFlexxCommon.hpp: 'IlluminationConfig{ ... DutyCycle::"
                  "DC_25_DEPRECATED, 90000000, ...}'; RawFrameSet.hpp: 'DC_25_DEPRECATED, //!< 25% trailing "
                  "dutycycle for legacy support of picoFlexx calibration only'"),
        "illumination_waveform.modulation_frequency_hz": (
            80.32e6, "quoted: [royale] ModuleConfigDataPicoFlexxU6.cpp line 34, MODE_9_5FPS_2000: '5u, 80320000, "
                     "60240000, ... 2000u }, 2000u, 2000u, 200u,' (5 fps, two frequencies, 2000 us per phase "
                     "image, a 200 us grey image with the illumination off)"),
        "illumination_waveform.extra_modulation_frequencies_hz": (
            [60.24e6], "quoted: [royale] ModuleConfigDataPicoFlexxU6.cpp line 34 (the second frequency, 4 phase "
                       "images of 2000 us); the pair unwraps to c / (2 x 20.08 MHz) = 7.465 m"),
        "illumination_waveform.frequency_fusion": (
            "inverse_variance", "derived: Royale fuses the two frequencies in Spectre ([royale] "
                                "CommonProcessingParameters.hpp, CommonProcessingParams2Frequencies: "
                                "'UseFilter2Freq_Bool, royale::Variant (true)'; ProcessingFlag.hpp: 'Activates 2 "
                                "frequency filtering'); "
                                "its weights are not published: the minimum-variance weighting, which equals "
                                "1 / d_u^2 weights when both frequencies have the same phase noise"),
        # [adc]: the sibling's (section_sources), except
        "adc.resolution_bits": (12, "quoted: [royale] BufferUtils.hpp: 'uint16_t, with the 12-bit data left-padded "
                                    "with zeros to 16 bits'"),
        # [timing]
        "timing.readout_time_s": (
            9.3e-4, "derived: Royale's raw-frame time ([royale] ImagerM2450.cpp calcRawFrameRateTime) less the "
                    "exposure: 24.8 us to the frame start, 2.2 us of exposure overhead and 172 lines (171 + the "
                    "pseudo-data line) of the PIF interface at 133.3 MHz, 0.90 ms: 0.93 ms; the raw frames of a "
                    "frame follow each other (START_ALIGNED). Over USB 2 Royale throttles raw frames to 230/s "
                    "(FlowControlStrategyFactory.cpp), 2.35 ms; the frame's eight phase images fit 200 ms either way"),
        "timing.frame_rate_hz": (5.0, "quoted: [royale] ModuleConfigDataPicoFlexxU6.cpp line 34, MODE_9_5FPS_2000: "
                                      "'5u, ...' (frames per second)"),
        # [scene]: the mode's exposure and the band-pass filter
        "scene.integration_time_s": (
            2e-3, "quoted: [royale] ModuleConfigDataPicoFlexxU6.cpp line 34, MODE_9_5FPS_2000: '... 2000u }, 2000u, "
                  "2000u, 200u,' (the exposure of each raw frame, us; the 200 us grey image is unlit and not modelled)"),
        "scene.integration_time_per": ("phase_image", "quoted: [royale] ImagerM2450.cpp calcRegExposure: the exposure "
                                                      "is set per raw frame, one raw frame per phase image"),
        "scene.filter_half_width_m": (
            25e-9, "derived: not published (the ambient-light claims imply a band-pass); a band-pass centred for 850 nm "
                   "must pass the corner's chief ray (36.7 deg from camera.fov_deg), where an interference filter "
                   "(effective index about 2, a typical value) shifts 4.6 % to the blue: 39 nm of pass band, "
                   "+-19.5 nm, widened to +-25 nm for the laser's tolerance and thermal drift"),
        # [frame]
        "frame.illumination_falloff_exponent": (
            0.0, "derived: a flat spot over illumination.fov_deg, the profile the power's class 1 estimate and "
                 "the sibling's validation assume; the pico flexx's emission profile is not published (a sweep's "
                 "centre pixel does not read it)"),
        "frame.baseline_m": ([0.0, 0.0], "derived: emitter and lens share one small module and no offset is "
                                         "published; taken at the lens, as the sibling's model (a sweep's centre "
                                         "pixel does not read it)"),
        "frame.relative_illumination_exponent": (4.0, "derived: the cos^4 law of a lens' relative illumination; no "
                                                      "measured falloff of the pico flexx's lens is published"),
        "frame.vignetting": (0.0, "derived: no mechanical vignetting is published; the calibrated image edges "
                                  "([astrobee]) are inside the lens' field"),
        "frame.distortion_k1": (-0.366735, "quoted: [astrobee] bumble.config perch_cam: 'distortion_coeff = "
                                           "{-0.366735, 0.182027, 0.00218105, 0.0114682}' (one unit; Spectre's "
                                           "order 'fx,fy,cx,cy,k1,k2,p1,p2', [royale] CalibrationField.def)"),
        "frame.distortion_k2": (0.182027, "quoted: [astrobee] bumble.config perch_cam (second coefficient)"),
        "frame.distortion_p1": (0.00218105, "quoted: [astrobee] bumble.config perch_cam (third coefficient)"),
        "frame.distortion_p2": (0.0114682, "quoted: [astrobee] bumble.config perch_cam (fourth coefficient)"),
        "frame.distortion_k3": (0.0, "quoted: [astrobee] bumble.config perch_cam states four coefficients, no k3"),
        "frame.prnu_sigma": (0.01, "derived: the sibling's default (the 'thesis' preset); a pixel's gain enters its "
                                   "depth noise only as its square root, 0.5 % here, inside the sibling's 11 %"),
        "frame.phase_offset_sigma_rad": (
            0.0, "derived: Spectre removes each pixel's fixed-pattern phase with the factory calibration "
                 "([royale] Spectre Changelog 2.3.0: 'correctFPPN'); the residual is not published"),
        "frame.tap_asymmetry_sigma": (
            0.0, "derived: the four phase images' differences cancel a tap's gain mismatch to first order, and "
                 "Royale invalidates inconsistent pixels ([royale] ProcessingFlag.hpp: 'ConsistencyTolerance_Float "
                 "... Consistency limit for asymmetry validation', 1.2); the sibling's 0"),
        "frame.threshold_sigma": (0.0, "derived: the sibling's (the 'thesis' preset); no spread of the pico flexx's "
                                       "SBI threshold is published"),
        "frame.max_phase_noise_rad": (
            round(_NOISE_THRESHOLD_M * 4.0 * math.pi * _F1 / _C, 4),
            "derived: Royale invalidates a pixel whose predicted final distance noise exceeds NoiseThreshold "
            "([royale] ModuleConfigPicoFlexxCommon.hpp line 36: 'NoiseThreshold_Float, royale::Variant (0.07f, "
            "0.03f, 0.2f)'; ProcessingFlag.hpp: 'Upper threshold for final distance noise'); tofjax reads the "
            "fused distance noise as a phase at the first frequency (c / (4 pi 80.32 MHz) = 0.2970 m/rad): "
            "0.07 m / 0.2970 m/rad = 0.2357 rad"),
        "frame.min_amplitude_lsb": (0.0, "derived: the pico flexx's processing map sets no amplitude threshold "
                                         "([royale] ModuleConfigPicoFlexxCommon.hpp, standardParametersPicoFlexx)"),
        # [processing]
        "processing.calibration": (
            True, "derived: every pico flexx is factory calibrated ([astrobee] readme: 'comes factory calibrated'; "
                  "its per-frequency phase wiggling and fixed-pattern phase: [royale] Spectre Changelog 2.6.5 "
                  "'usage of wiggling information for the wrong frequency', 2.3.0 'correctFPPN'), modelled as "
                  "tofjax's ideal factory calibration"),
        "processing.calibration_temperature_c": (
            25.0, "derived: not published; with the temperature compensation (pixel.phase_drift_rad_per_c = 0) "
                  "the delivered depth does not depend on it; the sensor's nominal temperature"),
        "processing.spatial_filter": (
            "median", "derived: Royale's adaptive noise filter, on by default ([royale] ModuleConfigPicoFlexxCommon"
                      ".hpp: 'UseAdaptiveNoiseFilter_Bool, royale::Variant (true)', 'Activate spatial filter "
                      "reducing the distance noise'), algorithm unpublished: an edge-preserving filter, modelled "
                      "as tofjax's edge-preserving one, a median (Spectre ships one: Changelog 2.7.0 'Use improved "
                      "Median filter implementation'); on a flat wall it lowers the noise by 2.45, a box by 3"),
        "processing.spatial_filter_size": (
            3, "derived: 'AdaptiveNoiseFilterType_Int, royale::Variant (1, 1, 2)' ([royale] "
               "ModuleConfigPicoFlexxCommon.hpp), type 1 = 3 x 3 (Spectre Changelog 2.7.0: 'Use valid filter type "
               "(3x3) for adaptive noise filter')"),
        "processing.temporal_average_frames": (
            1, "quoted: [royale] ProcessingFlag.hpp: 'stdUseSmoothingFilter ({ ...UseSmoothingFilter_Bool, false "
               "})', in CommonProcessingParams2Frequencies (Royale's only temporal filter, off)"),
        "processing.amplitude_threshold": (False, "derived: no amplitude threshold in the pico flexx's processing "
                                                  "map (frame.min_amplitude_lsb)"),
        "processing.flying_pixel_m": (
            0.134, "derived: Royale's flying-pixel filter, on by default ([royale] ModuleConfigPicoFlexxCommon.hpp: "
                   "'UseRemoveFlyingPixel_Bool, royale::Variant (true)'), algorithm unpublished; its thresholds are "
                   "normalised by the depth ('FlyingPixelsF0_Float, royale::Variant (0.018f, ...)', 'Scaling factor "
                   "for lower depth value normalization'; 'FlyingPixelsNearDist_Float ... (1.0f, ...)', 'Lower "
                   "normalized threshold'): NearDist x F0 = 1.8 % of the depth. tofjax's threshold is absolute, so "
                   "it is taken at the deepest depth the camera delivers, the pair's extended range 7.465 m: 0.134 m. "
                   "A flat wall's noise then never invalidates a pixel Royale's relative threshold would keep; "
                   "nearer, depth steps below about twice 0.134 m are kept where Royale would flag them"),
        "processing.flying_pixel_neighbours": (
            3, "derived: Spectre's default neighbour count, which Royale does not change for the pico flexx "
               "([royale] Parameter.def: 'FLYING_PIXEL_NEIGHBORS_MIN, \"flyPixNeighborsMin\", "
               "static_cast<uint32_t>(3)', 'Number of neighbors')"),
    },
    section_sources={
        "pixel": _SIBLING,
        "reference_waveform": _SIBLING.replace("Tables 4.2-4.8", "Table 4.7: a 50 % gate, order 15"),
        "adc": _SIBLING.replace("Tables 4.2-4.8", "Table 4.8"),
    },
    unpublished=("no pmd datasheet and no measurement of the pico flexx with numbers is held by any source reached "
                 "(docs/cameras/pmd-pico-flexx.md): its predictions have nothing to be checked against"),
)
