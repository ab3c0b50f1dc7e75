"""The Sony IMX556 DepthSense sensor, shared by the presets of the cameras built on it (Basler
blaze-101, ``basler_blaze_101``; LUCID Helios2, ``lucid_helios2``): its facts once, with the same
sources, so that the two cameras agree on their sensor (docs/cameras/basler-blaze-101.md,
docs/cameras/lucid-helios2.md, "The sensor").

What is published of the IMX556 itself is its array: 640 x 480 back-illuminated pixels of 10 um
(quoted). Its quantum efficiency, contrast, noise, full well, dark current and ADC are not
published in any source reached (Sony's sensor paper, Kato et al. 2017/2018, was not reachable).
They are derived from the one datasheet of a DepthSense pixel of the same pitch and array in the
project's sources, the Melexis MLX75027 ("Each DepthSense pixel is represented by 12bit data",
datasheet p.25; 640 x 480 pixels of 10 um), with the numbers of the ``melexis-mlx75027`` preset
(docs/cameras/melexis-mlx75027.md): a derivation by analogy, named so in every note. One number of
the analogy does not fit this sensor: its 83 e- dark noise cannot give the noise increase Basler
measured on the blaze-101 in daylight (a factor 7 at most 3.1). The read-noise floor is therefore
fitted to that measurement (the one published measurement of the sensor), and the quantisation,
which would exceed that floor at the analogy's conversion gain, is left out."""

from __future__ import annotations

#: References of the sensor's facts (tags used in the notes below).
REFERENCES = {
    "lucid-tb": ("LUCID Vision Labs, tech brief 'Sony DepthSense 3D Sensor Explained: Better Time of Flight' "
                 "(thinklucid.com/tech-briefs/sony-depthsense-how-it-works), its side note 'Sony IMX556 DepthSense ToF "
                 "sensor specs' as reproduced by 3D Vision Academy, 'ToF: Understand Current Assisted Photonic "
                 "Demodulator (CAPD)' (3da.medium.com)"),
    "sony2017": ("Sony Corporation, press release of 5 June 2017 on its back-illuminated ToF image sensor (as reported by "
                 "AZoSensors, news 12001, 'Sony's Time-of-Flight Image Sensor Features 10-um Pixel Pitch')"),
    "deptheye": ("PointCloud.AI, libDepthEye README, the IMX556's feature list (github.com/pointcloudAI/libDepthEye, "
                 "as stored by the docs index)"),
    "mlx75027": ("Melexis, 'MLX75027 VGA Time-of-Flight Sensor', datasheet v1.0, document 3901075027, 15 December 2020 "
                 "(copy in github.com/rzw2/mlx75027_config, doc/MLX75027-Datasheet-Melexis_v1.0.pdf, commit 0501f11; "
                 "read for this project in /work/research/mlx75027.md): a DepthSense pixel of the same pitch and array, "
                 "the analogy every derived pixel key below rests on"),
}

#: The array (quoted): 640 x 480 pixels of 10 um.
PITCH_M = 10e-6
COLUMNS, ROWS = 640, 480
#: The DepthSense pixel of the MLX75027 (Table 13, p.17): external QE at its two quoted wavelengths.
EQE = {850e-9: 0.510, 940e-9: 0.280}
#: The pixel's read-noise floor as tofjax's kTC on equal capacitances per tap: fitted to Basler's daylight
#: measurement of the blaze-101 (docs/cameras/basler-blaze-101.md, D5).
C_F = 1.0e-16
_E = 1.602176634e-19
_E_PER_V = 2 * C_F / _E  # C_int / e, electrons per volt

_ANALOGY = ("the IMX556's own number is not published; by analogy with the DepthSense pixel of the same 10 um pitch "
            "and 640 x 480 array whose datasheet is in the project's sources ([mlx75027])")
_UNIFORM = ("derived: not published; the typical pixel of [mlx75027] (Table 13), no pixel-to-pixel spread stated (its "
            "PDNU is 'tbd'), and a factory-calibrated product: 0")


def responsivity_a_per_w(wavelength_m: float) -> float:
    """R = EQE lambda / 1239.84 nm of the DepthSense pixel at one of its two quoted wavelengths."""
    return round(EQE[wavelength_m] * wavelength_m / 1239.84e-9, 4)


def values(wavelength_m: float) -> dict[str, tuple[object, str]]:
    """The sensor's keys (dotted key -> (value, note)) for a camera illuminating at ``wavelength_m``
    (850 or 940 nm, the two wavelengths its quantum efficiency is quoted at)."""
    nm = round(wavelength_m * 1e9)
    eqe = EQE[wavelength_m]
    r = responsivity_a_per_w(wavelength_m)
    return {
        "camera.pixel_pitch_m": (
            [PITCH_M, PITCH_M], "quoted: [lucid-tb] 'Sony IMX556 DepthSense ToF sensor specs: ... 640 x 480 px ... "
                                "10.0µm pixel size'; [sony2017] 'a back-illuminated time-of-flight (\"ToF\") image "
                                "sensor with a 10µm pixel pitch'; [deptheye] 'Unit cell size : 10.0 um (H) × 10.0 um (V)'"),
        "camera.optical_area_m": (
            [COLUMNS * PITCH_M, ROWS * PITCH_M],
            "derived: [lucid-tb] '640 x 480 px' of '10.0µm pixel size' ('1/2″ sensor size': 8 mm diagonal); [deptheye] "
            "'640 x 480 (VGA) time-of-flight pixels based on the DepthSense® pixel technology'"),
        "camera.fill_factor": (
            1.0, "derived: back-illuminated ([lucid-tb] 'Backside Illuminated CMOS'); the responsivity below is an "
                 "external (whole-pixel) quantum efficiency, microlens and fill factor inside it (docs/model.md, "
                 "'Datasheet responsivity and contrast')"),
        "pixel.photo_responsivity_a_per_w": (
            r, f"derived: {_ANALOGY}: Table 13 (p.17) 'External Quantum Efficiency @ {nm}nm {100 * eqe:.1f} %': "
               f"R = {eqe:.2f} x {nm} nm / 1239.84 nm = {r} A/W; degenerate with illumination.peak_power_w for the "
               "signal"),
        "pixel.collection_depth_m": (
            30e-6, f"derived: {_ANALOGY}: its spectral response, Fig. 12 (p.17) read at 760-980 nm and fitted as "
                   "eta (1 - exp(-alpha_Si d)) (the melexis-mlx75027 preset's d = 30 um); it weights the background "
                   "light inside the band-pass filter only"),
        "pixel.demodulation_contrast": (
            0.78, f"derived: {_ANALOGY}: Table 13 (p.17) 'AC demodulation contrast @ 100MHz 78 %'; a CAPD pixel "
                  "demodulates by drift ([sony2017] 'high-speed modulation using drift current'); at frequencies "
                  "below 100 MHz a floor (contrast falls with frequency); degenerate with the power where the noise "
                  "is the signal's shot noise"),
        "pixel.c_diode_f": (
            C_F, "fitted: the pixel's read-noise floor (an effective node: tofjax's read noise is reset + hold kTC, "
                 "sqrt(6 k T C) / e per tap), to Basler's daylight measurement of the blaze-101 on this sensor "
                 "('Daylight Robustness', docs.baslerweb.com/daylight-robustness: 90 % target at 6 m, 250 us, 12.8 "
                 "W/m^2 of 920-970 nm light: 'The image noise increased by a factor of 7'): at the blaze-101 preset's "
                 "power the model gives 7.03 for C = 1.0e-16 F, a kTC floor of 9.8 e- per tap, 13.8 e- A - B (5e-17 F: "
                 "8.4; 2e-16 F: 5.6); the analogous pixel's 'Pixel dark noise 83 e-' ([mlx75027] Table 13) gives 1.6 "
                 "there and at most sqrt(1 + B / 83^2) = 3.1 at any power (docs/cameras/basler-blaze-101.md, D5); "
                 "degenerate with the optics' throughput "
                 "(QE k_lens / N^2), which scales signal and daylight alike"),
        "pixel.c_sample_and_hold_f": (C_F, "derived: equal to c_diode_f (see there): the split of the kTC noise between "
                                           "the nodes is not stated"),
        "pixel.readout_noise_e": (0.0, "derived: the whole read-noise floor is in the kTC terms (pixel.c_diode_f, "
                                       "fitted)"),
        "pixel.full_well_e": (160e3, f"derived: {_ANALOGY}: Table 13 'Single tap full well capacity 106 [min] 160 "
                                     "[typ] ke-'"),
        "pixel.v_reset_v": (2.9, "derived: no effect: with pixel.full_well_e set and no SBI the well is full_well_e "
                                 "and the taps' voltages enter no prediction (docs/model.md 'Full well'); 2.9 V nominal"),
        "pixel.v_saturated_v": (2.0, "derived: no effect (see v_reset_v): SBI is off; 2.0 V nominal"),
        "pixel.dark_slope_mean_v_per_s": (
            round(51e3 / _E_PER_V, 3),
            f"derived: {_ANALOGY}: Table 13 'Single tap dark current 20 51 508 ke-/s' (typical) as a slope on the "
            "effective C_int = 2 pixel.c_diode_f: 51 ke-/s x e / C_int; 51 e- per ms, far below the signal"),
        "pixel.dark_slope_sigma_v_per_s": (0.0, _UNIFORM),
        "pixel.dark_reference_temperature_c": (
            25.0, "derived: [mlx75027] Table 13 states no temperature: room temperature, inside the IMX556's "
                  "'Performance guarantee temperature : -10 to +60 ̊C' ([deptheye])"),
        "pixel.dark_doubling_temperature_c": (7.0, "derived: silicon image sensors double their dark current every "
                                                   "5-8 degC (A. Theuwissen, Harvest Imaging, 2009; tofjax's value)"),
        "pixel.readout_nonlinearity": (0.0, "derived: a calibrated product's output; [mlx75027] states one conversion "
                                            "gain (0.0106 DN/e-), a linear transfer"),
        "pixel.sbi": (False, "derived: no background suppression is described for the sensor; Basler, of the same "
                             "sensor ('Influencing Factors', docs.baslerweb.com/influencing-factors): 'a pixel can only "
                             "accept a certain amount of electrical charge. If this capacity is used up by ambient "
                             "light, less space is available for the intended light pulse reflection'"),
        "reference_waveform.shape": (
            "pulse", "derived: a CAPD pixel's taps collect by an alternating drift field ([lucid-tb] 'CAPD's "
                     "alternating voltage creates an alternating drift field that divides electrons between two "
                     "detection junctions'), switched by digital mixing signals ([mlx75027] p.44 'DMIX0 & DMIX1'); "
                     "the pixel's finite response is in the contrast"),
        "reference_waveform.duty_cycle": (0.5, "quoted: [lucid-tb] 'The two junctions are 180° out of phase in order to "
                                               "fully capture the reflected light': each tap half the period"),
        "reference_waveform.gauss_order": (15, "derived: not read by the 'pulse' shape (no effect)"),
        "reference_waveform.fourier_order": (5, "derived: not read by the 'pulse' shape (no effect)"),
        "adc.enabled": (False, "derived: the sensor's conversion gain is not published; the analogous pixel's step "
                               "(0.0106 DN/e-, 94 e- per DN: 27 e- rms, [mlx75027] Table 13) is twice the read-noise "
                               "floor the daylight measurement leaves (pixel.c_diode_f): the IMX556's quantisation "
                               "lies below its noise, so the readout is modelled without it"),
        "adc.resolution_bits": (12, f"derived: no effect with adc.enabled false (it scales the amplitude's LSB only); "
                                    f"{_ANALOGY}: p.32 'Mode A-B (=12bit signed data)'"),
        "adc.v_ref_pos_v": (1.075, "derived: no effect on depth with adc.enabled false: it scales the amplitude's LSB "
                                   "only; the default kept"),
        "adc.v_ref_neg_v": (0.275, "derived: no effect on depth (see v_ref_pos_v)"),
        "adc.offset_error_lsb": (0.0, "derived: no effect with adc.enabled false; a calibrated product"),
        "adc.gain_error_percent_fsr": (0.0, "derived: no effect with adc.enabled false; a calibrated product"),
        "adc.integral_nonlinearity_lsb": (0.0, "derived: no effect with adc.enabled false; a calibrated product"),
        "adc.differential_nonlinearity_lsb": (0.0, "derived: no effect with adc.enabled false; a calibrated product"),
        "frame.prnu_sigma": (0.0, _UNIFORM),
        "frame.phase_offset_sigma_rad": (0.0, "derived: each pixel's offset is removed by the factory calibration "
                                              "(processing.calibration)"),
        "frame.tap_asymmetry_sigma": (0.0, _UNIFORM),
        "frame.threshold_sigma": (0.0, _UNIFORM),
        "illumination_waveform.gauss_order": (15, "derived: not read by the 'pulse' shape (no effect)"),
        "illumination_waveform.fourier_order": (5, "derived: not read by the 'pulse' shape (no effect)"),
        "pixel.phase_offset_rad": (0.0, "derived: the factory calibration removes the constant offset "
                                        "(processing.calibration)"),
    }
