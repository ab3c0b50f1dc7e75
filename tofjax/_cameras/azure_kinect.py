"""The ``azure-kinect`` preset (:mod:`tofjax._presets`): the Microsoft Azure Kinect DK depth camera
in its NFOV unbinned mode (640 x 576, 75 x 65 deg field of interest, 30 fps), key by key.

What Microsoft publishes (the mode table, the raw timing, the depth-engine's invalidation, the
specification bounds) is quoted; the sensor's own paper (ISSCC 2018) was not reachable, so the
pixel's keys are derived from the contemporary back-illuminated ToF pixel whose datasheet is in the
project's sources (Melexis MLX75027), scaled to this pixel's area where they are extensive. The
modulation frequencies are not published and are derived (docs/cameras/azure-kinect.md, "The
modulation frequencies"). The illumination's power is the most the depth system's stated power
allows; the pixel's read-noise floor is fitted to the specification's corner (15 %, 3.86 m, 2.2
uW/cm^2/nm), fitting/validation/azure_kinect_nfov_*.csv. The derivations' numbers are reproduced
by docs/cameras/azure-kinect.md."""

from .._presets import Preset
from ._sources import FXTOF1, SBAA217

_HWSPEC = ("Microsoft, 'Azure Kinect DK hardware specifications', learn.microsoft.com/azure/kinect-dk/hardware-"
           "specification (MicrosoftDocs/azure-docs, articles/kinect-dk/hardware-specification.md, ms.date 02/14/2020, "
           "commit 0306c6fd)")
_DEPTHCAM = ("Microsoft, 'Azure Kinect DK depth camera', learn.microsoft.com/azure/kinect-dk/depth-camera "
             "(MicrosoftDocs/azure-docs, articles/kinect-dk/depth-camera.md, ms.date 06/26/2019, commit 02d00dc8)")
_DEPTHCAM2019 = ("Microsoft, 'Depth camera', an earlier version of the same page (MicrosoftDocs/azure-docs, "
                 "articles/kinect-dk/azure-kinect-dk-depth-camera.md, ms.date 06/05/2019, commit 1daa0e5f)")
_SYNC = ("Microsoft, 'Synchronize multiple Azure Kinect DK devices' (MicrosoftDocs/azure-docs, "
         "articles/kinect-dk/multi-camera-sync.md, ms.date 02/20/2020)")
_SDK = ("Microsoft, Azure Kinect Sensor SDK, github.com/microsoft/Azure-Kinect-Sensor-SDK, commit 8bb59caa (2022-09-01); "
        "its depth engine is closed ('The depth engine is not licensed under MIT as it contains proprietary code', "
        "docs/depthengine.md)")
_ISSCC = ("C. S. Bamji et al., '1Mpixel 65nm BSI 320MHz Demodulated TOF Image Sensor with 3.5um Global Shutter "
          "Pixels and Analog Binning', ISSCC 2018, pp. 94-95 (title as on Microsoft's page 'Depth camera whitepaper - "
          "ISSCC 2018'; the paper's text was not reachable)")
_ISW2021 = ("Image Sensors World, 'Microsoft iToF Tutorial', 19 April 2021, quoting O. Wing (Microsoft), "
            "'Understanding Indirect ToF Depth Sensing'")


def _gh(number: int, title: str, who: str) -> str:
    return f"github.com/microsoft/Azure-Kinect-Sensor-SDK issue #{number}, '{title}', {who}"


_LF2 = ("OpenKinect/libfreenect2 (the Kinect v2's depth engine, 'modelled on the GPU shaders used by the official "
        "SDK', libfreenect2 issue #492), commit fd64c5d9: src/cuda_kde_depth_packet_processor.cu l. 328, "
        "src/depth_packet_processor.cpp l. 53-61")
_MLX = ("Melexis, 'MLX75027 VGA Time-of-Flight Sensor', datasheet v1.0 (15/12/2020), Table 13 and Fig. 11 "
        "(10 um back-illuminated pixel; read for this project in /work/research/mlx75027.md)")
_OPT8241 = ("Texas Instruments, 'OPT8241 3D Time-of-Flight Sensor', data sheet SBAS704B (2015), p. 1")
_LFW2020 = ("G. Dahlmann, V. Bhatt, S. Parthasarathi, 'VCSEL power-conversion efficiency improves to 45%', "
            "Laser Focus World, 28 January 2020")
_TOLGYESSY = ("M. Tolgyessy, M. Dekan, L. Chovanec, P. Hubinsky, 'Evaluation of the Azure Kinect and Its Comparison "
              "to Kinect V1 and Kinect V2', Sensors 21(2):413, 2021, abstract")
_DOCS = "this preset's page, docs/cameras/azure-kinect.md (its derivations D1-D7)"

#: The derived modulation frequencies (D1): the predecessor's ratios 15 : 10 : 2 under the sensor's 320 MHz.
FREQUENCIES_HZ = (300e6, 200e6, 40e6)
#: One phase image's laser burst and the frame's lit fraction (hwspec: 9 bursts of 125 us at 30 fps).
BURST_S = 125e-6
LIT_FRACTION = 9 * BURST_S * 30.0
#: D3: the most light the depth system's stated power allows: 45 % of 950 mW, over the lit fraction and
#: the 50 % square wave's mean.
PEAK_POWER_W = 0.45 * 0.950 / (0.5 * LIT_FRACTION)
#: The pixel's area over the MLX75027's 10 um pixel (D4: extensive quantities scale with it).
AREA_RATIO = (3.5 / 10.0) ** 2
#: D5: the fitted read-noise floor, an effective integration capacitance per tap side (see its note).
C_EFF_F = 4.0e-17
#: The MLX75027's typical dark current (51 ke-/s per tap), scaled to this pixel, as a slope on C_eff.
DARK_E_PER_S = 51e3 * AREA_RATIO
_E = 1.602176634e-19

PRESET = Preset(
    name="azure-kinect",
    title="Microsoft Azure Kinect DK depth camera (1-megapixel ToF sensor of ISSCC 2018), NFOV unbinned mode "
          "(640 x 576, 30 fps)",
    references={
        "hwspec": _HWSPEC, "depthcam": _DEPTHCAM, "depthcam2019": _DEPTHCAM2019, "sync": _SYNC, "sdk": _SDK,
        "isscc": _ISSCC, "isw2021": _ISW2021,
        "gh789": _gh(789, "Depth are interpolated at surface edge", "labelled 'By Design' by Microsoft"),
        "gh812": _gh(812, "What is Azure Kinect's IR baseline?", "answer by wes-b (Microsoft)"),
        "gh1000": _gh(1000, "what is the frequency of tof camera?", "answers by wes-b (Microsoft)"),
        "gh1156": _gh(1156, "Invalidaton of depth pixels in edges", "a user's report"),
        "gh1218": _gh(1218, "Question about temporal filtering of Kinect images", "answer by rabbitdaxi (Microsoft)"),
        "gh1465": _gh(1465, "Question about tof type", "answer by jaygullapalli (Microsoft)"),
        "gh1807": _gh(1807, "Azure Kinect modulation frequency and range ambiguity",
                      "a community answer reading isscc (not Microsoft's)"),
        "lf2": _LF2, "mlx75027": _MLX, "opt8241": _OPT8241, "sbaa217": SBAA217, "fxtof1": FXTOF1,
        "lfw2020": _LFW2020, "tolgyessy2021": _TOLGYESSY, "docs": _DOCS,
    },
    values={
        # --- illumination -------------------------------------------------------------------------
        "illumination.wavelength_m": (850e-9, "quoted: [gh1000] wes-b (Microsoft): 'The sensor uses a 850nm laser'; "
                                              "[hwspec] footnote: '15% to 95% reflectivity at 850nm'"),
        "illumination.fov_deg": ([75.0, 65.0], "quoted: [hwspec] NFOV unbinned 'FoI 75°x65°'; [depthcam]: 'Two NIR "
                                               "Laser diodes enabling near and wide field-of-view (FoV) depth modes' "
                                               "(the NFOV one lights the field of interest; its mask is a hexagon "
                                               "inside it, [depthcam] 'Illumination Mask')"),
        "illumination.peak_power_w": (
            round(PEAK_POWER_W, 2),
            "derived: [docs] D3, the most light the depth system's power allows: [depthcam2019] 'overall system power "
            "of 225-950mw', at most 45 % of it emitted ([lfw2020]: the best 850-940 nm laser power-conversion "
            "efficiency reported by 2020), over the lit fraction 9 x 125 us x 30 fps = 3.375 % ([hwspec] raw timing) "
            "and the 50 % square wave's mean: 0.45 x 0.95 W / (0.5 x 0.03375) = 25.3 W. The specification needs 15 W "
            "even from a noiseless pixel (17 W in the Monte Carlo) and 21.5 W with the fitted floor (24.1 W), so the "
            "camera runs near this ceiling ([docs] D5); the signal is P R k_lens / N^2 (the optics' keys below). "
            "Above tofjax's class 1 estimate for a small source (5.3 x its limit, which allows 4.8 W); an apparent "
            "source of 8 mrad or more, a diffuser's, raises the limit by C6 = alpha / 1.5 mrad >= 5.3 ([docs] D3)"),
        "illumination_waveform.shape": ("pulse", "quoted: [gh1465] jaygullapalli (Microsoft): 'The amplitude "
                                                 "modulated wave is a square wave.'"),
        "illumination_waveform.duty_cycle": (0.5, "derived: a square wave ([gh1465]) gated by two wells each 'open "
                                                  "for half of a modulation period' ([isw2021]): 50 %"),
        "illumination_waveform.gauss_order": (15, "derived: no effect: the shape is 'pulse' (gauss_extended only)"),
        "illumination_waveform.fourier_order": (5, "derived: no effect: the shape is 'pulse' (fourier only)"),
        "illumination_waveform.modulation_frequency_hz": (
            FREQUENCIES_HZ[0],
            "derived: not published ([docs] D1): 9 raw captures per frame ([hwspec] '9 IR pulses'; [sdk] raw frame "
            "sizes) = 3 frequencies x 3 phases, as the predecessor from the same group ([lf2] l. 328: 'modulation "
            "frequencies 16, 80 and 120 MHz', ratios 2 : 10 : 15); its ratios under the sensor's '320MHz Demodulated' "
            "([isscc] title) with the highest at 300 MHz: 300, 200, 40 MHz, whose extended range c / (2 x 20 MHz) = "
            "7.49 m covers every NFOV distance ([hwspec] 0.5-5.46 m binned); none 'at or near 75 MHz or 100 MHz' "
            "([gh1000]); mean 180 MHz ([gh1807] reads isscc as 'an average system modulation frequency of 200MHz')"),
        "illumination_waveform.extra_modulation_frequencies_hz": (
            list(FREQUENCIES_HZ[1:]), "derived: [docs] D1 (see modulation_frequency_hz): 200 and 40 MHz"),
        "illumination_waveform.frequency_fusion": (
            "inverse_variance", "derived: not published; the minimum-variance fusion (a Microsoft unwrapping "
                                "patent weights the frequencies, [docs] D1): weights 1 / sigma_i^2, i.e. f_i^2 for "
                                "equal phase noise, so 'unambiguity_range' gives the same; the 40 MHz frequency "
                                "carries 1.2 % of the weight and serves the unwrapping"),
        # --- reference waveform -------------------------------------------------------------------
        "reference_waveform.shape": ("pulse", "quoted: [isw2021] O. Wing (Microsoft): each pixel has two wells, "
                                              "'side A in sync with the emitter, and side B exactly out of sync'"),
        "reference_waveform.duty_cycle": (0.5, "quoted: [isw2021] 'If we keep each well open for half of a modulation "
                                               "period'"),
        "reference_waveform.gauss_order": (15, "derived: no effect: the shape is 'pulse' (gauss_extended only)"),
        "reference_waveform.fourier_order": (5, "derived: no effect: the shape is 'pulse' (fourier only)"),
        # --- camera -------------------------------------------------------------------------------
        "camera.pixel_pitch_m": ([3.5e-6, 3.5e-6], "quoted: [depthcam] 'The world's smallest ToF pixel, at 3.5μm by "
                                                   "3.5μm'"),
        "camera.optical_area_m": ([640 * 3.5e-6, 576 * 3.5e-6],
                                  "derived: [hwspec] NFOV unbinned 'Resolution 640x576' of 3.5 um pixels (the mode's "
                                  "crop of the 1024 x 1024 array, [sdk] src/transformation/mode_specific_calibration.c "
                                  "l. 95)"),
        "camera.fov_deg": ([64.76, 59.42],
                           "derived: [docs] D6, the pinhole field of the calibrated focal length: one unit's depth "
                           "intrinsics in [sdk] tests/UnitTests/utcommon/inc/ut_calibration_data.h (fx, fy = "
                           "0.49282, 0.49293 x 1024 = 504.6, 504.8 px = 1.766 mm) over the 640 x 576 crop; with the "
                           "distortion below the field is 73.2° x 65.7° ([hwspec]: 'FoI 75°x65°')"),
        "camera.f_number": (1.2, "derived: not published; a wide-field ToF receive lens of the same class: [fxtof1] "
                                 "'Receive lens | FoV 87° x 67° including 940nm BPF, F=1.2'; degenerate with "
                                 "illumination.peak_power_w for the signal (P k_lens / N^2)"),
        "camera.k_lens": (0.85, "derived: not published; [sbaa217] Table 1's ToF lens: 'Transmission efficiency >85% @ "
                                "850 nm'; degenerate with illumination.peak_power_w for the signal"),
        "camera.fill_factor": (1.0, "derived: the responsivity below is an external (whole-pixel) quantum efficiency, "
                                    "microlens and fill factor inside it (tofjax's convention, docs/model.md "
                                    "'Datasheet responsivity and contrast')"),
        # --- pixel --------------------------------------------------------------------------------
        "pixel.photo_responsivity_a_per_w": (
            0.3496, "derived: [isscc] not reachable; [docs] D4: the back-illuminated ToF pixel of [mlx75027] Table 13, "
                    "'External Quantum Efficiency @ 850nm 51.0 %': 0.51 x 850 nm / 1239.84 nm = 0.350 A/W ([opt8241] "
                    "quotes the same, 'Responsivity: 0.35 A/W at 850 nm'); degenerate with "
                    "illumination.peak_power_w for the signal"),
        "pixel.collection_depth_m": (0.0, "derived: flat: behind the 37 nm band-pass (scene.filter_half_width_m) the "
                                          "background is in band, where the response is flat (docs/model.md "
                                          "'Datasheet responsivity and contrast')"),
        "pixel.demodulation_contrast": (
            0.78, "derived: [isscc] not reachable; [docs] D4: [mlx75027] Table 13 'AC demodulation contrast @ 100MHz "
                  "78 %', the highest frequency a ToF pixel's contrast is quoted at in the project's sources, taken "
                  "for all three frequencies (an upper estimate at 200-300 MHz; contrast falls with frequency); "
                  "degenerate with illumination.peak_power_w where the noise is signal-independent"),
        "pixel.c_diode_f": (
            C_EFF_F, "fitted: [docs] D5, an effective read-noise floor, not the node's capacitance (tofjax's read "
                     "noise is reset + hold kTC without correlated double sampling, sqrt(6 k T C) / e per tap): the "
                     "largest C (in steps of 0.5e-17 F) with which the specification's corner (3.86 m, 15 %, 2.2 "
                     "uW/cm^2/nm) meets 'random error std. dev. <= 17 mm' with 5 % margin in the Monte Carlo at this "
                     "power (15.95 mm over 8000 frames; tofjax compare's analytic 14.50 mm): 6.2 e- per tap (8.8 e- "
                     "A - B); every bound holds for C <= 7.1e-17 F (analytic; the Monte Carlo's corner for C <= "
                     "4.85e-17 F). [depthcam]: the random error 'is caused by shot noise': the floor lies below the "
                     "corner's 9.9 e- of shot noise. The MLX75027's '83 e-' dark noise scaled to this pixel (29 e- A - "
                     "B) would need 57.5 W, 0.97 W of light: more than the depth system's 950 mW"),
        "pixel.c_sample_and_hold_f": (C_EFF_F, "derived: equal to c_diode_f (fitted): the floor sqrt(6 k T C) / e of "
                                               "tofjax's kTC model assumes C_d = C_sh; only the floor is fitted"),
        "pixel.n_phases": (3, "derived: [docs] D1: 9 raw images per depth frame ([hwspec] '9 IR pulses'; [sdk] "
                              "src/depth_mcu/depthcommands.h 'SENSOR_MODE_LONG_THROW_NATIVE_SIZE (5310760)' = 9 x 640 x "
                              "576 x 1.6 B + 2344 B) = 3 phases at 3 frequencies, as its predecessor's '3 phases at 3 "
                              "frequencies' (libfreenect2 issue #747)"),
        "pixel.v_reset_v": (2.9, "derived: no effect: with pixel.full_well_e set and no SBI the well is full_well_e and "
                                 "the taps' voltages enter no prediction (docs/model.md 'Full well'); 2.9 V nominal"),
        "pixel.v_saturated_v": (2.0, "derived: no effect (see v_reset_v): the SBI threshold is unused (pixel.sbi "
                                     "false); 2.0 V nominal"),
        "pixel.dark_slope_mean_v_per_s": (
            round(DARK_E_PER_S * _E / (2 * C_EFF_F), 4),
            "derived: [mlx75027] Table 13 'Single tap dark current 20 51 508 ke-/s' (typical) scaled to this pixel's "
            "area ([docs] D4): 6.2 ke-/s, on the effective C_int = 2 C_eff: 6.2e3 e / C_int; 0.8 e- per 125 us "
            "phase image, below the read noise"),
        "pixel.dark_slope_sigma_v_per_s": (0.0, "derived: not published; a fixed pattern of the dark slope cancels in "
                                                "the 0/120/240 deg phasor and its electrons (< 1 e-) are negligible"),
        "pixel.dark_reference_temperature_c": (25.0, "derived: [mlx75027] Table 13 states no temperature: room "
                                                     "temperature, the top of the product's 10-25 °C ([hwspec] "
                                                     "'Operating environment')"),
        "pixel.dark_doubling_temperature_c": (7.0, "derived: silicon's dark current doubles every 5-8 °C (docs/model.md "
                                                   "'Dark current and temperature', A. Theuwissen 2009): mid-range"),
        "pixel.phase_offset_rad": (0.0, "derived: calibrated away: [hwspec] 'Azure Kinect DK is calibrated at the "
                                        "factory'; processing.calibration removes the offset"),
        "pixel.phase_drift_rad_per_c": (
            0.0, "derived: compensated: the depth engine receives the sensor's and the lasers' temperatures each frame "
                 "([sdk] include/k4ainternal/k4aplugin.h 'float sensor_temp', 'float laser_temp[2]') and "
                 "each unit's calibration carries 'ThermalAdjustmentParams'; [tolgyessy2021]: 'The device, however, "
                 "has to be warmed up for at least 40–50 min to give stable results' (a transient, not modelled)"),
        "pixel.readout_noise_e": (0.0, "derived: the whole read-noise floor is in the kTC terms (c_diode_f, fitted)"),
        "pixel.readout_nonlinearity": (0.0, "derived: not published; the factory calibration and the per-pixel gain "
                                            "selection ([depthcam]) keep the readout within its linear range; the "
                                            "spec's 'systematic error < 11 mm + 0.1%' leaves no room for more"),
        "pixel.full_well_e": (
            round(160e3 * AREA_RATIO), "derived: [mlx75027] Table 13 'Single tap full well capacity 106 [min] 160 "
                                       "[typ] ke-' scaled to this pixel's area ([docs] D4): 19.6 ke-; [depthcam] "
                                       "'Automatic per pixel gain selection enabling large dynamic range allowing near "
                                       "and far objects to be captured cleanly': the near end of the range (0.5 m, "
                                       "95 %) stays below it ([docs] D5)"),
        "pixel.sbi": (False, "derived: no background-suppression circuit is described; [depthcam] credits sunlight to "
                             "the 'Global shutter that allows for improved performance in sunlight'"),
        # --- adc ----------------------------------------------------------------------------------
        "adc.enabled": (False, "derived: the per-pixel gain selection ([depthcam]) and the 12-bit compressed raw "
                               "format ([sdk] src/dewrapper/dewrapper.c) keep the quantisation below the "
                               "temporal noise at every signal; tofjax's ADC is one linear gain, so the readout is "
                               "modelled without quantisation"),
        "adc.v_ref_pos_v": (1.075, "derived: no effect on depth with adc.enabled false: it scales the amplitude's LSB "
                                   "only (the raw format is undocumented, 'this is an area of the technology that we "
                                   "as a company are not yet ready to share', issue #509)"),
        "adc.v_ref_neg_v": (0.275, "derived: no effect on depth (see v_ref_pos_v)"),
        "adc.resolution_bits": (12, "derived: [sdk] src/dewrapper/dewrapper.c: "
                                    "'K4A_DEPTH_ENGINE_INPUT_TYPE_12BIT_COMPRESSED' (the transported raw; scales the "
                                    "amplitude's LSB only with adc.enabled false)"),
        "adc.offset_error_lsb": (0.0, "derived: no effect with adc.enabled false; a calibrated product"),
        "adc.gain_error_percent_fsr": (0.0, "derived: no effect with adc.enabled false; a calibrated product"),
        "adc.integral_nonlinearity_lsb": (0.0, "derived: no effect with adc.enabled false; a calibrated product"),
        "adc.differential_nonlinearity_lsb": (0.0, "derived: no effect with adc.enabled false; a calibrated product"),
        # --- timing and the mode's exposure --------------------------------------------------------
        "timing.readout_time_s": (1.45e-3, "quoted: [hwspec] 'Depth sensor raw timing', NFOV Unbinned: '9 | 125 us | "
                                           "8 | 1450 us | 12.8 ms' (idle time between the pulses)"),
        "timing.frame_rate_hz": (30.0, "quoted: [hwspec] NFOV unbinned 'FPS 0, 5, 15, 30'"),
        "scene.integration_time_s": (BURST_S, "quoted: [hwspec] 'Pulse Width 125 us'; [sync] 'For each depth camera "
                                              "capture, the laser turns on nine times and is active for only 125μs "
                                              "each time' (one burst per raw image: the camera's fixed exposure)"),
        "scene.integration_time_per": ("phase_image", "derived: one 125 us laser burst per raw phase image ([docs] D1)"),
        "scene.filter_half_width_m": (
            18.5e-9, "derived: the camera's band-pass is not published (a property of the camera kept in [scene]); "
                     "[opt8241] 'Integrated Optical Band-Pass Filter (830 nm to 867 nm)', an 850 nm ToF sensor's "
                     "filter: half width 18.5 nm. It must pass the laser's line, its thermal drift (~0.26 nm/K for "
                     "GaAs, a textbook value) and the oblique rays of a 75 deg lens, so a narrow filter is "
                     "excluded ([docs] D2)"),
        # --- frame --------------------------------------------------------------------------------
        "frame.baseline_m": ([-0.014, 0.0], "quoted: [gh812] wes-b (Microsoft): 'NFOV: [-14, 0, 1] ... units are "
                                            "millimeters', read as the illuminator's position from the lens (the "
                                            "reply does not say which is the origin)"),
        "frame.distortion_k1": (-0.3277, "derived: [docs] D6, the least-squares Brown-Conrady fit (k1, k2, k3) of "
                                         "the unit's rational model in ut_calibration_data.h (k1..k6 = 0.5825, "
                                         "0.00614, -0.00132, 0.9256, 0.1257, -0.00653) over the NFOV crop's field "
                                         "(r <= 1.37), residual <= 0.0024; one unit's lens, each differs"),
        "frame.distortion_k2": (0.1295, "derived: [docs] D6 (see distortion_k1)"),
        "frame.distortion_k3": (-0.0260, "derived: [docs] D6 (see distortion_k1)"),
        "frame.distortion_p1": (-1.2878e-4, "quoted: [sdk] ut_calibration_data.h, the unit's p1 "
                                            "'-0.00012877916742581874'"),
        "frame.distortion_p2": (-2.0834e-5, "quoted: [sdk] ut_calibration_data.h, the unit's p2 "
                                            "'-0.000020833556845900603'"),
        "frame.relative_illumination_exponent": (
            1.17, "derived: [docs] D6, the relative illumination of the calibrated lens, cos^4 of the field angle "
                  "times each pixel's solid angle under the distortion ((r_u / r_d)(dr_u / dr_d)), fitted as cos^m "
                  "over the crop's pixels: m = 1.17 (0.62 at the corner, 49.6 deg)"),
        "frame.vignetting": (0.0, "derived: none inside the crop: the unit's calibration is valid to 'MetricRadius "
                                  "1.737' (normalised radius), beyond the crop's corner at 0.92"),
        "frame.illumination_falloff_exponent": (
            0.0, "derived: not published; the evenest profile tofjax models: a ToF illuminator is shaped to even out "
                 "its image's exposure (as [fxtof1]'s 'batwing profile diffuser'), and the product invalidates "
                 "outside its mask ([depthcam] 'Illumination Mask') rather than letting the edge fade"),
        "frame.prnu_sigma": (0.0, "derived: corrected per pixel ([sdk] depthcommands.h 'DEVICE_NV_IR_COLUMN_GAIN_ARRAY'); "
                                  "a gain spread changes no phase, only the pixel's SNR"),
        "frame.phase_offset_sigma_rad": (0.0, "derived: calibrated per pixel ([sdk] depthcommands.h "
                                              "'DEVICE_NV_IR_P0_CORRECTION'); processing.calibration removes each "
                                              "pixel's own offset"),
        "frame.tap_asymmetry_sigma": (0.0, "derived: not published; with 3 phases a tap gain mismatch cancels in the "
                                           "phasor (docs/model.md 'Fixed pattern')"),
        "frame.threshold_sigma": (0.0, "derived: not published; it moves only each pixel's saturation, which the "
                                       "per-pixel gain selection ([depthcam]) keeps away"),
        "frame.max_phase_noise_rad": (
            0.24, "derived: [docs] D7, the invalidation of 'Low IR signal' and 'Filter outlier' ([depthcam] "
                  "'Invalidation'): the phase noise per frequency at which the 300/200/40 MHz unwrapping errs in 1 % "
                  "of frames (tofjax's unwrap_frequencies, 2e5 draws over 0.25-5.8 m); the specification's corner "
                  "(15 %, 3.86 m) lies just inside it (0.23 rad), as 'Depth may be provided outside of the operating "
                  "range ... It depends on an object's reflectivity' ([hwspec]) implies"),
        "frame.min_amplitude_lsb": (0.0, "derived: off: the low-signal invalidation acts on the signal against its "
                                         "noise (max_phase_noise_rad); an amplitude in LSB would need the undocumented "
                                         "gain"),
        # --- processing ---------------------------------------------------------------------------
        "processing.calibration": (True, "quoted: [hwspec] 'Azure Kinect DK is calibrated at the factory'; "
                                         "[depthcam] 'Multi-phase depth calculation method that enables robust "
                                         "accuracy even in the presence of chip, laser, and power supply variation'"),
        "processing.calibration_temperature_c": (
            25.0, "derived: no effect: the engine compensates temperature (pixel.phase_drift_rad_per_c 0), so the "
                  "calibration holds at every temperature; 25 °C, the top of the product's 10-25 °C ([hwspec])"),
        "processing.spatial_filter": (
            "box", "derived: [docs] D5: the engine filters spatially ([gh789], depth 'interpolated at surface edge', "
                   "labelled 'By Design'; its algorithm is closed, [sdk]); its predecessor's engine averages each "
                   "frequency's phasor over 3 x 3 Gaussian weights (sigma 3 px: a box, [lf2] l. 53-61), which tofjax's "
                   "box filters each frequency's phase before the fusion. Without a filter the corner would need "
                   "69 W, 1.17 W of light, more than the depth system's 950 mW ([depthcam2019])"),
        "processing.spatial_filter_size": (3, "derived: [lf2] l. 53-61, the predecessor's 3 x 3 kernel (see "
                                              "spatial_filter)"),
        "processing.temporal_average_frames": (1, "quoted: [gh1218] rabbitdaxi (Microsoft): 'the depth processing in "
                                                  "the SDK is per frame, we do not do temporal filtering.'"),
        "processing.amplitude_threshold": (False, "derived: off (see frame.min_amplitude_lsb)"),
        "processing.flying_pixel_m": (
            0.5, "derived: [docs] D7, the invalidation of 'pixels that contain the mixed signal from foreground and "
                 "background (such as around object edges)' ([depthcam]), which a user sees where the background is "
                 "far and not where it is near ([gh1156]): a jump of the 300 MHz unambiguity range (c / (2 x 300 MHz) "
                 "= 0.50 m), the smallest error of a wrong unwrap; tofjax filters each frequency's own depth before "
                 "the fusion, and the 40 MHz depth's noise at the specification's corner (0.13 m a pixel) stays "
                 "well below it (the corner keeps 99.2 % of its frames)"),
        "processing.flying_pixel_neighbours": (
            4, "derived: [docs] D7: a pixel beside a straight depth step has 3 neighbours across it and is kept; a "
               "mixed pixel on the step differs from all 8; 4 removes the second, keeps the first"),
    },
)
