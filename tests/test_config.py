"""The TOML configuration: defaults, overrides, validation and error messages."""

import tomllib

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import tofjax as tj
from tofjax._schema import KEYS


def test_default_file_parses_to_the_defaults_and_comments_every_key():
    text = tj.schema.default_config_text()
    parsed = tomllib.loads(text)
    assert tj.config_from_dict(parsed).values == tj.Config().values
    lines = text.splitlines()
    assignments = [i for i, line in enumerate(lines) if " = " in line and not line.startswith("#")]
    assert len(assignments) == len(KEYS)
    for i, key in zip(assignments, KEYS, strict=True):
        assert lines[i].startswith(f"{key.name} = ")
        assert lines[i - 1].startswith("# ") and "allowed:" in lines[i - 1] and f"[{key.unit}]" in lines[i - 1]


def test_issue_sections_and_keys_exist():
    required = {
        "illumination": ["peak_power_w", "wavelength_m", "fov_deg"],
        "scene": ["reflectivity", "background", "filter_half_width_m", "distance_m", "illuminance_lx",
                  "integration_time_s"],
        "camera": ["k_lens", "f_number", "fov_deg", "pixel_pitch_m", "optical_area_m", "fill_factor"],
        "pixel": ["photo_responsivity_a_per_w", "demodulation_contrast", "c_diode_f", "c_sample_and_hold_f",
                  "n_phases", "v_reset_v", "v_saturated_v", "temperature_c", "dark_slope_mean_v_per_s",
                  "dark_slope_sigma_v_per_s", "sbi", "noise"],
        "illumination_waveform": ["shape", "duty_cycle", "gauss_order", "fourier_order", "modulation_frequency_hz"],
        "reference_waveform": ["shape", "duty_cycle", "gauss_order", "fourier_order"],
        "adc": ["enabled", "v_ref_pos_v", "v_ref_neg_v", "resolution_bits", "offset_error_lsb",
                "gain_error_percent_fsr", "integral_nonlinearity_lsb", "differential_nonlinearity_lsb"],
        "frame": ["subpixel_samples", "illumination_falloff_exponent", "baseline_m", "relative_illumination_exponent",
                  "vignetting", "prnu_sigma", "phase_offset_sigma_rad", "tap_asymmetry_sigma", "threshold_sigma",
                  "seed", "distortion_k1", "distortion_k2", "distortion_p1", "distortion_p2", "distortion_k3"],
        "timing": ["readout_time_s", "frame_rate_hz"],
        "interference": ["enabled", "peak_power_w", "baseline_m", "frequency_offset_hz", "phase_rad", "duty"],
        "processing": ["calibration", "calibration_temperature_c", "spatial_filter", "spatial_filter_size",
                       "temporal_average_frames", "amplitude_threshold", "flying_pixel_m", "flying_pixel_neighbours"],
    }
    values = tj.Config().values
    assert set(values) == set(required)
    for section, names in required.items():
        assert set(names) <= set(values[section])


def test_thesis_defaults():
    p = tj.Config().params
    assert float(p.pixel.photo_responsivity_a_per_w) == 0.23 and float(p.pixel.demodulation_contrast) == 0.42
    assert float(p.pixel.integration_capacitance_f) == pytest.approx(14e-15)
    assert float(p.illumination.peak_power_w) == 1.2 and float(p.scene.reflectivity) == 0.9
    assert p.illumination_waveform.shape == "gauss_extended" and p.illumination_waveform.gauss_order == 15
    assert float(p.illumination_waveform.duty_cycle) == 0.25
    assert float(p.illumination_waveform.modulation_frequency_hz) == 80.32e6
    assert p.adc.resolution_bits == 12 and float(p.adc.v_ref_pos_v) == 1.075
    sweep = tj.Config().sweep("distance")
    assert sweep.samples == 1000 and float(sweep.values[0]) == 0.45 and float(sweep.values[-1]) == 4.5
    assert tj.Config().iterations == 2000


def test_partial_file_overrides_only_what_it_names(tmp_path):
    path = tmp_path / "cam.toml"
    path.write_text('[pixel]\nn_phases = 3\nsbi = false\n[illumination]\nfov_deg = [60.0, 45.0]\n')
    config = tj.load_config(path)
    p = config.params
    assert p.pixel.n_phases == 3 and p.pixel.sbi is False
    np.testing.assert_allclose(p.illumination.fov_deg, [60.0, 45.0])
    assert float(p.pixel.demodulation_contrast) == 0.42  # untouched
    assert config.values["adc"] == tj.Config().values["adc"]


@pytest.mark.parametrize(
    "text, pattern",
    [
        ("[pixel]\ncontrast = 0.4\n", r"unknown key pixel.contrast.*"),
        ("[pixel]\ndemodulation_contarst = 0.4\n", r'unknown key pixel.demodulation_contarst \(did you mean '
                                                   r'"demodulation_contrast"\?\)'),
        ("[pixle]\nn_phases = 4\n", r'unknown section \[pixle\].*did you mean "pixel"'),
        ("[pixel]\nn_phases = 7\n", r"pixel.n_phases = 7 is out of range: allowed integer 2 <= value <= 5"),
        ("[pixel]\nn_phases = 4.0\n", r"pixel.n_phases = 4.0 has the wrong type: expected integer"),
        ('[pixel]\nsbi = "yes"\n', r"pixel.sbi = 'yes' has the wrong type: expected true or false"),
        ("[scene]\nreflectivity = 1.5\n", r"scene.reflectivity = 1.5 is out of range: allowed 0 <= value <= 1 \[1\]"),
        ('[scene]\nbackground = "sun"\n', r"scene.background = 'sun' is not allowed: expected one of"),
        ("[camera]\npixel_pitch_m = [17.5e-6]\n", r"camera.pixel_pitch_m = \[1.75e-05\] has the wrong type"),
        ("[illumination]\nfov_deg = [60, 190]\n", r"illumination.fov_deg = \[60.0, 190.0\] is out of range"),
        ("[pixel]\nv_saturated_v = 3.0\n", r"pixel.v_saturated_v = 3.0 must be less than pixel.v_reset_v = 2.9"),
        ("[adc]\nv_ref_neg_v = 2.0\n", r"adc.v_ref_neg_v = 2.0 must be less than adc.v_ref_pos_v = 1.075"),
        ("[pixel]\nphoto_responsivity_a_per_w = 0.9\n", r"quantum efficiency above 1.*allowed 0 < value <= 0.68"),
        ("[scene]\ndistance_from_m = 5.0\n", r"scene.distance_from_m = 5.0 must be less than scene.distance_to_m"),
        ("pixel = 3\n", r"\[pixel\] must be a table of keys"),
    ],
)
def test_bad_values_give_one_clear_error(tmp_path, text, pattern):
    path = tmp_path / "bad.toml"
    path.write_text(text)
    with pytest.raises(tj.ConfigError, match=pattern) as info:
        tj.load_config(path)
    assert str(path) in str(info.value)


def test_malformed_toml_names_file_line_and_column(tmp_path):
    path = tmp_path / "broken.toml"
    path.write_text("[pixel]\nn_phases = 4\nsbi = tru\n")
    with pytest.raises(tj.ConfigError, match=r"broken.toml: line 3, column 7: malformed TOML"):
        tj.load_config(path)
    with pytest.raises(tj.ConfigError, match="configuration file not found"):
        tj.load_config(tmp_path / "missing.toml")


FLOAT_KEYS = [k for k in KEYS if k.kind == "float" and (k.lo is not None or k.hi is not None)]


@settings(max_examples=150, deadline=None)
@given(st.sampled_from(FLOAT_KEYS), st.floats(allow_nan=True, allow_infinity=True, width=64))
def test_every_float_key_is_range_checked(key, value):
    inside = value == value and (key.lo is None or (value > key.lo if key.lo_open else value >= key.lo)) and (
        key.hi is None or (value < key.hi if key.hi_open else value <= key.hi))
    try:
        tj.config_from_dict({key.section: {key.name: value}})
    except tj.ConfigError as err:
        message = str(err)
        assert key.dotted in message
        assert not inside or "must be less than" in message or "quantum efficiency" in message
        if not inside:
            assert "allowed" in message
    else:
        assert inside


@settings(max_examples=60, deadline=None)
@given(st.sampled_from([k for k in FLOAT_KEYS if k.section != "processing"]), st.floats(-1e6, 1e6))
def test_direct_module_construction_is_range_checked(key, value):
    # (The [processing] keys are the processing stages' arguments, not a module's fields: their own
    # constructors' checks are tests/test_processing.py's.)
    from tofjax._params import SECTION_CLASSES

    cls = {**SECTION_CLASSES, "frame": tj.FrameSettings}[key.section]
    names = {f for f in cls.__dataclass_fields__}
    if key.name not in names:
        return  # sweep-range keys live in the configuration only
    inside = (key.lo is None or (value > key.lo if key.lo_open else value >= key.lo)) and (
        key.hi is None or (value < key.hi if key.hi_open else value <= key.hi))
    try:
        cls(**{key.name: value})
    except ValueError as err:
        assert key.dotted in str(err) or "must be less than" in str(err)
        assert not inside or "must be less than" in str(err)
    else:
        assert inside


def test_modules_accept_traced_values_without_checking():
    def f(x):
        return tj.Pixel(demodulation_contrast=x).demodulation_contrast * 2

    assert float(jax.jit(f)(jnp.asarray(0.5))) == 1.0
    assert float(jax.grad(f)(0.5)) == 2.0


def test_config_replace_and_sweeps():
    config = tj.Config().replace("pixel.n_phases", 5)
    assert config.params.pixel.n_phases == 5
    with pytest.raises(tj.ConfigError, match="pixel.n_phases = 9"):
        config.replace("pixel.n_phases", 9)
    sweep = config.sweep("integration_time", samples=7)
    assert sweep.samples == 7 and float(sweep.values[0]) == pytest.approx(0.2e-3)
    with pytest.raises(ValueError, match="sweep = 'depth' is not allowed"):
        config.sweep("depth")


def test_a_list_of_modulation_frequencies_means_range_extension():
    config = tj.config_from_dict({"illumination_waveform": {"modulation_frequency_hz": [80.32e6, 60.24e6]}})
    assert config.modulation_frequencies_hz == [80.32e6, 60.24e6]
    assert float(config.params.illumination_waveform.modulation_frequency_hz) == 80.32e6
    assert tj.Config().modulation_frequencies_hz == [80.32e6]  # one frequency stays the default
    with pytest.raises(tj.ConfigError, match=r"modulation_frequency_hz = \[80320000.0, -1.0\]|out of range"):
        tj.config_from_dict({"illumination_waveform": {"modulation_frequency_hz": [80.32e6, -1.0]}})
    with pytest.raises(tj.ConfigError, match="not both"):
        tj.config_from_dict({"illumination_waveform": {"modulation_frequency_hz": [80e6, 60e6],
                                                       "extra_modulation_frequencies_hz": [20e6]}})


def test_array_values_are_range_checked_element_by_element():
    """The first element out of range is named, with its index (NaN is never in range; the bounds'
    openness as the key states it: 0 < distance <= 1000 m)."""
    values = np.linspace(0.5, 4.0, 1000)
    values[[321, 700]] = [0.0, np.nan]
    with pytest.raises(ValueError, match=r"^scene\.distance_m = 0\.0 \(element \[321\] of an array of shape \(1000,\)\) "
                                         r"is out of range: allowed 0 < value <= 1000 \[m\]$"):
        tj.Sweep("distance", values)
    values[321] = 1.0
    with pytest.raises(ValueError, match=r"^scene\.distance_m = nan \(element \[700\] "):
        tj.Sweep("distance", values)
    with pytest.raises(ValueError, match=r"^scene\.distance_m = 1000\.5 \(element \[1, 1\] of an array of shape \(2, 2\)\)"):
        tj.Sweep("distance", [[1.0, 1000.0], [2.0, 1000.5]])
    assert float(tj.Sweep("distance", [1000.0]).values[0]) == 1000.0  # the closed upper bound
