"""The explorer (thesis §4.3 GUI) driven headlessly: set widget values, press its buttons, read
the configuration, previews, messages and figures."""

import csv
import html
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import tofjax as tj
from tofjax import plots
from tofjax._schema import KEYS

pytest.importorskip("ipywidgets")


@pytest.fixture(scope="module")
def shared_explorer():
    return tj.explorer()


def _descendants(widget):
    yield widget
    for child in getattr(widget, "children", ()):
        yield from _descendants(child)


def _set(ex, dotted, value, index=0):
    ex.fields[dotted].inputs[index].value = value


def test_every_key_sits_in_exactly_one_tab_with_its_unit_and_range():
    ex = tj.explorer()
    assert ex.tabs.titles == ("Main", "Pixel", "Scene & Camera", "Physical & ADC", "Processing", "Frame")
    assert set(ex.fields) == {k.dotted for k in KEYS}
    tab_of = {}
    for title, tab in zip(ex.tabs.titles, ex.tabs.children, strict=True):
        ids = {id(x) for x in _descendants(tab)}
        for dotted, field in ex.fields.items():
            if id(field.box) in ids:
                assert dotted not in tab_of, f"{dotted} in {tab_of[dotted]} and {title}"
                tab_of[dotted] = title
    assert set(tab_of) == set(ex.fields)
    assert tab_of["scene.background"] == tab_of["scene.distance_from_m"] == tab_of["pixel.iterations"] == "Main"
    assert tab_of["pixel.n_phases"] == tab_of["reference_waveform.shape"] == "Pixel"
    assert tab_of["camera.f_number"] == tab_of["illumination.fov_deg"] == "Scene & Camera"
    assert tab_of["adc.resolution_bits"] == "Physical & ADC"
    for key in KEYS:
        note = ex.fields[key.dotted].note.value
        assert f"[{html.escape(key.unit)}]" in note
        # The bounds (short for the kinds whose input shows its form: a dropdown lists its choices).
        bounds = key.range_text().rsplit("each ", 1)[-1]
        assert (html.escape(bounds) in note) != (key.kind == "choice"), (key.dotted, note)
    constants = next(x.value for x in _descendants(ex.tabs.children[3])
                     if isinstance(getattr(x, "value", None), str) and "Physical constants" in x.value)
    assert "299792458" in constants and "1.380649e-23" in constants


def test_a_change_updates_the_configuration_and_the_previews():
    ex = tj.explorer()
    line = ex.preview["waveforms"].axes[0].lines[0]
    peak_before = float(np.max(line.get_ydata()))
    png_before = ex.waveform_image.value
    _set(ex, "illumination.peak_power_w", 2.4)
    assert ex.config.values["illumination"]["peak_power_w"] == 2.4 and ex.error is None
    # Drawn when its tab is shown (the Main tab is): not for every edit on another tab.
    assert ex.waveform_image.value == png_before
    ex.tabs.selected_index = ex.tabs.titles.index("Pixel")
    assert ex.waveform_image.value != png_before
    peak_after = float(np.max(ex.preview["waveforms"].axes[0].lines[0].get_ydata()))
    assert peak_after == pytest.approx(2 * peak_before, rel=1e-12)
    ex.tabs.selected_index = 0
    # The correlation preview follows the phase count and the nominal distance (not the peak power).
    correlation = ex.preview["correlation"]
    _set(ex, "pixel.n_phases", 3)
    assert [line.get_label()[:3] for line in ex.preview["correlation"].axes[0].lines] == ["a_0", "a_1", "a_2", "nom"]
    _set(ex, "scene.distance_m", 1.5)
    marker = ex.preview["correlation"].axes[0].lines[-1].get_xdata()[0]
    assert marker == pytest.approx(2 * 1.5 / 299792458 * 1e9, rel=1e-12) and correlation is not ex.preview["correlation"]
    _set(ex, "scene.distance_m", 1.0)

    # FoV: diagonal -> circular spot pi (d tan(fov/2))^2; h x v -> rectangle 4 d^2 tan tan (§3.1.1).
    _set(ex, "illumination.fov_deg", 60.0, index=1)
    assert ex.config.values["illumination"]["fov_deg"] == 60.0
    assert ex.preview["spot_area_m2"] == pytest.approx(math.pi * math.tan(math.radians(30)) ** 2, rel=1e-12)
    field = ex.fields["illumination.fov_deg"]
    assert field.inputs[2].layout.visibility == "hidden"  # hidden in place: the layout does not jump
    others = [x for f in ex.fields.values() if f is not field
              for x in (f.inputs[:2] if f.key.kind == "angle" else f.inputs)]
    assert all(x.layout.visibility is None for x in others)  # hiding one input hides no other
    field.mode.value = "hv"
    _set(ex, "illumination.fov_deg", 40.0, index=2)
    assert ex.config.values["illumination"]["fov_deg"] == [60.0, 40.0]
    assert field.inputs[2].layout.visibility is None
    assert ex.preview["spot_area_m2"] == pytest.approx(
        4 * math.tan(math.radians(30)) * math.tan(math.radians(20)), rel=1e-12)

    # The derived lens follows the f-number (aperture = focal length / N).
    focal = ex.preview["focal_length_m"]
    _set(ex, "camera.f_number", 2.8)
    assert ex.preview["focal_length_m"] == pytest.approx(focal, rel=1e-12)
    assert ex.preview["aperture_diameter_m"] == pytest.approx(focal / 2.8, rel=1e-12)
    # The waveform preview's time axis is in ns at the configured frequency: 40 MHz spans twice 80 MHz.
    span = np.ptp(ex.preview["waveforms"].axes[0].lines[0].get_xdata())
    _set(ex, "illumination_waveform.modulation_frequency_hz", 40.16e6)
    assert ex.preview["unambiguity_range_m"] == pytest.approx(299792458 / (2 * 40.16e6), rel=1e-12)
    assert np.ptp(ex.preview["waveforms"].axes[0].lines[0].get_xdata()) == pytest.approx(2 * span, rel=1e-9)
    assert span == pytest.approx(1e9 / 80.32e6, rel=1e-9) and "ns" in ex.preview["waveforms"].axes[0].get_xlabel()
    _set(ex, "illumination_waveform.extra_modulation_frequencies_hz", "60.24e6, 20e6")
    assert ex.config.modulation_frequencies_hz == [40.16e6, 60.24e6, 20e6]
    assert ex.config.params == tj.config_from_dict(ex.config.values).params


def test_previews_catch_up_after_an_invalid_spell():
    """A preview change made while another field is invalid shows once the configuration is valid."""
    ex = tj.explorer()
    _set(ex, "pixel.v_saturated_v", 3.5)
    _set(ex, "illumination.peak_power_w", 3.0)
    assert ex.error is not None
    _set(ex, "pixel.v_saturated_v", 2.0)
    assert ex.error is None
    assert float(np.max(ex.preview["waveforms"].axes[0].lines[0].get_ydata())) == pytest.approx(3.0, rel=1e-9)


@pytest.mark.parametrize(("dotted", "value", "index", "expected"), [
    ("illumination_waveform.duty_cycle", -0.1, 0, "illumination_waveform.duty_cycle = -0.1 is out of range"),
    ("pixel.v_saturated_v", 3.5, 0, "pixel.v_saturated_v = 3.5 must be less than pixel.v_reset_v = 2.9"),
    ("scene.distance_from_m", 9.0, 0, "scene.distance_from_m = 9.0 must be less than scene.distance_to_m"),
    ("camera.pixel_pitch_m", 0.0, 1, "camera.pixel_pitch_m = [1.75e-05, 0.0] is out of range"),
    ("illumination_waveform.extra_modulation_frequencies_hz", "60e6, fast", 0, "is not a list of numbers"),
    ("pixel.photo_responsivity_a_per_w", 0.9, 0, "quantum efficiency above 1"),
])
def test_invalid_values_show_the_message_instead_of_raising(dotted, value, index, expected):
    ex = tj.explorer()
    before = ex.config
    _set(ex, dotted, value, index)
    assert expected in ex.error and expected.split(" ")[0] in ex.message.value
    assert ex.config is before and ex.calculate_button.disabled and "invalid" in ex.lamp.value
    field = ex.fields[dotted]  # the message at the field too, and the field highlighted
    assert html.escape(expected) in field.note.value and "tofjax-invalid" in field.box._dom_classes
    untouched = ex.fields["scene.reflectivity"]
    assert "tofjax-invalid" not in untouched.box._dom_classes and "&#9888;" not in untouched.note.value
    ex.calculate()
    assert ex.run is None and "cannot calculate: " in ex.message.value  # nothing ran, and it says why
    assert html.escape(expected) in ex.message.value
    ex.save_button.click()
    assert "not saved" in ex.message.value
    # Another (valid) change does not hide the problem; fixing it clears the message.
    _set(ex, "scene.reflectivity", 0.5)
    assert ex.error is not None and ex.config is before
    ex.fields[dotted].set_value(before.values[dotted.split(".")[0]][dotted.split(".")[1]])
    assert ex.error is None and ex.message.value == "" and not ex.calculate_button.disabled
    assert "tofjax-invalid" not in field.box._dom_classes and "ready" in ex.lamp.value
    assert ex.config.values["scene"]["reflectivity"] == 0.5


@settings(max_examples=20, deadline=None)
@given(key=st.sampled_from([k for k in KEYS if k.kind == "float"]),
       value=st.floats(allow_nan=True, allow_infinity=True))
def test_any_number_in_any_float_field_is_accepted_or_explained(shared_explorer, key, value):
    ex = shared_explorer
    ex.fields[key.dotted].set_value(value)
    try:
        if ex.error is None:  # the field shows (and so holds) 12 significant digits
            assert ex.config.values[key.section][key.name] == pytest.approx(value, rel=1e-11, abs=0.0)
        else:
            assert key.dotted in ex.error and ("allowed" in ex.error or "must be less than" in ex.error)
    finally:
        ex.fields[key.dotted].set_value(key.default)
        assert ex.error is None


@pytest.mark.parametrize("variable", ["distance", "illuminance", "integration_time"])
def test_plot_choices_and_range_fields_follow_the_sweep(variable):
    ex = tj.explorer()
    for box in ex.plot_checkboxes.values():
        box.value = True
    ex.sweep.value = variable
    enabled = [name for name, box in ex.plot_checkboxes.items() if not box.disabled]
    assert enabled == plots.applicable(variable) == ex.selected_plots()
    if variable != "distance":
        assert ex.plot_checkboxes["wiggling"].disabled and "wiggling" not in ex.selected_plots()
    for name, axis in tj.schema.SWEEP_AXES.items():
        for key in axis.range_keys:
            shown = ex.fields[f"scene.{key}"].box.layout.display is None
            assert shown == (name == variable)


def test_calculate_runs_the_sweep_with_busy_lamp_time_and_the_ticked_plots():
    ex = tj.explorer()
    _set(ex, "scene.samples", 12)
    _set(ex, "pixel.iterations", 40)
    ex.sweep.value = "integration_time"
    ex.plot_checkboxes["snr"].value = True
    lamp, calculate = [], []
    ex.lamp.observe(lambda change: lamp.append(change["new"]), names="value")
    ex.calculate_button.observe(lambda change: calculate.append(change["new"]), names="disabled")
    ex.calculate_button.click()  # runs in a background thread
    ex.calculate()  # a second press while it runs starts nothing
    ex.wait()
    assert [("busy" in v, "ready" in v) for v in lamp] == [(True, False), (False, True)]
    assert calculate == [True, False] and not ex.busy and ex.cancel_button.disabled
    assert ex.run.result.method == "mc" and ex.run.result.n_frames == 40
    np.testing.assert_allclose(ex.run.result.integration_time_s, np.linspace(0.2e-3, 5e-3, 12))
    assert list(ex.figures) == [n for n in plots.PLOTS if n in ("photon_transfer_curve", "snr", "amplitude",
                                                                  "depth_noise")]
    assert len(ex.plots_box.children) == len(ex.figures)
    for cell, fig in zip(ex.plots_box.children, ex.figures.values(), strict=True):  # titled, at their own size
        view = cell.children[0]  # zoomable where ipympl is installed (the test extra has it)
        assert type(view).__name__ == "Canvas" and view.figure is fig and fig.dpi == 96
        assert fig.get_suptitle() and view.layout.width == f"{round(fig.get_figwidth() * 96) + 4}px"
        assert [b.description for b in cell.children[1].children] == ["Save PNG", "Export CSV"]
    assert ex.time_label.value.startswith("simulation time ") and "12 samples" in ex.summary.value
    assert "at the nominal point" in ex.summary.value and ex.headlines["nominal_depth_std_m"] > 0
    assert "eye safety (an estimate" in ex.summary.value  # the frame's timing and eye safety too
    assert not ex.calculate_button.disabled and ex.message.value == "" and not ex.stale
    # What a script (notebook 06, under Voila) prints is text: the widget's HTML had shown as &#x27;.
    assert "&#x27;" in ex.summary.value and "a frame's phase images" in ex.summary_text
    assert "<" not in ex.summary_text and len(ex.summary_text.splitlines()) >= 4

    ex.method.value = "analytic"
    ex.sweep.value = "distance"
    ex.plot_checkboxes["wiggling"].value = True
    ex.calculate()
    assert ex.run.result.method == "analytic" and "wiggling" in ex.figures
    # The buttons name this run's files (its sweep, not the previous run's).
    first_name = list(ex.figures)[0]
    assert f"distance_{first_name}.png" in ex.plots_box.children[0].children[1].children[0].tooltip
    # Another sweep variable before: nothing to overlay.
    assert not any(line.get_gid() == plots.OVERLAY_GID for fig in ex.figures.values() for line in fig.axes[0].lines)
    # Several frequencies, analytically: the fused noise and the wrong-unwrap rate's closed form.
    _set(ex, "illumination_waveform.extra_modulation_frequencies_hz", "60.24e6")
    previous = ex.run
    ex.calculate()
    # The same sweep: the previous run's curves grey behind the new ones.
    fig = ex.figures["depth_noise"]
    grey = [line for line in fig.axes[0].lines if line.get_gid() == plots.OVERLAY_GID]
    np.testing.assert_array_equal(grey[0].get_ydata(), 1e3 * np.asarray(previous.result.depth_std_m))
    assert fig.get_suptitle().endswith("grey: previous run")
    assert ex.message.value == "" and ex.run.multifrequency.fusion == "inverse_variance"
    wrong = np.asarray(ex.run.multifrequency.wrong_unwrap_fraction)
    assert np.all((wrong >= 0) & (wrong <= 1))
    # The summary's range is the plots' range: the extended one (the first frequency's named as such).
    extended = float(ex.run.multifrequency.extended_range_m)
    assert f"extended range {extended:.4g} m" in ex.summary.value
    assert f"extended range {extended:.4g} m" in ex.derived.value
    ex.method.value = "mc"
    ex.overlay.value = False
    ex.calculate()
    assert "multifrequency_distance" in ex.figures and ex.run.multifrequency is not None
    assert not any(line.get_gid() == plots.OVERLAY_GID for fig in ex.figures.values() for line in fig.axes[0].lines)
    ex.seed.value = -1
    ex.calculate()
    assert "seed = -1 is out of range" in ex.message.value


def test_saved_toml_round_trips_and_bad_files_are_reported(tmp_path):
    ex = tj.explorer(folder=tmp_path)
    _set(ex, "scene.background", "halogen")
    _set(ex, "pixel.n_phases", 3)
    _set(ex, "pixel.sbi", False)
    ex.fields["camera.fov_deg"].mode.value = "hv"
    _set(ex, "camera.fov_deg", 50.0, index=2)
    _set(ex, "camera.optical_area_m", 3e-3, index=0)
    _set(ex, "illumination_waveform.extra_modulation_frequencies_hz", "60.24e6")
    assert ex.error is None
    path = tmp_path / "camera.toml"
    ex.path.value = str(path)
    ex.save_button.click()
    assert "saved" in ex.message.value
    assert tj.load_config(path).values == ex.config.values

    other = tj.explorer(folder=tmp_path)
    other.load(path)
    assert other.config.values == ex.config.values and other.message.value.startswith("loaded")
    for dotted, field in other.fields.items():  # the widgets show the loaded values
        section, name = dotted.split(".")
        assert field.value() == ex.config.values[section][name], dotted
    assert tj.explorer(path).config.values == ex.config.values

    bad = tmp_path / "bad.toml"
    bad.write_text("[pixel]\nn_phases = 3\nsbi = maybe\n")
    other.path.value = str(bad)
    other.load_button.click()
    assert "bad.toml: line 3, column 7: malformed TOML" in other.message.value
    assert other.config.values == ex.config.values
    other.load(tmp_path / "missing.toml")
    assert "configuration file not found" in other.message.value
    other.save(tmp_path / "no_such_dir" / "x.toml")
    assert "cannot write" in other.message.value


def test_a_run_can_be_cancelled_and_changed_settings_mark_it_stale(tmp_path):
    ex = tj.explorer(folder=tmp_path)
    ex.path.value = str(tmp_path / "camera.toml")
    _set(ex, "scene.samples", 12)
    _set(ex, "pixel.iterations", 40)
    ex.calculate()
    first = ex.run
    assert not ex.stale and ex.stale_note.value == ""
    # Any change after the run marks the plots and the summary stale; changing it back unmarks them.
    _set(ex, "scene.reflectivity", 0.5)
    assert ex.stale and "stale" in ex.stale_note.value and "tofjax-stale" in ex.plots_box._dom_classes
    _set(ex, "scene.reflectivity", 0.9)
    ex.method.value = "analytic"
    assert ex.stale
    ex.method.value = "mc"
    assert not ex.stale and "tofjax-stale" not in ex.summary._dom_classes

    # A long Monte Carlo, cancelled between its chunks: nothing of it replaces the last run.
    _set(ex, "scene.samples", 400)
    _set(ex, "pixel.iterations", 40000)
    ex.calculate_button.click()
    while ex.busy and ex.progress.value == 0:  # its first chunk has been reported
        ex.wait(0.05)
    assert ex.busy and ex.calculate_button.disabled and not ex.cancel_button.disabled
    ex.cancel_button.click()
    ex.wait(60)
    assert not ex.busy and "cancelled" in ex.message.value and ex.run is first
    assert ex.progress.value < ex.progress.max and not ex.calculate_button.disabled and ex.stale

    # The figures and the report of the last run, beside the TOML file.
    written = ex.save_figures()
    assert [p.name for p in written] == [f"distance_{n}.png" for n in ex.figures] and all(p.exists() for p in written)
    report = ex.write_report()
    assert report.exists() and tj.sweepfile.read_sweep(report.parent / "sweep.csv").n_rows == 12
    # One plot's PNG and its curves as CSV (its buttons): the run's numbers, not the figure's pixels.
    cell = ex.plots_box.children[list(ex.figures).index("depth_noise")]
    cell.children[1].children[1].click()
    rows = list(csv.DictReader((tmp_path / "distance_depth_noise.csv").read_text().splitlines()))
    np.testing.assert_allclose([float(r["x"]) for r in rows], np.asarray(first.result.distance_m), rtol=1e-15)
    np.testing.assert_allclose([float(r["y"]) for r in rows], 1e3 * np.asarray(first.result.depth_std_m), rtol=1e-15)
    assert "distance_depth_noise.csv" in ex.message.value
    # Every write asks before it replaces a file: the PNG just saved, the CSV exported, the report.
    before = (tmp_path / "distance_amplitude.png").read_bytes()
    assert ex.save_figure("amplitude") is None and "distance_amplitude.png exists" in ex.message.value
    assert ex.overwrite_button.layout.display is None and (tmp_path / "distance_amplitude.png").read_bytes() == before
    ex.overwrite_button.click()
    assert "saved" in ex.message.value and ex.overwrite_button.layout.display == "none"
    assert ex.export_csv("depth_noise") is None and "distance_depth_noise.csv exists" in ex.message.value
    assert ex.write_report() is None and "report_distance exists" in ex.message.value
    assert ex.overwrite_button.click() is None and "wrote" in ex.message.value  # the report, the last pending
    assert ex.save_figures() == [] and "more exist: press Overwrite to replace them" in ex.message.value
    assert ex.export_csv("snr") is None and "no plot 'snr'" in html.unescape(ex.message.value)
    # Nothing is read or written outside its folder; an empty path box names no file.
    for outside in ("/tmp/elsewhere.toml", "../up.toml", ""):
        ex.path.value = outside
        ex.save_button.click()
        assert ("only in" in ex.message.value or "give a file name" in ex.message.value), ex.message.value
        assert ex.message.value.startswith("<span style=") and not ex.message_text.startswith("<")
        assert ex.save_figure("amplitude") is None
    assert not (tmp_path.parent / "up.toml").exists()
    ex.path.value = str(tmp_path / "camera.toml")

    # Save asks before it overwrites; Reset brings every field back to the defaults.
    ex.save()
    assert "saved" in ex.message.value
    _set(ex, "scene.reflectivity", 0.25)
    ex.save_button.click()
    assert "exists: press Overwrite" in ex.message.value and ex.overwrite_button.layout.display is None
    assert tj.load_config(ex.path.value).values["scene"]["reflectivity"] == 0.9
    ex.overwrite_button.click()
    assert "saved" in ex.message.value and tj.load_config(ex.path.value).values["scene"]["reflectivity"] == 0.25
    ex.reset_button.click()
    assert ex.config.values == tj.Config().values and ex.message.value == "reset to the defaults"
    assert ex.fields["scene.reflectivity"].value() == tj.Config().values["scene"]["reflectivity"]


def test_numbers_show_at_sensible_precision():
    ex = tj.explorer()
    raw = tj.Config().values["camera"]["optical_area_m"][1]  # 172 x 17.5 um in floating point
    assert raw != 0.00301 and ex.fields["camera.optical_area_m"].inputs[1].value == 0.00301


def test_the_frame_tabs_default_scene_is_the_readmes_flying_pixel_edge(shared_explorer):
    """The Frame tab opens on the README's step edge, whose edge falls inside a pixel column
    (tests/test_readme.py checks that its frame has a column of flying pixels); at edge_x_m = 0 the
    edge fell between two columns and the default frame showed none."""
    from pathlib import Path

    readme = (Path(__file__).resolve().parents[1] / "README.md").read_text()
    assert f"tofjax render --scene {shared_explorer.frame_scene.value} " in readme
    assert "edge_x_m=0.013" in shared_explorer.frame_scene.value
