"""The ``melexis-mlx75027`` preset (:mod:`tofjax._presets`): a *reference camera* on the Melexis
MLX75027 VGA time-of-flight sensor, not a product.

The sensor is the datasheet's, key by key (quoted, or derived from its numbers). No camera built on
the sensor documents its illumination, lens or filter, so the camera side is derived: the datasheet's
use case B ("Performance": 100 MHz, 600 us per phase, 60 fps), a 940 nm illumination at the IEC 60825-1
class 1 bound of tofjax's estimator over a stated field of view, a lens of stated typical values, and the
widest band-pass filter that the datasheet's "120KLUX robust" statement allows. docs/cameras/melexis-mlx75027.md
gives every argument and what stays open."""

from .._presets import Preset
from ._sources import FXTOF1, SBAA217, TOFJAX_CLASS1, typical_relative_illumination

_MLX = ("Melexis, 'MLX75027 VGA Time-of-Flight Sensor', datasheet v1.0, document 3901075027, 15 December 2020 "
        "(page numbers 'Page N of 67'; copy in github.com/rzw2/mlx75027_config, "
        "doc/MLX75027-Datasheet-Melexis_v1.0.pdf, commit 0501f11)")

#: Derived circuit numbers (docs/cameras/melexis-mlx75027.md, "The pixel's circuit keys"). The 83 e- "Pixel dark
#: noise" is the A-B output's, quantisation (94.34 e- per DN / sqrt 12 = 27.2 e-) included; its analog part
#: sqrt(83^2 - 27.2^2) = 78.4 e- is sqrt 2 x 55.4 e- per tap, tofjax's reset plus hold kTC sqrt(6 k T C) / e at
#: 25 degC with C_diode = C_sample_and_hold = C.
_C_F = 3.19e-15
_E_PER_V = 2 * _C_F / 1.602176634e-19  # C_int / e, electrons per volt
_NOTE_C = ("derived: [mlx75027] Table 13 (p.17) 'Pixel dark noise 83 e-', read as the noise of the pixel's A-B "
           "output (the table writes 'Single tap' before every per-tap row, its dark current, full well and "
           "conversion gain, and 'Pixel' here; A-B is the default output, p.32), measured on the output and so "
           "with its quantisation: one DN is 1/0.0106 = 94.3 e- (Table 13), 27.2 e- rms; the analog rest "
           "sqrt(83^2 - 27.2^2) = 78.4 e- is sqrt 2 x 55.4 e- per tap; tofjax's kTC per tap (reset on C_int plus "
           "hold on C_sh) with equal capacitances (the split is not stated; the thesis' pixel splits equally) is "
           "sqrt(6 k T C) / e: C = 3.19 fF at 25 degC; the model's dark A-B output noise is 82.9 e- (83.3 e- with "
           "600 us of dark current). An "
           "effective node, not the circuit: 160 ke- on 6.38 fF is a 4.0 V swing. Read per tap instead, C would be "
           "6.39 fF and the far-range depth noise up to sqrt 2 higher (docs/cameras/melexis-mlx75027.md)")
_UNIFORM = ("derived: [mlx75027] states one typical pixel (Table 13, p.17) and no pixel-to-pixel spread (its local "
            "and global PDNU are 'tbd'): the reference camera's pixels are all that typical pixel (0)")
_NO_FILTER = "quoted: [mlx75027] p.58, the datasheet's distance calculation: a plain 4-phase atan2 without filters"
_UNUSED_SHAPE = "derived: not read by the 'pulse' shape (no effect); the default is kept"

PRESET = Preset(
    name="melexis-mlx75027",
    title="Melexis MLX75027 reference camera, NOT a product: the sensor's datasheet v1.0 with its use case B "
          "(100 MHz, 600 us, 60 fps) and a derived 940 nm class 1 illumination, lens and band-pass filter",
    references={"mlx75027": _MLX, "fxtof1": FXTOF1, "sbaa217": SBAA217, "tofjax": TOFJAX_CLASS1},
    values={
        # --- the illumination: derived (no MLX75027 camera documents its own)
        "illumination.peak_power_w": (
            3.0, "derived: the IEC 60825-1 class 1 bound at this camera's field of view, wavelength, duty and frame "
                 "timing, with [tofjax]'s estimator: 940 nm (C4 = 3.02), a flat 87 x 67 deg field (brightest at its "
                 "corner: 5.47e-3 of the peak power into the 7 mm aperture), 50 % duty, 4 x 600 us at 60 fps (lit "
                 "14.4 %): the average power binds at 3.02 W (one phase image at 4.9 W); 3.0 W is 0.994 of the "
                 "limit. A small source is the strictest case: a diffuser's larger apparent source allows more, "
                 "so a product may be brighter"),
        "illumination.wavelength_m": (
            940e-9, "derived: one of the two wavelengths [mlx75027] quotes its quantum efficiency at (p.1, Table 13: "
                    "'51% (850nm)', '28% (940nm)'); 940 nm for the sunlight the datasheet claims ('120KLUX robust "
                    "when using lens with filter', p.1), as the VGA ToF reference design [fxtof1] ('940nm VCSEL'); at "
                    "850 nm the responsivity is 1.65x, the class 1 bound 0.66x"),
        "illumination.fov_deg": (
            [87.0, 67.0], "derived: matched to the lens (camera.fov_deg), a typical VGA ToF illumination: [fxtof1] "
                          "'940nm VCSEL with 87° x 67° batwing profile diffuser'; no MLX75027 camera states its own"),
        # --- the lens: stated typical values
        "camera.k_lens": (
            0.85, "derived: a typical ToF lens' transmission, [sbaa217] Table 1 'Transmission efficiency >85% @ "
                  "850 nm', taken as this lens' with its band-pass filter at 940 nm; the sensor has 'no optical "
                  "filter' ([mlx75027] p.6) and its cover glass is inside the quoted EQE; a filter's own in-band "
                  "loss is stated nowhere here (at 0.9 it would be 0.77)"),
        "camera.f_number": (
            1.2, "derived: a typical ToF lens: [fxtof1] 'Receive lens: FoV 87° x 67° including 940nm BPF, F=1.2', "
                 "[sbaa217] Table 1 'F.No 1.2'; [mlx75027] p.19 asks for 'low F-number'"),
        "camera.fov_deg": (
            [87.0, 67.0], "derived: a typical VGA ToF lens, [fxtof1] 'Receive lens: FoV 87° x 67°' (on the "
                          "MLX75027's 6.4 x 4.8 mm array: a focal length of about 3.4 mm)"),
        "camera.pixel_pitch_m": ([10e-6, 10e-6], "quoted: [mlx75027] Table 13 (p.17) 'Pixel pitch 10 µm'"),
        "camera.optical_area_m": (
            [6.4e-3, 4.8e-3], "quoted: [mlx75027] Fig. 14 (p.18) '6.4mm (640 x 0.01 mm)', '4.8mm (480 x 0.01 mm)'"),
        "camera.fill_factor": (
            1.0, "derived: [mlx75027] Table 13 note 1 (p.17) computes the EQE from the responsivity 'x FF': the "
                 "quoted EQE is the whole pixel's ('Integrated microlenses', p.1), the fill factor inside it"),
        # --- the pixel
        "pixel.photo_responsivity_a_per_w": (
            0.2123, "derived: [mlx75027] Table 13 (p.17) 'External Quantum Efficiency @ 940nm 28.0 %': R = EQE "
                    "lambda / 1239.84 nm = 0.2123 A/W"),
        "pixel.collection_depth_m": (
            30e-6, "fitted: [mlx75027] Fig. 12 (p.17), EQE against wavelength read at 760-980 nm (+-0.5 points: "
                   "64.8 % at 760 nm, 50.6 % at 850, 29.1 % at 940, 20.7 % at 980), least squares of eta (1 - "
                   "exp(-alpha_Si d)): d = 31 um, eta = 0.65, rms 1.8 points (d = 25-35 um within 2.6 points); it "
                   "weights the background light inside the filter only"),
        "pixel.demodulation_contrast": (
            0.78, "quoted: [mlx75027] Table 13 (p.17) 'AC demodulation contrast @ 100MHz 78 %' (p.1 likewise), at the "
                  "use case's 100 MHz (Fig. 11 reads 78.5 % at 30 degC, 68.4 % at 105 degC: tofjax keeps one "
                  "contrast)"),
        "pixel.c_diode_f": (_C_F, _NOTE_C),
        "pixel.c_sample_and_hold_f": (_C_F, _NOTE_C),
        "pixel.readout_noise_e": (
            0.0, "derived: all of the quoted 'Pixel dark noise 83 e-' ([mlx75027] Table 13) is in the kTC noise of "
                 "pixel.c_diode_f: nothing is left for a further readout noise"),
        "pixel.n_phases": (4, "quoted: [mlx75027] p.12, use case B: '4 raw phases per distance frame'"),
        "pixel.full_well_e": (160e3, "quoted: [mlx75027] Table 13 (p.17) 'Single tap full well capacity 106 [min] 160 "
                                     "[typ] ke-'"),
        "pixel.v_reset_v": (
            160e3 / _E_PER_V, "derived: the swing that holds the quoted full well (160 ke-, [mlx75027] Table 13) on "
                              "the effective C_int = 6.38 fF of pixel.c_diode_f, from 0 V: 160e3 e / C_int = 4.02 V; "
                              "it sets only the reported tap voltages (the full well is pixel.full_well_e)"),
        "pixel.v_saturated_v": (0.0, "derived: the bottom of the effective node's swing (pixel.v_reset_v); SBI is off, "
                                     "so no threshold reads it"),
        "pixel.dark_slope_mean_v_per_s": (
            51e3 / _E_PER_V, "derived: [mlx75027] Table 13 (p.17) 'Single tap dark current 20 51 508 ke-/s' (min "
                             "typ max): 51 ke-/s x e / C_int (6.38 fF) = 1.281 V/s, i.e. 31 e- per 600 us phase image"),
        "pixel.dark_slope_sigma_v_per_s": (0.0, _UNIFORM),
        "pixel.dark_reference_temperature_c": (
            25.0, "derived: [mlx75027] Table 13 states no temperature; its typical values taken at room temperature, "
                  "25 degC (Fig. 11's typical curve is 30 degC: the dark current would change by 2^(5/7))"),
        "pixel.dark_doubling_temperature_c": (
            7.0, "derived: silicon image sensors double their dark current every 5-8 degC (A. Theuwissen, Harvest "
                 "Imaging, 2009; tofjax's value); [mlx75027]'s typ-to-max ratio of 10 (Table 13) would be 23 degC "
                 "of heating at 7 degC, a plausible hot corner (its conditions are not stated)"),
        "pixel.phase_offset_rad": (
            0.0, "derived: a camera trims its constant delay with the sensor's analog delay between illumination and "
                 "mixing ([mlx75027] p.45: coarse 1.25 ns at 100 MHz, fine ~75 ps, super fine ~20 ps, 3 mm of "
                 "distance): the reference camera is trimmed to 0"),
        "pixel.phase_drift_rad_per_c": (
            8.03e-4, "quoted: [mlx75027] Table 13 (p.17) 'Phase drift over temperature 0.046 deg/°C' (note 3: "
                     "'Stability of the calculated phase (= distance) over temperature'): 8.03e-4 rad/degC, the "
                     "sensor's; its sign is not stated (taken as reading longer when warm), and a camera's emitter "
                     "and driver add their own drift, documented for none"),
        "pixel.readout_nonlinearity": (
            0.0, "derived: [mlx75027] states one conversion gain for the tap ('0.0106 DN/e-', Table 13), a linear "
                 "transfer, and no nonlinearity"),
        "pixel.sbi": (
            False, "derived: [mlx75027] describes no background suppression; a full tap is only flagged ('This data "
                   "can be used as indicator to warn for pixel saturation', p.50), and the sunlight robustness is "
                   "the filter's ('To avoid pixel saturation under strong sunlight an optical bandpass filter is "
                   "highly recommended', p.19)"),
        # --- waveforms
        "illumination_waveform.shape": (
            "pulse", "derived: the sensor drives the illumination with a digital signal, LEDP/LEDN ([mlx75027] "
                     "p.55, subLVDS); the reference emitter follows it (its rise and fall, not documented, would "
                     "round it towards a sine)"),
        "illumination_waveform.duty_cycle": (0.5, "quoted: [mlx75027] p.54 'The default duty cycle is 50%'"),
        "illumination_waveform.gauss_order": (15, _UNUSED_SHAPE),
        "illumination_waveform.fourier_order": (5, _UNUSED_SHAPE),
        "illumination_waveform.modulation_frequency_hz": (
            100e6, "quoted: [mlx75027] p.12, use case B ('Performance'): '100 MHz modulation frequency'"),
        "illumination_waveform.extra_modulation_frequencies_hz": (
            [], "quoted: [mlx75027] p.12, use case B: one frequency, '4 raw phases per distance frame'"),
        "illumination_waveform.frequency_fusion": ("inverse_variance", "derived: one frequency: nothing to fuse"),
        "reference_waveform.shape": (
            "pulse", "derived: the pixel's mixing signals are digital ([mlx75027] p.44: 'DMIX0 & DMIX1, that actively "
                     "forces a guiding field inside the pixel'); the pixel's finite response is in the quoted "
                     "contrast"),
        "reference_waveform.duty_cycle": (
            0.5, "derived: [mlx75027] p.32 'tap A and tap B, each in counterphase (180° shifted) of one another': "
                 "each tap collects half the period"),
        "reference_waveform.gauss_order": (15, _UNUSED_SHAPE),
        "reference_waveform.fourier_order": (5, _UNUSED_SHAPE),
        # --- the ADC
        "adc.enabled": (True, "quoted: [mlx75027] p.25 'Each DepthSense pixel is represented by 12bit data'"),
        "adc.resolution_bits": (12, "quoted: [mlx75027] p.32 'Mode A-B (=12bit signed data)', the default output"),
        "adc.v_ref_pos_v": (
            2048 / 0.0106 / _E_PER_V,
            "derived: [mlx75027] Table 13 (p.17) 'Single tap conversion gain 0.0106 DN/e-'; a raw tap is 11 bit (p.50, "
            "Table 28) and A-B 12 bit signed (p.32), so one A-B DN is one tap DN, 94.3 e- of difference; tofjax's "
            "differential ADC spans +-V_ref in 2^12 codes: V_ref = 2048 x 94.3 e- x e / C_int (6.38 fF) = 4.85 V "
            "(+-193 ke-, beyond the full well)"),
        "adc.v_ref_neg_v": (0.0, "derived: V_ref = v_ref_pos_v - v_ref_neg_v carries the conversion gain (v_ref_pos_v)"),
        "adc.offset_error_lsb": (
            0.0, "derived: an offset cancels in [mlx75027]'s I = p0 - p180, Q = p270 - p90 (p.58) and in its A-B "
                 "output; none is stated"),
        "adc.gain_error_percent_fsr": (
            0.0, "derived: the quoted conversion gain (0.0106 DN/e-, [mlx75027] Table 13) is the whole transfer: "
                 "v_ref_pos_v holds it exactly"),
        "adc.integral_nonlinearity_lsb": (0.0, "derived: [mlx75027] states a linear transfer (one conversion gain) "
                                               "and no nonlinearity"),
        "adc.differential_nonlinearity_lsb": (0.0, "derived: [mlx75027] states a linear transfer (one conversion gain) "
                                                   "and no nonlinearity"),
        # --- timing
        "timing.frame_rate_hz": (60.0, "quoted: [mlx75027] p.12, use case B: '60 distance frames per second'"),
        "timing.readout_time_s": (
            1.822e-3, "fitted: [mlx75027] Fig. 7 (p.13), 'Theoretical Maximum Distance Frame Rate' at 960 Mbps (4 "
                      "lanes, use case B's), read at 21 integration times 0-1000 us (+-0.3 fps): tofjax's maximum "
                      "1 / (4 (t + t_ro)) by least squares (the slope is 4.000 per us, as it must be): t_ro = 1.822 "
                      "ms meets every point within 0.2 fps (1.818-1.826 ms within 0.5 fps; 117.8 fps at 300 us, "
                      "p.1 'max. 120 FPS ... Tint 300µs'). The register formula (p.37 eq. 3, HMAX 694, 263 rows "
                      "per phase) gives 1.521 ms plus PLLSETUP 0.549 ms per frame (p.34): about 28 rows per phase "
                      "fewer than the figure"),
        # --- the frame
        "frame.illumination_falloff_exponent": (
            0.0, "derived: a batwing diffuser evens the irradiance on a plane ([fxtof1] 'batwing profile diffuser'): "
                 "a flat top, as the class 1 bound of illumination.peak_power_w assumes"),
        "frame.baseline_m": (
            [0.0, 0.0], "derived: no MLX75027 camera states its emitter's place; beside the lens its parallax "
                        "matters only in the first tens of centimetres: the reference camera's is coaxial"),
        "frame.relative_illumination_exponent": typical_relative_illumination(),
        "frame.vignetting": (0.0, "derived: a lens' relative illumination (frame.relative_illumination_exponent, "
                                  "[sbaa217]) includes its vignetting; nothing further"),
        **dict.fromkeys(
            ("frame.distortion_k1", "frame.distortion_k2", "frame.distortion_k3", "frame.distortion_p1",
             "frame.distortion_p2"),
            (0.0, "derived: a typical ToF lens states a TV distortion ([sbaa217] Table 1 '< 10%'), which fixes no "
                  "Brown-Conrady profile: the reference lens is distortion-free, its field of view exact")),
        "frame.prnu_sigma": (0.0, _UNIFORM),
        "frame.phase_offset_sigma_rad": (0.0, _UNIFORM),
        "frame.tap_asymmetry_sigma": (0.0, _UNIFORM),
        "frame.threshold_sigma": (0.0, _UNIFORM),
        "frame.max_phase_noise_rad": (
            3.15, "quoted: [mlx75027] p.58, the datasheet's distance calculation delivers every pixel (no "
                  "confidence threshold): 3.15 rad, above any phase noise, flags none"),
        "frame.min_amplitude_lsb": (
            0.0, "quoted: [mlx75027] p.58 invalidates no amplitude, and its per-tap limits are off after the "
                 "initialisation ('0x1433 is set to zero in the 6.2 Initialisation Register Map', p.50)"),
        # --- the processing: the datasheet's (p.58)
        "processing.calibration": (
            False, "quoted: [mlx75027] p.58, the distance calculation: no calibration of the wiggling or the offset "
                   "(the sensor offers delay trimming, p.45, and a temperature sensor, p.49, to a camera maker)"),
        "processing.calibration_temperature_c": (25.0, "derived: no calibration (processing.calibration): not read"),
        "processing.spatial_filter": ("none", _NO_FILTER),
        "processing.spatial_filter_size": (3, "derived: no spatial filter (processing.spatial_filter): not read"),
        "processing.temporal_average_frames": (1, _NO_FILTER + ", one frame per distance frame"),
        "processing.amplitude_threshold": (False, _NO_FILTER + " and no invalidation"),
        "processing.flying_pixel_m": (0.0, _NO_FILTER + " and no invalidation"),
        "processing.flying_pixel_neighbours": (1, "derived: no flying-pixel filter (processing.flying_pixel_m): "
                                                  "not read"),
        # --- the camera's own operating point and filter (in [scene]: the keys tofjax has for them)
        "scene.integration_time_s": (
            600e-6, "quoted: [mlx75027] p.12, use case B: '600 µs integration time' (per phase, p.41)"),
        "scene.integration_time_per": ("phase_image", "derived: the datasheet's integration time is set per phase "
                                                      "(raw frame; section 7.13), tofjax's unit"),
        "scene.filter_half_width_m": (
            28e-9, "derived: the widest band-pass that the datasheet's '120KLUX robust when using lens with filter' "
                   "([mlx75027] p.1) allows in use case B: 120 klx of sunlight on a 90 % target, this lens (k 0.85, "
                   "F/1.2), 600 us: the background fills a tap at +-29.0 nm (+-28.4 nm with a 1 m target's signal); "
                   "+-28 nm. A VCSEL's narrow, slowly drifting line would allow a narrower filter, which no source "
                   "here states"),
    },
    product=False,
)
