"""The ``kinect-v2`` preset (:mod:`tofjax._presets`): the Microsoft Kinect for Xbox One / Kinect for
Windows v2 depth camera (512 x 424 pixels, 30 fps), key by key.

Its one depth mode runs three modulation frequencies of three phases each (80, 16 and 120 MHz,
derived from the open depth engine's decoder) and fuses the unwrapped phases by their mean, after a
3 x 3 joint bilateral filter of each frequency's phasor. The sensor's paper (Bamji et al., JSSC 2015)
was reachable only as its abstract (pixel, responsivity, contrast, ADC: quoted); the engine is
libfreenect2's port of the official SDK's shaders (quoted with file and line). No vendor states a
depth-noise bound with conditions; the one published characterisation with a distance law,
Fankhauser et al. (ICAR 2015), fixes the illumination's power and the pixel's read-noise floor
(fitted; fitting/validation/kinect_v2_fankhauser2015_axial_noise.csv). docs/cameras/kinect-v2.md
gives every derivation (D1-D9) and reproduces its numbers."""

from .._presets import Preset
from ._sources import FXTOF1, SBAA217

_BAMJI = ("C. S. Bamji, P. O'Connor, T. Elkhatib, S. Mehta, B. Thompson, L. A. Prather, D. Snow, O. C. Akkaya, A. Daniel, "
          "A. D. Payne, T. Perry, M. Fenton, V.-H. Chan, 'A 0.13 um CMOS System-on-Chip for a 512 x 424 Time-of-Flight "
          "Image Sensor With Multi-Frequency Photo-Demodulation up to 130 MHz and 2 GS/s ADC', IEEE J. Solid-State "
          "Circuits 50(1), 303-319, January 2015 (its first page with the abstract, docslib.org/doc/638348; the body "
          "was not reachable)")
_LF2 = ("OpenKinect/libfreenect2, the open re-implementation of the Kinect v2's depth engine, commit fd64c5d9 "
        "(2020-03-01): src/depth_packet_processor.cpp (the engine's parameters, l. 37-98), "
        "src/cpu_depth_packet_processor.cpp (the reference pipeline), src/libfreenect2.cpp (tables, defaults), "
        "src/cuda_kde_depth_packet_processor.cu, src/depth_packet_stream_parser.cpp")


def _gh(number: int, title: str, who: str) -> str:
    return f"github.com/OpenKinect/libfreenect2 issue #{number}, '{title}', {who}"


_MATHWORKS = ("MathWorks, Image Acquisition Toolbox, 'Data Streams Returned by the Kinect V2 Adaptor in MATLAB' "
              "(uk.mathworks.com/help/imaq/data-streams-returned-by-the-kinect-v2-adaptor-in-matlab.html)")
_SMEENK = ("smeenk.com, on the fields of view of the old and new Kinect for Windows (smeenk.com/tag/three-js/, 2014, "
           "'based on preliminary software and/or hardware')")
_VGLEAKS = ("vgleaks.com, 'Durango next generation Kinect sensor' (2013; leaked pre-release Xbox developer "
            "documentation, not an official publication)")
_SEMIACC = ("SemiAccurate, 'A long look at Microsoft's XBox One Kinect sensor', 2013-10-15, reporting the Hot Chips 25 "
            "talk of J. Sell and P. O'Connor (Microsoft)")
_HOTHW = "HotHardware, 'Microsoft Xbox One, The Full Review', page 5 'Kinect Performance and Features' (2013)"
_TOMS = "Tom's Hardware, Xbox One review, 'A New Kinect Camera: The Xbox One's Other Controller' (2013)"
_STUEHMER = ("J. Stuehmer, S. Nowozin, A. Fitzgibbon, R. Szeliski, T. Perry, S. Acharya, D. Cremers, J. Shotton, "
             "'Model-Based Tracking at 300Hz using Raw Time-of-Flight Observations', ICCV 2015 (abstract)")
_CHIPWORKS = ("Image Sensors World, 'Chipworks Tears Down New Kinect Camera', 2013-11-28, quoting Chipworks")
_CODINGTRAIN = ("CodingTrain/website-archive, Processing/12_kinect/sketch_12_3_PointCloud2/CameraParams.pde: one unit's "
                "factory IR intrinsics read through libfreenect2 ('camera information based on the Kinect v2 "
                "hardware')")
_FLAT = ("Q. Guo, I. Frosio, O. Gallo, T. Zickler, J. Kautz, 'Tackling 3D ToF Artifacts Through Learning and the FLAT "
         "Dataset', ECCV 2018; code github.com/NVlabs/FLAT, sim/kinect_spec.py (kinect_sin_spec, kinect_real_spec)")
_FANKHAUSER = ("P. Fankhauser, M. Bloesch, D. Rodriguez, R. Kaestner, M. Hutter, R. Siegwart, 'Kinect v2 for Mobile "
               "Robot Navigation: Evaluation and Modeling', ICAR 2015, pp. 388-394, doi:10.1109/ICAR.2015.7251485 "
               "(abstract reachable; its axial noise model read in code that implements it, see the validation file)")
_MSDOC = ("Microsoft, Kinect for Windows SDK 2.0 reference, 'DepthFrame Class' (learn.microsoft.com/en-us/"
          "previous-versions/windows/kinect/dn758543(v=ieb.10))")
_TWEAKTOWN = "TweakTown, 'iFixit opens up the new Xbox One Kinect sensor to see whats inside' (2013), news/34077"
_MLX = ("Melexis, 'MLX75027 VGA Time-of-Flight Sensor', datasheet v1.0, 15 December 2020, Table 13 (p.17): the one "
        "10 um ToF pixel with a full datasheet in the project's sources")
_CMR = ("C. Bamji, K. Salama (Canesta, now Microsoft), 'Method and system to differentially enhance sensor dynamic "
        "range using enhanced common mode reset', US 7,176,438 (the pixel family's background suppression)")
_CORTI = ("A. Corti, S. Giancola, G. Mainetti, R. Sala, 'A metrological characterization of the Kinect V2 time-of-flight "
          "camera', Robotics and Autonomous Systems 75 (2016), highlights and abstract (docslib.org/doc/13042799)")
_WASEN = ("O. Wasenmueller, D. Stricker, 'Comparison of Kinect v1 and v2 Depth Images in Terms of Accuracy and Precision', "
          "ACCV 2016 workshops, abstract")
_DOCS = "this preset's page, docs/cameras/kinect-v2.md (its derivations D1-D9)"

#: The three modulation frequencies in the engine's raw-image order (D1): 240 MHz / (3, 15, 2).
FREQUENCIES_HZ = (80e6, 16e6, 120e6)
#: One raw capture's integration (D3): ten captures (nine lit, one dark) in the 14 ms 'shutter', less the readout.
INTEGRATION_S = 1.2e-3
READOUT_S = 2.0e-4
#: The fitted signal scale and read-noise floor (D8, fitting/validation/kinect_v2_fankhauser2015_axial_noise.csv).
PEAK_POWER_W = 4.03
READ_NOISE_E = 0.0
#: The node capacitance that keeps tofjax's kTC terms negligible beside the fitted read noise (D8).
C_NODE_F = 5.0e-17
#: The 10 um ToF pixel's full well (the MLX75027's typical, the same pitch).
FULL_WELL_E = 160e3
_E = 1.602176634e-19
#: The same-pitch ToF pixel's typical dark current per tap (MLX75027, 51 ke-/s), as a slope on C_int = 2 C_node.
DARK_E_PER_S = 51e3

PRESET = Preset(
    name="kinect-v2",
    title="Microsoft Kinect for Xbox One / Kinect for Windows v2 depth camera (512 x 424, 30 fps; 80/16/120 MHz, "
          "3 phases each, libfreenect2's depth engine)",
    references={
        "bamji2015": _BAMJI, "lf2": _LF2,
        "lf2-150": _gh(150, "Questions about the depth calculation", "comment by floe (libfreenect2 developer)"),
        "lf2-172": _gh(172, "Depth image is mirrored?", "comment by wiedemeyer"),
        "lf2-338": _gh(338, "Switch off IR light", "comments by xlz and floe (libfreenect2 developers)"),
        "lf2-492": _gh(492, "store raw depth data", "comment by floe"),
        "lf2-747": _gh(747, "Getting Raw data", "comment by xlz"),
        "mathworks": _MATHWORKS, "smeenk": _SMEENK, "vgleaks": _VGLEAKS, "semiacc": _SEMIACC, "hothw": _HOTHW,
        "toms": _TOMS, "stuehmer2015": _STUEHMER, "chipworks": _CHIPWORKS, "codingtrain": _CODINGTRAIN, "flat": _FLAT,
        "fankhauser2015": _FANKHAUSER, "msdoc": _MSDOC, "tweaktown": _TWEAKTOWN, "mlx75027": _MLX, "fxtof1": FXTOF1,
        "sbaa217": SBAA217, "cmr": _CMR, "corti2016": _CORTI, "wasenmuller2016": _WASEN, "docs": _DOCS,
    },
    values={
        # --- illumination -------------------------------------------------------------------------
        "illumination.peak_power_w": (
            PEAK_POWER_W,
            "fitted: [fankhauser2015]'s axial noise at 1-4 m (fitting/validation/kinect_v2_fankhauser2015_axial_noise"
            ".csv, its stated conditions and the file's choices: 0.9 reflectivity, 300 lx fluorescent): least squares "
            "of log(model / measured) over the seven rows with pixel.readout_noise_e: 4.03 W, model / measured "
            "0.72-1.14 ([docs] D8); every row stays within a factor 2 for 1.48-8.33 W (read noise 0). Only the signal "
            "scale P R k_lens c t / N^2 is pinned (the optics' keys below are degenerate with it). tofjax's class 1 "
            "estimate for a small source puts it at 4.6 x its limit (average power); three lasers behind "
            "patterned filters ([chipworks]) that spread them over 70 x 60 deg are an extended source, whose limit "
            "is C6 = alpha / 1.5 mrad higher: alpha >= 7.2 "
            "mrad (0.72 mm seen from 100 mm) meets it ([docs] D9)"),
        "illumination.wavelength_m": (
            860e-9, "derived: [bamji2015] abstract: 'a responsivity of 0.14 A/W at 860 nm', the sensor's stated "
                    "wavelength, taken as the lasers' (no emitter wavelength is published)"),
        "illumination.fov_deg": (
            [70.6, 60.0], "derived: the illuminator lights the depth camera's field (camera.fov_deg's 70.6 x 60 "
                          "deg with the lens' distortion, [smeenk], [vgleaks] '70 horizontal by 60 vertical'): no "
                          "illumination field is published; [chipworks]: 'three laser diodes, and the filters over "
                          "them are patterned with what looks like a grid'; the pixels beyond the spot's 42.4 deg corner "
                          "(the lens' corners reach 44.6 deg: 3.8 % of the pixels) are outside it in a frame"),
        # --- illumination waveform -------------------------------------------------------------------
        "illumination_waveform.modulation_frequency_hz": (
            FREQUENCIES_HZ[0],
            "derived: [docs] D1: [lf2] src/cuda_kde_depth_packet_processor.cu l. 328 'the sequence of modulation "
            "frequencies 16, 80 and 120 MHz'; the decoder scales the three wrapped phases by 3, 15 and 2 "
            "(cpu_depth_packet_processor.cpp l. 623-625), i.e. 240 MHz / 3, / 15, / 2, and the fused phase by "
            "unambigious_dist 2083.333 mm = c / (2 x 72 MHz) (depth_packet_processor.cpp l. 64): 80, 16, 120 MHz in "
            "the raw images' order; [bamji2015] 'Multi-Frequency Photo-Demodulation up to 130 MHz'"),
        "illumination_waveform.extra_modulation_frequencies_hz": (
            list(FREQUENCIES_HZ[1:]), "derived: [docs] D1 (see modulation_frequency_hz): 16 and 120 MHz; extended "
                                      "range c / (2 x 8 MHz) = 18.7 m"),
        "illumination_waveform.frequency_fusion": (
            "phase_average",
            "quoted: [lf2] cpu_depth_packet_processor.cpp l. 645-649 't6 *= 0.333333f; t7 *= 0.066667f; ... float t9 "
            "= (t8 + t6 + t7); ... float t10 = t9 * 0.333333f; // some avg': the mean of the three unwrapped phases "
            "(in cycles of each frequency), weights 1 / d_u in distance"),
        "illumination_waveform.shape": (
            "sine", "derived: [flat] sim/kinect_spec.py models the Kinect 2's correlation ('kinect_real_spec', its "
                    "parameters loaded from a camera-function file) as a sinusoid at each frequency, clipped at the "
                    "16 MHz one ('for i in range(3,6): ... np.maximum(np.minimum(...)'): a sinusoidal emission "
                    "against the pixel's square gate gives that sinusoid at 80 and 120 MHz, which carry 93 % of "
                    "the fusion's weight; the 16 MHz clipping is not modelled ([docs] D2)"),
        "illumination_waveform.duty_cycle": (1.0, "derived: duty 1 is tofjax's pure sinusoid (docs/model.md "
                                                  "'Waveforms'; see shape)"),
        "illumination_waveform.gauss_order": (15, "derived: no effect: the shape is 'sine' (gauss_extended only)"),
        "illumination_waveform.fourier_order": (5, "derived: no effect: the shape is 'sine' (fourier only)"),
        # --- reference waveform -------------------------------------------------------------------
        "reference_waveform.shape": (
            "pulse", "derived: a 2-tap differential pixel ([semiacc]: 'a dual ported sensor array'; the raw samples "
                     "are signed A - B: [lf2] src/libfreenect2.cpp l. 137-138 'lut[x] = y; lut[1024 + x] = -y;'), "
                     "each tap gated by a square wave of the modulation clock"),
        "reference_waveform.duty_cycle": (0.5, "derived: each tap open half a period (see shape)"),
        "reference_waveform.gauss_order": (15, "derived: no effect: the shape is 'pulse' (gauss_extended only)"),
        "reference_waveform.fourier_order": (5, "derived: no effect: the shape is 'pulse' (fourier only)"),
        # --- camera -------------------------------------------------------------------------------
        "camera.pixel_pitch_m": ([10e-6, 10e-6], "quoted: [bamji2015] abstract: 'The 10 um x 10 um pixel "
                                                 "incorporates a TOF detector'"),
        "camera.optical_area_m": ([512 * 10e-6, 424 * 10e-6], "derived: [bamji2015] title '512 x 424' pixels of 10 um"),
        "camera.fov_deg": (
            [70.02, 60.24],
            "derived: [docs] D7, the pinhole field of the calibrated focal length: one unit's factory intrinsics "
            "([codingtrain] 'fx = 365.456f', 3.65 mm at 10 um) over 512 x 424 pixels; with the distortion below "
            "the field is 70.56 x 60.04 deg ([smeenk]: 'a fov of 70.6 x 60 degrees')"),
        "camera.f_number": (1.2, "derived: not published; a wide-field ToF receive lens of the same class, [fxtof1] "
                                 "'Receive lens | FoV 87 x 67 including 940nm BPF, F=1.2'; degenerate with "
                                 "illumination.peak_power_w (fitted): the signal is P k_lens / N^2"),
        "camera.k_lens": (0.85, "derived: not published; [sbaa217] Table 1's ToF lens 'Transmission efficiency >85% "
                                "@ 850 nm'; degenerate with illumination.peak_power_w (fitted)"),
        "camera.fill_factor": (1.0, "derived: [bamji2015]'s responsivity is the pixel's, fill factor inside it "
                                    "(tofjax's convention, docs/model.md 'Datasheet responsivity and contrast')"),
        # --- pixel --------------------------------------------------------------------------------
        "pixel.photo_responsivity_a_per_w": (0.14, "quoted: [bamji2015] abstract: 'a responsivity of 0.14 A/W at "
                                                   "860 nm' (QE 0.20)"),
        "pixel.demodulation_contrast": (
            0.67, "quoted: [bamji2015] abstract: 'achieves a modulation contrast of 67% at 50 MHz'; tofjax takes one "
                  "contrast for the three frequencies (the engine's per-frequency amplitude scales 1.322581, 1.0, "
                  "1.612903, [lf2] depth_packet_processor.cpp l. 40-42, suggest less at 80 and 120 MHz: absorbed "
                  "by the fitted power, [docs] D8)"),
        "pixel.n_phases": (3, "quoted: [lf2-150] floe: 'the 9 images are divided into three groups. Within each group, "
                              "the images correspond to phase-shifts of the modulation signal by 0°, 120° and 240°'; "
                              "[lf2-747] xlz: '3 phases at 3 frequencies. 3x3=9.'"),
        "pixel.collection_depth_m": (0.0, "derived: a flat response (0): with the 30 nm band-pass (scene."
                                          "filter_half_width_m) the background's photons all lie within 4 % of 860 nm"),
        "pixel.c_diode_f": (
            C_NODE_F, "derived: degenerate with pixel.readout_noise_e (fitted): tofjax's kTC is reset plus hold "
                      "without correlated double sampling, so the capacitances are an effective node; 5e-17 F keeps "
                      "them at 4.0 and 5.7 e- per tap and leaves the read floor to readout_noise_e ([docs] D8)"),
        "pixel.c_sample_and_hold_f": (C_NODE_F, "derived: equal to c_diode_f (see there)"),
        "pixel.v_reset_v": (2.9, "derived: no effect: with pixel.full_well_e set the well and the SBI threshold are "
                                 "full_well_e (docs/model.md 'Full well'); 2.9 V nominal"),
        "pixel.v_saturated_v": (2.0, "derived: no effect (see v_reset_v); 2.0 V nominal"),
        "pixel.dark_slope_mean_v_per_s": (
            round(DARK_E_PER_S * _E / (2 * C_NODE_F), 4),
            "derived: not published; the same-pitch ToF pixel's typical dark current ([mlx75027] Table 13 'Single "
            "tap dark current 20 51 508 ke-/s') on C_int = 2 x c_diode_f: 51 ke-/s, 61 e- per 1.2 ms phase image "
            "(7.8 e- of shot noise, part of the floor the fit sees)"),
        "pixel.dark_slope_sigma_v_per_s": (0.0, "derived: a fixed pattern of the dark slope cancels in the "
                                                "0/120/240 deg phasor (docs/model.md 'Noise') and its electrons are "
                                                "few (61 e-)"),
        "pixel.dark_reference_temperature_c": (25.0, "derived: [mlx75027] Table 13 states no temperature: room "
                                                     "temperature"),
        "pixel.dark_doubling_temperature_c": (7.0, "derived: silicon's dark current doubles every 5-8 °C (docs/model.md "
                                                   "'Dark current and temperature', A. Theuwissen 2009): mid-range"),
        "pixel.phase_offset_rad": (0.0, "derived: calibrated away: the device's factory per-pixel phase offsets (P0 "
                                        "tables, one per frequency) are added to each phase step, [lf2] "
                                        "cpu_depth_packet_processor.cpp l. 359 'float p0 = -((float)p0table.at(y, x))"
                                        " * 0.000031 * M_PI;'; processing.calibration removes the offset"),
        "pixel.phase_drift_rad_per_c": (
            0.0, "derived: the warmed-up state: the sensor is cooled by a fan ([tweaktown] 'the Kinect now packed "
                 "enough power that a Fan is required to keep things nice and cool'); a temperature influence is "
                 "reported ([corti2016] 'The temperature of the Kinect V2 has an influence in the distance "
                 "measurement'; [wasenmuller2016] lists temperature among the 'influencing factors') but no coefficient "
                 "was reachable; the characterisation it is fitted to is of a running camera"),
        "pixel.readout_noise_e": (
            READ_NOISE_E,
            "fitted: with illumination.peak_power_w to [fankhauser2015]'s seven rows (1-4 m): the least-squares "
            "optimum is 0 e- per tap beyond the kTC and dark-shot floor (10.5 e-): the axial noise flattens towards "
            "1 m (1.30 mm at 1 m, 1.43 mm at 1.5 m), so the data leave no room for a floor that grows faster with "
            "distance than shot noise; every row stays within a factor 2 up to 77 e- (power refitted) ([docs] D8)"),
        "pixel.readout_nonlinearity": (0.0, "derived: not published; the engine reads the samples through a fixed "
                                            "table ([lf2] libfreenect2.cpp l. 133-142) and no gain compression is "
                                            "stated: a linear readout"),
        "pixel.full_well_e": (
            FULL_WELL_E, "derived: not published ([bamji2015]'s body); the one 10 um ToF pixel with a datasheet in "
                         "the project's sources, [mlx75027] Table 13 'Single tap full well capacity 106 [min] 160 "
                         "[typ] ke-': 160 ke-; a white target at 0.5 m fills 30 % of it ([docs] D8)"),
        "pixel.sbi": (
            True, "derived: [fankhauser2015] evaluates the camera 'outdoors in overcast and direct sunlight "
                  "situations': direct sun (100 klx on a 50 % target) puts 1.27 full wells of background into a "
                  "tap in one phase image behind the band-pass, so the camera needs a background suppression ([docs] D3); the sensor's group owns the common-mode reset "
                  "([cmr] 'Common mode reset is achieved by resetting storage capacitors ... before storage potential "
                  "exceeds a saturation voltage'), which tofjax's SBI emulates; indoors it never acts"),
        # --- adc ----------------------------------------------------------------------------------
        "adc.enabled": (
            False, "derived: [docs] D4: the raw samples are not a linear code: 11 bits (sign and 10 bits, [lf2] "
                   "depth_packet_stream_parser.cpp l. 42 '512*424*11/8') expanded by a table to +-16320 "
                   "(libfreenect2.cpp l. 133-142: step 1 below 256 codes, then doubling every 128 codes to 64), a "
                   "floating-point code with a 0.4-0.8 % step whose quantisation noise is below the shot noise; "
                   "tofjax's ADC is one linear gain, so the readout is modelled without quantisation"),
        "adc.resolution_bits": (10, "quoted: [bamji2015] abstract: 'The TOF sensor includes a 2 GS/s 10 bit signal "
                                    "path' (no effect with adc.enabled false)"),
        "adc.v_ref_pos_v": (1.075, "derived: no effect on depth with adc.enabled false: it scales the amplitude's LSB "
                                   "only (the table's electron scale is not published)"),
        "adc.v_ref_neg_v": (0.275, "derived: no effect on depth (see v_ref_pos_v)"),
        "adc.offset_error_lsb": (0.0, "derived: no effect with adc.enabled false"),
        "adc.gain_error_percent_fsr": (0.0, "derived: no effect with adc.enabled false"),
        "adc.integral_nonlinearity_lsb": (0.0, "derived: no effect with adc.enabled false"),
        "adc.differential_nonlinearity_lsb": (0.0, "derived: no effect with adc.enabled false"),
        # --- timing and the mode's exposure --------------------------------------------------------
        "timing.frame_rate_hz": (30.0, "quoted: [mathworks] 'DEPTH_512X424 Resolution of 512 x 424, frame rate of 30 "
                                       "frames per second'; [lf2-338] xlz: 'Every second 30 frames are transmitted "
                                       "from Kinect'"),
        "timing.readout_time_s": (
            READOUT_S, "derived: [docs] D3: [bamji2015] '2 GS/s': 512 x 424 pixels converted once each take 0.11 ms, "
                       "twice (both taps) 0.22 ms; 0.2 ms between raw captures (with the exposure below, ten "
                       "captures fill the 14 ms 'shutter' of [hothw])"),
        "scene.integration_time_s": (
            INTEGRATION_S,
            "derived: [docs] D3: a frame is ten raw captures, nine lit and one dark ([lf2-338] xlz: 'Each frame has "
            "10 layers. the 10-th layer is obtained with IR led turned off'), 'taken in quick succession near the "
            "beginning of each depth frame' ([stuehmer2015]) within a 'shutter speed of 14ms' ([hothw]; [toms] "
            "'reducing motion blur to less than 14 ms'): 1.4 ms per capture less the 0.2 ms readout; degenerate "
            "with illumination.peak_power_w (fitted) for the signal"),
        "scene.integration_time_per": ("phase_image", "derived: one raw capture per phase image (see "
                                                      "integration_time_s)"),
        "scene.filter_half_width_m": (
            30e-9, "derived: not published; [docs] D3: a band-pass centred for 860 nm must pass the corner's chief ray "
                   "(44.5 deg, D7), where an interference filter (effective index about 2, a typical value) shifts "
                   "6.3 % to the blue: 58 nm of pass band, +-29 nm, rounded to +-30 nm (the laser's thermal drift "
                   "adds a few nm)"),
        # --- frame --------------------------------------------------------------------------------
        "frame.baseline_m": (
            [-0.045, 0.0],
            "derived: [docs] D5, from the engine's correction for an emitter beside the lens: [lf2] "
            "cpu_depth_packet_processor.cpp l. 702-704 'xmultiplier = (xmultiplier * 90) / (max_depth * max_depth "
            "* 8192.0); float depth_fit = depth_linear / (-depth_linear * xmultiplier + 1);' with xtable = 8192 x_u "
            "(libfreenect2.cpp l. 115, 126) adds 22.5 mm x_u z^2 / d^2, the first-order path of an emitter 45 mm along "
            "the engine's +x; its images are mirrored ([lf2-172] 'Yes, all images are mirrored'), so -45 mm in the "
            "camera's own x (the sign rests on that reading)"),
        "frame.distortion_k1": (0.0905474, "quoted: [codingtrain] 'static float k1 = 0.0905474;' (one unit's factory "
                                           "value; OpenCV's model, [lf2] libfreenect2.cpp l. 152)"),
        "frame.distortion_k2": (-0.26819, "quoted: [codingtrain] 'static float k2 = -0.26819;' (one unit)"),
        "frame.distortion_k3": (0.0950862, "quoted: [codingtrain] 'static float k3 = 0.0950862;' (one unit)"),
        "frame.distortion_p1": (0.0, "quoted: [codingtrain] 'static float p1 = 0.0;' (one unit)"),
        "frame.distortion_p2": (0.0, "quoted: [codingtrain] 'static float p2 = 0.0;' (one unit)"),
        "frame.relative_illumination_exponent": (
            3.6, "derived: [docs] D7, the calibrated lens' relative illumination, cos^4 of the field angle times "
                 "each pixel's solid angle under the distortion ((r_u / r_d)(dr_u / dr_d)), fitted as cos^m over the "
                 "pixels (least squares, rms 0.035): m = 3.6 (0.46 at the corner, 44.5 deg)"),
        "frame.vignetting": (0.0, "derived: not published; the relative illumination above is the lens' whole "
                                  "off-axis falloff"),
        "frame.illumination_falloff_exponent": (
            0.0, "derived: not published; the evenest profile tofjax models: a flood illuminator behind patterned "
                 "filters ([chipworks]) is shaped to even out its image's exposure"),
        "frame.prnu_sigma": (0.01, "derived: not published, and not corrected: the device hands the engine per-pixel "
                                   "phase (P0) tables and lens parameters, no gain table ([lf2]); a CMOS sensor's usual "
                                   "1 % (the thesis camera's); it changes no phase"),
        "frame.phase_offset_sigma_rad": (0.0, "derived: removed per pixel by the factory P0 tables (see "
                                              "pixel.phase_offset_rad)"),
        "frame.tap_asymmetry_sigma": (0.0, "derived: not published; with 3 phases a tap gain mismatch cancels in the "
                                           "phasor (docs/model.md 'Fixed pattern')"),
        "frame.threshold_sigma": (0.0, "derived: not published; it moves only each pixel's saturation and SBI "
                                       "threshold, which indoor scenes do not reach"),
        "frame.max_phase_noise_rad": (
            0.21, "derived: [docs] D6, the engine's low-signal invalidation: after the bilateral filter a pixel is "
                  "dropped where its neighbours' phasor directions disagree ('joint_bilateral_max_edge = 2.5f', [lf2] "
                  "cpu_depth_packet_processor.cpp l. 569) or its three unwrapped phases stray from the line (80, 16, "
                  "120) by more than thr = clamp(12.89 a^-0.533, 0.349, 0.611) rad (l. 656-681; 0.611 for a weak "
                  "signal); a Monte Carlo of that code (2e5 draws per point, a flat surface at 0.5-4.5 m) delivers "
                  "half the frames at 0.62 rad of phase noise per pixel and frequency, which tofjax's 3 x 3 box "
                  "(the threshold reads the filtered noise) makes 0.62 / 3 = 0.21 rad: the preset flags a 20 % target "
                  "from 7.8 m, a 10 % one from 5.5 m, a 5 % one from 3.9 m (fused noise 40 mm); [msdoc]: 'The maximum "
                  "depth distance is 8 meters, although reliability starts to degrade at around 4.5 meters'"),
        "frame.min_amplitude_lsb": (0.0, "derived: off: the engine's amplitude thresholds ('individual_ab_threshold = "
                                         "3', 'ab_threshold = 10', [lf2] l. 65-66) are in the table's units, whose "
                                         "electron scale is not published; low signal is max_phase_noise_rad's"),
        # --- processing ---------------------------------------------------------------------------
        "processing.calibration": (
            True, "derived: the factory per-pixel phase offsets are removed ([lf2] P0 tables, see "
                  "pixel.phase_offset_rad); no wiggling table is visible in the engine, and the sinusoidal "
                  "correlation (illumination_waveform.shape) has no wiggling, so tofjax's calibration acts as the "
                  "P0 correction"),
        "processing.calibration_temperature_c": (25.0, "derived: no effect: pixel.phase_drift_rad_per_c is 0 (the "
                                                       "warmed-up state)"),
        "processing.spatial_filter": (
            "box", "derived: [docs] D6: the engine's joint bilateral filter ([lf2] cpu_depth_packet_processor.cpp "
                   "l. 486-576, on by default: libfreenect2.cpp l. 733 'EnableBilateralFilter(true)'; the SDK's "
                   "shaders, [lf2-492] floe: 'the conversion code is modelled on the GPU shaders used by the "
                   "official SDK') averages each frequency's phasor over 3 x 3 Gaussian weights (depth_packet_"
                   "processor.cpp l. 53-61: 0.1069973, 0.1131098, 0.1195716), (sum w)^2 / sum w^2 = 8.99 pixels, "
                   "with a range weight exp(-7.21 (1 - cos dphi) / 2) that averages 0.985 at the rows' largest "
                   "phase noise (0.066 rad a pixel at 4 m; filtered noise within 0.3 % of the box's): on a flat surface "
                   "a 3 x 3 box (9 pixels), which tofjax applies to each frequency's phase "
                   "before the fusion"),
        "processing.spatial_filter_size": (3, "quoted: [lf2] cpu_depth_packet_processor.cpp l. 528-530 'for(int yi = "
                                              "-1; yi < 2; ++yi) { for(int xi = -1; xi < 2; ++xi, ++j)' (3 x 3)"),
        "processing.temporal_average_frames": (1, "derived: the engine has no temporal filter ([lf2]: each frame "
                                                  "from its own ten captures)"),
        "processing.amplitude_threshold": (False, "derived: off (see frame.min_amplitude_lsb)"),
        "processing.flying_pixel_m": (
            0.0, "derived: off ([docs] D6): the engine's edge-aware filter ([lf2] cpu_depth_packet_processor.cpp l. "
                 "725-803, on by default) removes a pixel lying more than 'edge_close_delta_threshold = 50.0f' mm "
                 "behind its nearest neighbour and 'edge_far_delta_threshold = 30.0f' in front of its farthest (one "
                 "of them above 100 mm) where the 3 x 3 IR also varies by 5 % or more, on the fused depth: a mixed "
                 "pixel on a depth step, never a flat surface; tofjax runs its filter on each frequency's phase "
                 "before the fusion (docs/model.md), where 50 mm meets the 16 MHz depth's own noise (32 mm a pixel "
                 "at 4 m on a white wall) and would drop 1.6 % of a white wall's frames at 4 m and 72 % of a 20 % "
                 "one's, which the product keeps; 100 mm still drops 11 % of the 20 % wall's. The product's "
                 "removal of mixed pixels at steps is not modelled"),
        "processing.flying_pixel_neighbours": (4, "derived: no effect with flying_pixel_m 0; 4 is the mapping's "
                                                  "count (more than the 3 neighbours across a straight step, fewer "
                                                  "than the 6 a pixel on the step differs from), should it be "
                                                  "switched on"),
    },
)
