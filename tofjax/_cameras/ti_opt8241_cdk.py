"""The ``ti-opt8241-cdk`` preset (:mod:`tofjax._presets`): the Texas Instruments OPT8241-CDK-EVM
time-of-flight camera (OPT8241 sensor, 320 x 240 pixels of 15 um; OPT9221 controller; four 850 nm
laser diodes; TI's Voxel SDK, board 'TintinCDK') in the SDK's default profile, Long Range (id 130):
40 + 60 MHz de-aliased, six quads of 0.78 ms per frequency, 30 fps, full illumination power, key by
key.

What the OPT8241 data sheet's first page states (array, pitch, responsivity, contrast, band-pass,
12-bit output) is quoted; it carries the facts of the former sensor-only ``ti-opt8241`` preset.
The mode (frequencies, quads, exposure, frame rate, illumination power), the lens and the
controller's processing are derived from the Voxel SDK's profiles, register map and board code,
each with file and line. The data sheet's tables (full well, dark current, read noise) and the
CDK quick-start guide's "Top-Level Specifications" were not readable in any stored copy, so the
pixel's electrical keys are derived by analogy with the one CW ToF pixel whose datasheet states
them in the project's sources (Melexis MLX75027, the same 51 % quantum efficiency at 850 nm),
scaled to this pixel's area where they are extensive. TI publishes no depth performance of the
CDK in any source reached, so nothing here is fitted. docs/cameras/ti-opt8241-cdk.md gives every
derivation (T1-T7) and what stays open."""

import math

from .._presets import Preset
from ._sources import SBAA217, TOFJAX_CLASS1, typical_relative_illumination

_VX = "github.com/3dtof/voxelsdk"
_VX_HEAD = "db85629019111fbc95f0ecb45f1a87f6af94a40b"
_BOARD = "TI3DToF/boards/TintinCDK"

REFERENCES = {
    "opt8241": ("Texas Instruments, 'OPT8241 3D Time-of-Flight Sensor', data sheet SBAS704B (June 2015, revised "
                "October 2015), p. 1, Features and Description (ti.com/lit/gpn/opt8241; mirror dtsheet.com/model/"
                "4185105)"),
    "opt8241-app": ("the same data sheet, section 8.2.1.1 'Design Requirements' of its application example 'Presence "
                    "Detection for Industrial Safety' (TI's HTML data sheet, Chinese edition ZHCSE82B, section 8, as "
                    "stored: yogichopra.com/document-viewer/cn/OPT8241/datasheet/8_ZHCSE82B.html; page number not "
                    "shown)"),
    "tida00750": ("Texas Instruments, TIDA-00750 'People counting for demand controlled ventilation using 3D "
                  "time-of-flight (ToF) reference design', ti.com/tool/TIDA-00750, Features; its design guide TIDUBL5A "
                  "(April 2016, revised May 2016), p. 1, names the 'OPT8241-CDK-EVM Tool Folder' among its resources "
                  "and draws its camera as 'Lens Diffuser Scene Modulation Laser x4 OPT8241 (3D ToF sensor) OPT9221 "
                  "(TFC)'"),
    "voxelsdk": (f"Texas Instruments, Voxel SDK ({_VX}, commit {_VX_HEAD[:8]}, 2018-07-19): the CDK's board code and "
                 f"profiles in {_BOARD}/ (default_profile = 130, TintinCDKCamera.conf l. 4; the Long Range profile, "
                 "TintinCDKCameraLongRange.conf), the controller's register map TI3DToF/OPT9221.dml, and "
                 "TI3DToF/ToFTintinCamera.cpp; lines as cited"),
    "voxelsdk-2015": (f"the same repository at commit 00232bfc (2015-08-06): {_BOARD}/TintinCDKCameraLensOnly.conf "
                      "l. 16-25, [calib], TI's calibration of a CDK's lens, the parent profile's lens from July 2015 "
                      "(105f1ed) until commit 54b335e (2016-10-25) 'TintinCDKCameraLensOnly: update default lens "
                      "parameters to no distortion' set fx = fy = 230, k1..p2 = 0"),
    "calwiz": ("Texas Instruments, Voxel calibration wizard, github.com/3dtof/calibwizard, doc/Calibrations.rst "
               "(commit 81942c0c)"),
    "sbaa217": SBAA217,
    "mlx75027": ("Melexis, 'MLX75027 VGA Time-of-Flight Sensor', datasheet v1.0, 15 December 2020, Table 13 (p. 17) "
                 "(read for this project in /work/research/mlx75027.md; the melexis-mlx75027 preset): a 10 um "
                 "back-illuminated ToF pixel of the same 51 % external quantum efficiency at 850 nm as the OPT8241's "
                 "0.35 A/W, the analogy the pixel's electrical keys rest on"),
    "tofjax": TOFJAX_CLASS1,
    "docs": "this preset's page, docs/cameras/ti-opt8241-cdk.md (its derivations T1-T7)",
}

_C = 299792458.0
_E = 1.602176634e-19

#: T1: the Long Range profile's frame (TintinCDKCameraLongRange.conf l. 8-13): 2 sub-frames (one per frequency) of
#: 6 quads at 30 fps, each quad integrating 18/64 of its period, at 100 % illumination power.
FRAME_RATE_HZ = 30.0
SUB_FRAMES, QUADS, INTG_DUTY_CYCLE = 2, 6, 18
QUAD_PERIOD_S = 1.0 / (FRAME_RATE_HZ * SUB_FRAMES * QUADS)
QUAD_INTEGRATION_S = INTG_DUTY_CYCLE / 64.0 * QUAD_PERIOD_S
PER_FREQUENCY_S = QUADS * QUAD_INTEGRATION_S
READOUT_S = QUAD_PERIOD_S - QUAD_INTEGRATION_S
#: T1: the SDK's de-aliasing arithmetic for 'unambiguous_range = 8' (ToFTintinCamera.cpp l. 212-263).
FREQUENCIES_HZ = (40e6, 60e6)
#: T2: the SDK's model of the illumination board at 'illum_power_percentage = 100' (TintinCDKCameraCommon.h l. 103-128).
PEAK_POWER_W = 4 * 2.2
#: T3: TI's calibration of a CDK's lens ([voxelsdk-2015]), focal lengths in pixels of 15 um.
FX_PX, FY_PX = 228.973245816, 229.365392955
FOV_DEG = [round(2 * math.degrees(math.atan(160 / FX_PX)), 2), round(2 * math.degrees(math.atan(120 / FY_PX)), 2)]
#: The field TI states for a camera on the CDK ([tida00750]): what the illumination covers.
FIELD_DEG = [74.4, 59.3]
#: T4: the pixel's electrical keys by analogy with the MLX75027's 10 um pixel, extensive ones scaled to 15 um.
AREA_RATIO = (15.0 / 10.0) ** 2
C_F = round(3.19e-15 * AREA_RATIO, 19)
FULL_WELL_E = round(160e3 * AREA_RATIO)
DARK_E_PER_S = 51e3 * AREA_RATIO
_E_PER_V = 2 * C_F / _E  # C_int / e, electrons per volt
#: T5: the 12-bit A - B output spans the pixel's differential swing, +- one full well.
V_REF_V = round(FULL_WELL_E / _E_PER_V, 4)

_NOT_READ = "derived: not read by the 'pulse' shape (no effect)"
_ANALOGY = ("the OPT8241's number is in its data sheet's tables, which no stored copy lets read; by analogy with the "
            "ToF pixel of the same quantum efficiency whose datasheet is in the project's sources ([mlx75027]), "
            "scaled to this pixel's area where extensive ([docs] T4)")
_UNIFORM = ("derived: not published; [mlx75027] states one typical pixel (no spread), and the CDK calibrates each "
            "pixel's phase offset ([calwiz] 'pixel-wise phase offset'): 0")
_NO_ADC_ERROR = ("derived: not published; the controller removes each pixel's offset and the cyclic error "
                 "(processing.calibration), an offset cancels in A - B, and the 12-bit code is the calibrated output: 0")

PRESET = Preset(
    name="ti-opt8241-cdk",
    title="Texas Instruments OPT8241-CDK-EVM time-of-flight camera (OPT8241, 320 x 240; OPT9221; Voxel SDK), default "
          "profile Long Range: 40 + 60 MHz, 6 quads of 0.78 ms per frequency, 30 fps, 8.8 W",
    references=REFERENCES,
    values={
        # --- illumination ---------------------------------------------------------------------------
        "illumination.peak_power_w": (
            PEAK_POWER_W,
            "derived: [docs] T2, the SDK's model of the illumination board ([voxelsdk] TintinCDKCameraCommon.h l. 103-"
            "109: 'float I = 118079.0e-3/Rlim; //Current limit implemented by the linear current limiting IC ...', "
            "'uint retVal = uint(4*(I-0.2)*1100); //Subtracting the threshold current and multiplying by the power "
            "gain of the laser diode.'; l. 127-128: 'ILLUM_POWER, \"mW\", ... 4*1000, 4*2200, 4*1129', 'These power "
            "numbers are approximate (+- 20%)') at the profile's 'illum_power_percentage = 100' "
            "(TintinCDKCameraLongRange.conf l. 13; l. 158-166: percentage x upper limit): 4 x 2200 mW while the "
            "lasers are on, the square wave's high level; +- 20 %"),
        "illumination.wavelength_m": (
            850e-9, "derived: the laser's wavelength is not in any source reached; [opt8241] 'Responsivity: 0.35 A/W at "
                    "850 nm' inside its 'Integrated Optical Band-Pass Filter (830 nm to 867 nm)' (centre 848.5 nm): "
                    "the camera's light is where its sensor is specified"),
        "illumination.fov_deg": (
            FIELD_DEG, "derived: not published for the illumination; [tida00750] 'Four NIR lasers provide large "
                       "illumination area' for its 'Wide field of View: H74.4º x V59.3º' (the same field as "
                       "[opt8241-app]'s example, 'Field of view | 74.4 x 59.3 | Degrees (H x V)'): the light matched to "
                       "the field the camera sees (camera.fov_deg with its distortion, [docs] T3)"),
        "illumination_waveform.shape": (
            "pulse", "derived: [opt8241] p. 1's block diagram drives the lasers with the sensor's logic outputs "
                     "('ILLUM_P', 'ILLUM_N', 'ILLUM_EN') through a current limiter ([voxelsdk] "
                     "TintinCDKCameraCommon.h l. 107): a square wave; its wiggling is calibrated "
                     "(processing.calibration)"),
        "illumination_waveform.duty_cycle": (0.5, "derived: a square wave of the pixel's two antiphase taps "
                                                  "(reference_waveform.duty_cycle): 50 %"),
        "illumination_waveform.gauss_order": (15, _NOT_READ),
        "illumination_waveform.fourier_order": (5, _NOT_READ),
        "illumination_waveform.modulation_frequency_hz": (
            FREQUENCIES_HZ[0],
            "derived: [docs] T1, the SDK's arithmetic for the profile's 'unambiguous_range = 8' "
            "(TintinCDKCameraLongRange.conf l. 8): beyond the single-frequency limit (3 m at the CDK's 'getOptimalMinimum"
            "() { return 39; }', TintinCDKCameraCommon.h l. 257) ToFTintinCamera.cpp takes 'ma = 2, mb = 3, ka = 2, kb "
            "= 1' (l. 218) and the VCO at its maximum, min(60 x 2/3 x 6 x 2, 600) = 480 MHz (l. 223, 243); 'float v "
            "= vcoFrequency/quadCount/(1 + modulationPS)' (l. 102) = 480 / 6 / 2 = 40 MHz, the base frequency"),
        "illumination_waveform.extra_modulation_frequencies_hz": (
            [FREQUENCIES_HZ[1]],
            "derived: [docs] T1: the de-aliasing frequency's VCO 'std::max(vco->lowerLimit(), vcoFreq*mb/ma*(1+modPS2)/"
            "(1+modPS1))' (ToFTintinCamera.cpp l. 261) = 360 MHz, / 6 quads / (1 + 0) = 60 MHz; [voxelsdk] OPT9221.dml "
            "l. 1920 'ma = fA/feff', 'mb = fB/feff', 'ma and mb have to be co-prime': 40 : 60 = 2 : 3, extended range "
            "c / (2 x 20 MHz) = 7.49 m"),
        "illumination_waveform.frequency_fusion": (
            "inverse_variance",
            "derived: [docs] T1: the controller's combination is not documented beyond its register map ([voxelsdk] "
            "OPT9221.dml l. 1962 'The mask for the getting the output phase from the calculated dealiased phase. The "
            "mask is 16bits wide'; ToFCamera.cpp l. 626-628 with ToFTintinCamera.cpp l. 478-496 read it in units of "
            "c / (2 x 4096 x 20 MHz x ma x mb), i.e. of 120 MHz, the frequencies' common multiple: both phases on one "
            "scale); the minimum-variance combination, weights 1 / sigma_i^2 (f_i^2 for equal phase noise); the "
            "base frequency alone would be 1.8x noisier ([docs] T1)"),
        # --- reference waveform -----------------------------------------------------------------------
        "reference_waveform.shape": ("pulse", "derived: [opt8241] p. 1's block diagram: logic 'Mix Drivers' ('DMIX0, "
                                              "DMIX1') switch the pixel's two taps in antiphase: square gates"),
        "reference_waveform.duty_cycle": (0.5, "derived: two antiphase taps (see shape): each gate is open half the "
                                               "period"),
        "reference_waveform.gauss_order": (15, _NOT_READ),
        "reference_waveform.fourier_order": (5, _NOT_READ),
        # --- camera and lens --------------------------------------------------------------------------
        "camera.pixel_pitch_m": ([15e-6, 15e-6], "quoted: [opt8241] Features: 'Pixel Pitch: 15 µm'"),
        "camera.optical_area_m": ([320 * 15e-6, 240 * 15e-6],
                                  "derived: [opt8241] Features: '320 × 240 Array' of 'Pixel Pitch: 15 µm' ('1/3” "
                                  "Optical Format'): 4.8 x 3.6 mm"),
        "camera.fill_factor": (1.0, "derived: [opt8241] quotes the pixel's responsivity (microlens and fill factor "
                                    "inside it; tofjax's reading, docs/model.md 'Datasheet responsivity and "
                                    "contrast')"),
        "camera.fov_deg": (
            FOV_DEG, "derived: [docs] T3: [voxelsdk-2015] TintinCDKCameraLensOnly.conf [calib] 'fx = 228.973245816', "
                     "'fy = 229.365392955' (pixels, OpenCV's pinhole) over 320 x 240 pixels: 2 atan(160 / fx), 2 atan(120 "
                     "/ fy); with the lens' barrel distortion (frame.distortion_k1..p2) the edge pixels look 73.3 "
                     "x 57.2 deg apart, 86.8 deg diagonally (the SDK's 'fovHalfAngle = (87/2.0f)', TintinCDKCamera.cpp "
                     "l. 163; [tida00750] 'H74.4º x V59.3º')"),
        "camera.f_number": (1.2, "derived: the CDK's lens F-number is not in any source reached; TI's example ToF lens "
                                 "for its sensors, [sbaa217] Table 1 'F.No 1.2'; degenerate with "
                                 "illumination.peak_power_w for the signal"),
        "camera.k_lens": (0.85, "derived: not published; [sbaa217] Table 1 'Transmission efficiency >85% @ 850 nm' (the "
                                "band-pass filter is the sensor's own, [opt8241] 'Integrated Optical Band-Pass Filter', "
                                "its loss read as inside the quoted responsivity); degenerate with "
                                "illumination.peak_power_w for the signal"),
        # --- pixel --------------------------------------------------------------------------------------
        "pixel.photo_responsivity_a_per_w": (0.35, "quoted: [opt8241] Features: 'Responsivity: 0.35 A/W at 850 nm' "
                                                   "(quantum efficiency 0.51)"),
        "pixel.collection_depth_m": (0.0, "derived: flat: the background counts only inside the integrated 830-867 nm "
                                          "filter ([opt8241], scene.filter_half_width_m), where the response is that "
                                          "of the quoted 850 nm (docs/model.md 'Datasheet responsivity and contrast')"),
        "pixel.demodulation_contrast": (
            0.45, "quoted: [opt8241] Features: 'Demodulation Contrast: 45% at 50 MHz', between the mode's 40 and 60 MHz "
                  "(the data sheet's contrast curve is not readable; tofjax keeps one contrast for both)"),
        "pixel.n_phases": (
            5, "derived: [docs] T1: the camera takes 6 quads per frequency ('quad_cnt_max = 6', "
               "TintinCDKCameraLongRange.conf l. 10; [voxelsdk] OPT9221.dml l. 315 'Only values of 4 and 6 are valid', "
               "coefficients 'sin(quadcount*2*pi/quad_cnt_max)', l. 1968); tofjax takes at most 5: 5 phase images "
               "sharing the frequency's whole exposure (scene.integration_time_per) give the same shot-noise phase "
               "variance, a charge per image 6/5 of a quad's, and 5 reads for 6"),
        "pixel.c_diode_f": (
            C_F, f"derived: {_ANALOGY}: [mlx75027] Table 13 'Pixel dark noise 83 e-' as tofjax's reset + hold kTC on "
                 "equal capacitances, C = 3.19 fF per tap (the melexis-mlx75027 preset's derivation), x 2.25 for the "
                 "15 um pixel: 7.18 fF, 83 e- per tap, 118 e- A - B; an effective node, not the circuit"),
        "pixel.c_sample_and_hold_f": (C_F, "derived: equal to c_diode_f (see there): the split of the kTC noise "
                                           "between reset and hold is not stated; the thesis' pixel splits equally"),
        "pixel.v_reset_v": (3.3, "quoted: [voxelsdk] TintinCDKCameraCommon.h l. 92-93: 'PVDD, \"mV\", ... 2000, 3300, "
                                 "3300, \"Pixel VDD\", \"Reset voltage level of pixel.\"' (default 3300 mV); it sets "
                                 "only the reported tap voltages (the well is pixel.full_well_e)"),
        "pixel.v_saturated_v": (0.0, "derived: no effect: with pixel.full_well_e set and SBI off no threshold reads it "
                                     "(docs/model.md 'Full well'); the bottom of the node's range"),
        "pixel.full_well_e": (
            FULL_WELL_E, f"derived: {_ANALOGY}: [mlx75027] Table 13 'Single tap full well capacity 106 [min] 160 [typ] "
                         "ke-' x 2.25: 360 ke- per tap"),
        "pixel.readout_noise_e": (0.0, "derived: the analogy's whole dark noise is in the kTC terms (pixel.c_diode_f): "
                                       "nothing is left for a further readout noise"),
        "pixel.readout_nonlinearity": (0.0, "derived: [mlx75027] states one conversion gain, a linear transfer; the "
                                            "controller's phase linearity table ([voxelsdk] OPT9221.dml l. 6220 "
                                            "'phase_lin_corr_en') corrects what remains in the phase"),
        "pixel.dark_slope_mean_v_per_s": (
            round(DARK_E_PER_S * _E / (2 * C_F), 4),
            f"derived: {_ANALOGY}: [mlx75027] Table 13 'Single tap dark current 20 51 508 ke-/s' (typical) x 2.25 = "
            "115 ke-/s on C_int = 2 c_diode_f; 108 e- per 0.94 ms phase image, far below the signal"),
        "pixel.dark_slope_sigma_v_per_s": (0.0, _UNIFORM),
        "pixel.dark_reference_temperature_c": (25.0, "derived: [mlx75027] Table 13 states no temperature: room "
                                                     "temperature, inside the OPT8241's 'Operating Temperature: 0°C to "
                                                     "70°C' ([opt8241])"),
        "pixel.dark_doubling_temperature_c": (7.0, "derived: silicon's dark current doubles every 5-8 °C (docs/model.md "
                                                   "'Dark current and temperature', A. Theuwissen 2009): mid-range"),
        "pixel.phase_offset_rad": (
            0.0, "derived: calibrated away: [voxelsdk] OPT9221.dml l. 3159 'phase_corr_1': 'Phase correction for base "
                 "frequency. This value is subtracted from the obtained phase.' (and 'phase_corr_2', l. 3175), set per "
                 "unit by [calwiz]'s common phase offset calibration; processing.calibration removes it"),
        "pixel.phase_drift_rad_per_c": (
            0.0, "derived: compensated: [voxelsdk] OPT9221.dml l. 3205 'phase correction = phase_offset + "
                 "coeff_illum*(tillum-tillum_calib) + coeff_sensor*(tsensor-tsensor_calib) ... phase correction is "
                 "subtracted from the phase output', on in the profile ('coeff_sensor = -26', 'disable_temp_corr = "
                 "False', TintinCDKCameraLongRange.conf l. 26-28; [calwiz] 'Normally temperature calibration only needs "
                 "to be done once per design'); the unit's residual is not published"),
        "pixel.sbi": (False, "derived: no background suppression is described: TI's answer to ambient light is a "
                             "shorter integration over more sub-frames (the High Ambient profile, 'sub_frame_cnt_max = "
                             "4', 'intg_duty_cycle = 3', TintinCDKCameraHighAmbient.conf l. 9-12), and the sensor "
                             "reports the common mode ([opt8241] '4-Bit Common-Mode (Ambient)')"),
        # --- adc ------------------------------------------------------------------------------------------
        "adc.enabled": (True, "derived: [opt8241] Features: '12-Bit Phase Correlation Data': each quad's A - B is "
                              "digitised to 12 bits"),
        "adc.resolution_bits": (12, "quoted: [opt8241] Features: 'Output Data Format: – 12-Bit Phase Correlation "
                                    "Data'"),
        "adc.v_ref_pos_v": (
            V_REF_V, "derived: [docs] T5: the converter's range is not published; the 12 bits span the pixel's "
                     "differential swing, +- one full well (pixel.full_well_e on C_int = 2 c_diode_f: 360 ke- / 14.4 "
                     "fF = 4.02 V), the range that clips no charge the pixel holds: 176 e- per LSB, a quantisation of 51 "
                     "e- rms against the 118 e- of the analog A - B noise"),
        "adc.v_ref_neg_v": (0.0, "derived: V_ref = v_ref_pos_v - v_ref_neg_v carries the range (v_ref_pos_v)"),
        "adc.offset_error_lsb": (0.0, _NO_ADC_ERROR),
        "adc.gain_error_percent_fsr": (0.0, _NO_ADC_ERROR),
        "adc.integral_nonlinearity_lsb": (0.0, _NO_ADC_ERROR),
        "adc.differential_nonlinearity_lsb": (0.0, _NO_ADC_ERROR),
        # --- the mode's exposure and the band-pass filter (kept in [scene]) ------------------------------
        "scene.integration_time_s": (
            round(PER_FREQUENCY_S, 7),
            "derived: [docs] T1: the profile's 'sub_frame_cnt_max = 2', 'quad_cnt_max = 6', 'frame_rate = 30.00', "
            "'intg_duty_cycle = 18' (TintinCDKCameraLongRange.conf l. 9-12); a quad lasts 1 / (30 x 2 x 6) = 2.778 ms "
            "([voxelsdk] OPT9221.dml l. 309 'pix_cnt_max': 'Total frame time divided by the number of subframes and "
            "quads') and integrates 'intg_duty_cycle * 100/64.0' % of it (l. 1859): 0.781 ms; 6 quads per frequency: "
            "4.69 ms"),
        "scene.integration_time_per": ("frequency", "derived: [docs] T1: one sub-frame of 6 quads per frequency (the "
                                                    "controller's separate 'f1' and 'f2' quad coefficients, OPT9221.dml "
                                                    "l. 1968-2106)"),
        "scene.filter_half_width_m": (
            18.5e-9, "derived: [opt8241] Features: 'Integrated Optical Band-Pass Filter (830 nm to 867 nm)': half the "
                     "37 nm width, about the 850 nm illumination (831.5-868.5 nm)"),
        # --- timing -----------------------------------------------------------------------------------------
        "timing.frame_rate_hz": (FRAME_RATE_HZ, "quoted: [voxelsdk] TintinCDKCameraLongRange.conf l. 11 'frame_rate = "
                                                "30.00'"),
        "timing.readout_time_s": (
            round(READOUT_S, 7), "derived: [docs] T1: a quad's period less its integration, 2.778 - 0.781 = 2.00 ms "
                                 "(readout and the idle time the duty cycle leaves); 10 phase images of 0.94 ms with "
                                 "these gaps take 27.3 ms of the 33.3 ms frame"),
        # --- frame ----------------------------------------------------------------------------------------
        "frame.distortion_k1": (-0.186367327989, "quoted: [voxelsdk-2015] TintinCDKCameraLensOnly.conf l. 25 'k1 = "
                                                 "-0.186367327989' (OpenCV's coefficients; one unit's lens)"),
        "frame.distortion_k2": (0.186886972881, "quoted: [voxelsdk-2015] l. 18 'k2 = 0.186886972881'"),
        "frame.distortion_k3": (-0.0838070075746, "quoted: [voxelsdk-2015] l. 17 'k3 = -0.0838070075746'"),
        "frame.distortion_p1": (0.00128792508541, "quoted: [voxelsdk-2015] l. 24 'p1 = 0.00128792508541'"),
        "frame.distortion_p2": (0.00177329655628, "quoted: [voxelsdk-2015] l. 21 'p2 = 0.00177329655628'"),
        "frame.relative_illumination_exponent": typical_relative_illumination(
            "not published for the CDK's lens; TI's example ToF lens: "),
        "frame.vignetting": (0.0, "derived: the relative illumination (frame.relative_illumination_exponent) includes "
                                  "the lens' vignetting"),
        "frame.illumination_falloff_exponent": (
            0.0, "derived: not published; the evenest profile tofjax models: [tida00750] draws the lasers behind a "
                 "'Diffuser', which evens out the field"),
        "frame.baseline_m": ([0.0, 0.0], "derived: the lasers' position on the illumination board is not published; "
                                         "beside the lens their parallax matters only in the first tens of "
                                         "centimetres: coaxial"),
        "frame.prnu_sigma": (0.0, _UNIFORM),
        "frame.phase_offset_sigma_rad": (
            0.0, "derived: calibrated per pixel: [calwiz] 'PixelWise Phase Offset Calibration' ('For high-precision "
                 "applications, pixel-to-pixel calibration is recommended'), applied by the SDK where the profile "
                 "carries it ([voxelsdk] ToFCamera.cpp l. 501-504, 'phasecorrection'); processing.calibration removes "
                 "each pixel's own offset"),
        "frame.tap_asymmetry_sigma": (0.0, _UNIFORM),
        "frame.threshold_sigma": (0.0, _UNIFORM),
        "frame.max_phase_noise_rad": (
            3.15, "derived: off (the largest value): the controller's one confidence is the amplitude threshold "
                  "(frame.min_amplitude_lsb); no noise-based invalidation is described ([voxelsdk] OPT9221.dml)"),
        "frame.min_amplitude_lsb": (
            1.0, "quoted: [voxelsdk] ToFTintinCamera.cpp l. 392 '!set(CONFIDENCE_THRESHOLD, 1U)' at initialisation, "
                 "with ToFTintinCamera.h l. 34-35 '#define CONFIDENCE_THRESHOLD \"amplitude_threshold\"' and "
                 "OPT9221.dml l. 2905 'Phase will be made '0xFFF' when amplitude is lower than this threshold.' (its LSB "
                 "read as tofjax's amplitude LSB: 'Default amplitude of the (A-B) is 2048', l. 2716, is the 12-bit "
                 "A - B's scale)"),
        # --- the camera's processing --------------------------------------------------------------------
        "processing.calibration": (
            True, "derived: the CDK's profiles are calibrated ones: the SDK keeps a separate 'No Calibration' profile "
                  "(id 132, TintinCDKCameraNoCalibration.conf l. 2-3) beside them, each profile carries its unit's "
                  "calibration in the camera ([voxelsdk] ToFCamera.cpp l. 126-138: 'phase_corr_1', 'phase_corr_2', "
                  "'phasecorrection' per profile), and the controller applies the offsets and the phase linearity "
                  "table (OPT9221.dml 'phase_corr_1' l. 3159, 'phase_lin_corr_en' l. 6220: 'the lookup table for "
                  "converting the obtained phase to actual phase'); [calwiz]: 'For best accuracy, the relatively small "
                  "nonlinear relationship that exists between the raw phase measurement and actual depth must be "
                  "taken into consideration'"),
        "processing.calibration_temperature_c": (
            25.0, "derived: no effect: the controller compensates temperature (pixel.phase_drift_rad_per_c 0), so the "
                  "calibration holds at every temperature; 25 °C (a unit's own: 'tsensor_calib = 56', "
                  "TintinCDKCameraExtraLongRange.conf l. 36)"),
        "processing.spatial_filter": (
            "none", "quoted: [voxelsdk] OPT9221.dml l. 6704 'filt_en' default '0' ('Enable spatial filter'), not set by "
                    "any CDK profile; the SDK's software filters (Voxel/Filter) run only when added ('filteradd', "
                    "App/CLIManager.cpp l. 262): none by default"),
        "processing.spatial_filter_size": (3, "derived: not read (processing.spatial_filter none)"),
        "processing.temporal_average_frames": (
            1, "derived: no temporal filter is on by default (the SDK's IIR, temporal median and denoise filters are "
               "added only explicitly, [voxelsdk] Voxel/Filter): one frame"),
        "processing.amplitude_threshold": (True, "quoted: [voxelsdk] OPT9221.dml l. 2905 'Phase will be made '0xFFF' "
                                                 "when amplitude is lower than this threshold.' (see "
                                                 "frame.min_amplitude_lsb)"),
        "processing.flying_pixel_m": (
            0.0, "derived: off: the SDK's 'FlypixFilter' (a gradient threshold) runs only when added ([voxelsdk] "
                 "Voxel/Filter/FlypixFilter.h), and the controller has none"),
        "processing.flying_pixel_neighbours": (1, "derived: not read (processing.flying_pixel_m 0)"),
    },
    unpublished=("TI states the CDK's performance in its quick-start guide (SBOU156B, section 5, p. 9), which no "
                 "source reached holds readably (docs/cameras/ti-opt8241-cdk.md): nothing to check it against"),
)
