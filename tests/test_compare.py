"""Measured data against the model (fitting/_compare.py, `tofjax compare`), the tofjax-sweep/2
additions, multi-frequency fusion, datasheet inputs and validity at the solution (issue 11)."""

import base64
import json
import re
import types
from pathlib import Path

import jax
import numpy as np
import pytest

import fitting as ft
import tofjax as tj
from fitting._compare import compare
from tofjax import sweepfile as sf
from tofjax.cli import main

D = np.linspace(0.4, 3.0, 12)
FREQS = [80.32e6, 60.24e6]
META = {"sweep": "distance", "source": "measurement", "n_phases": 4, "created_utc": "2026-11-21T00:00:00+00:00"}


def _file(path, columns, **meta):
    sf.write_sweep(path, {**META, "modulation_frequency_hz": repr(FREQS[0]), **meta}, columns)
    return path


def _operating(d, frames=100.0, t=2e-3):
    return {"distance_m": d, "integration_time_s": np.full(d.shape, t), "illuminance_lx": np.full(d.shape, 20.0),
            "n_frames": np.full(d.shape, frames)}


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    """Depth-only, amplitude-only and multi-frequency files made from the model itself (so the
    model/measured ratio is 1 by construction), and a near row that saturates."""
    tmp = tmp_path_factory.mktemp("compare")
    d = np.concatenate([[0.12], D])  # 0.12 m saturates the default camera
    r = tj.predict(tj.Params(), tj.Sweep("distance", d))
    depth_only = _file(tmp / "depth_only.csv", {**_operating(d), "depth_mean_m": np.asarray(r.depth_mean_m),
                                                "depth_std_m": np.asarray(r.depth_std_m)})
    amp_only = _file(tmp / "amplitude_only.csv", {**_operating(d), "amplitude_mean_lsb": np.asarray(r.amplitude_mean_lsb),
                                                  "amplitude_std_lsb": np.asarray(r.amplitude_std_lsb)})
    m = tj.predict(tj.Camera(tj.Params(), frequencies_hz=FREQS), tj.Sweep("distance", d))
    multi = _file(tmp / "multi.csv", {**_operating(d), "depth_mean_m": np.asarray(m.depth_mean_m),
                                      "depth_std_m": np.asarray(m.depth_std_m)},
                  modulation_frequencies_hz=",".join(map(repr, FREQS)), frequency_fusion="inverse_variance")
    return depth_only, amp_only, multi


def test_version_2_files_hold_what_version_1_cannot(files):
    depth_only, amp_only, multi = files
    assert depth_only.read_text().startswith("# format: tofjax-sweep/2")
    data = sf.read_sweep(depth_only)
    assert np.all(np.isnan(data.columns["amplitude_mean_lsb"])) and np.all(np.isnan(data.columns["valid_fraction"]))
    assert sf.read_sweep(multi).modulation_frequencies_hz == FREQS
    # a file that needs nothing of version 2 stays version 1 (older readers read it)
    assert sf.needed_format({}, sf.REQUIRED_COLUMNS) == "tofjax-sweep/1"
    text = multi.read_text().replace("tofjax-sweep/2", "tofjax-sweep/1", 1)
    with pytest.raises(sf.SweepFileError, match="modulation_frequencies_hz needs format tofjax-sweep/2"):
        sf.parse_sweep(text, "old.csv")
    with pytest.raises(sf.SweepFileError, match="must start with modulation_frequency_hz"):
        sf.parse_sweep(multi.read_text().replace("80320000.0,60240000.0", "60240000.0,80320000.0"), "m.csv")
    with pytest.raises(sf.SweepFileError, match="frequency_fusion = 'median' is not one of"):
        sf.parse_sweep(multi.read_text().replace("fusion: inverse_variance", "fusion: median"), "m.csv")


def test_compare_depth_only_amplitude_only_and_multifrequency(files):
    dual = tj.Config().replace("illumination_waveform.extra_modulation_frequencies_hz", [FREQS[1]])
    depth, amp = compare(files[:2])
    (multi,) = compare([files[2]], dual)
    for c, name in ((depth, "depth_std_m"), (amp, "amplitude_mean_lsb"), (multi, "depth_std_m")):
        s = c.summary(name)  # the files are the model's own prediction: ratio 1
        assert s["rows"] == len(D) and s["within"] == len(D)
        np.testing.assert_allclose(c.ratio(name)[1:], 1.0, rtol=1e-9)
        assert c.flags[0][0] == "model: pixel saturated" and not any(c.flags[1:])  # the 0.12 m row
    assert np.all(np.isnan(depth.ratio("amplitude_mean_lsb"))) and np.all(np.isnan(amp.ratio("depth_std_m")))
    # the model's expected depth of one frequency is continued to the real distance's period
    np.testing.assert_allclose(depth.model["depth_mean_m"][1:], D, atol=0.03)
    # ... and drawn as the measured readings are, as read: wrapped into [0, 1.866) m, the line broken at
    # the wrap (it had been drawn unwrapped, up to 3 m, beside readings that wrap)
    lines = {line.get_label(): np.asarray(line.get_ydata(), dtype=float)
             for line in ft._compare.figure(depth).axes[0].lines}
    read, model = lines["measured"], lines["model (expected depth)"]
    assert read.size == len(D) and np.all(read < depth.range_m) and read.max() > 0.9 * depth.range_m
    finite = np.flatnonzero(np.isfinite(model))  # the near rows saturate (no value); D reaches 3 m: one wrap
    assert np.nanmax(model) < depth.range_m and np.sum(np.diff(finite) > 1) == 1
    assert multi.range_m == pytest.approx(7.465, abs=1e-3)
    with pytest.raises(ft.CalibrationInputError, match="measured at 2 modulation frequencies.*configuration has 1"):
        compare([files[2]])  # never modelled with one frequency silently


def test_compare_command_writes_tables_and_an_html_report(files, tmp_path, capsys):
    dual = tmp_path / "dual.toml"
    dual.write_text("[illumination_waveform]\nextra_modulation_frequencies_hz = [60.24e6]\n")
    out = tmp_path / "cmp"
    assert main(["compare", str(files[0]), str(files[1]), "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "depth noise model/measured median 1.000, 12/12 within 30 %; 1 rows flagged" in printed
    table = (out / "comparison.csv").read_text().splitlines()
    assert len(table) == 1 + 2 * (len(D) + 1) and "model: pixel saturated" in table[1]
    html = (out / "comparison.html").read_text()
    images = re.findall(r"data:image/png;base64,([A-Za-z0-9+/=]+)", html)
    assert len(images) == 2 and base64.b64decode(images[0])[:4] == b"\x89PNG"
    assert "| depth_only.csv | depth_std_m | 12 | 12 | 1.000 |" in (out / "comparison.md").read_text()
    assert main(["compare", str(files[2]), "--out", str(out), "--overwrite"]) == 2
    assert "measured at 2 modulation frequencies" in capsys.readouterr().err
    assert main(["compare", str(files[2]), "--config", str(dual), "--out", str(out), "--overwrite"]) == 0


def test_fused_noise_matches_the_monte_carlo_for_every_fusion():
    """The analytic fused depth noise sqrt(sum w^2 s^2) / sum w against frames fused the same way
    (2000 frames: the std's standard error is 1.6 %)."""
    p = tj.Params(scene=tj.Scene(illuminance_lx=0.0))
    sweep = tj.Sweep("distance", [0.6, 1.4, 2.2])
    for fusion in ("inverse_variance", "highest_frequency"):
        a = tj.predict(tj.Camera(p, frequencies_hz=FREQS, fusion=fusion), sweep)
        m = tj.simulate(tj.Camera(p, frequencies_hz=FREQS, fusion=fusion), sweep, jax.random.key(3), 2000)
        np.testing.assert_allclose(np.asarray(m.depth_std_m), np.asarray(a.depth_std_m), rtol=0.06)
    per = np.asarray(a.per_frequency.depth_std_m)
    inverse = tj.predict(tj.Camera(p, frequencies_hz=FREQS), sweep)
    np.testing.assert_allclose(np.asarray(inverse.depth_std_m), (per[0] ** -2 + per[1] ** -2) ** -0.5, rtol=1e-12)
    np.testing.assert_allclose(np.asarray(a.depth_std_m), per[0], rtol=1e-12)  # highest frequency alone


def test_phase_noise_wiggles_with_distance_in_both_paths():
    """With non-sinusoidal correlation the depth noise oscillates with distance (Köhler et al.,
    Sensors 25:109, 2025): the analytic path follows the Monte Carlo point by point."""
    p = tj.Params(scene=tj.Scene(illuminance_lx=0.0))
    d = np.linspace(1.0, 1.0 + 1.8662 / 4, 9)  # one wiggle period of a 4-phase camera (d_u / 4)
    a = np.asarray(tj.predict(p, tj.Sweep("distance", d)).depth_std_m)
    m = np.asarray(tj.simulate(p, tj.Sweep("distance", d), jax.random.key(5), 4000).depth_std_m)
    np.testing.assert_allclose(m, a, rtol=0.05)
    relative = a / d
    assert relative.max() / relative.min() > 1.15  # not a smooth 1/amplitude law: it wiggles


def test_datasheet_full_well_exposure_and_background_mixture():
    near = tj.Sweep("distance", np.linspace(0.15, 1.0, 40))
    r = tj.predict(tj.Params(pixel=tj.Pixel(full_well_e=20_000.0)), near)
    n = r.noise
    top = np.asarray(n.signal_e + n.background_e) / 2 + np.asarray(n.dark_e) / 2  # a lower bound of the fuller tap
    assert np.all(np.asarray(r.full_well_fraction) >= top / 20_000.0 * (1 - 1e-12))
    swing = tj.predict(tj.Params(), near)
    assert np.sum(np.asarray(r.valid_fraction) < 1) > np.sum(np.asarray(swing.valid_fraction) < 1)
    np.testing.assert_allclose(np.asarray(r.full_well_fraction) * 20_000.0,
                               np.asarray(swing.full_well_fraction) * (2.9 - 2.0) * 14e-15 / 1.602176634e-19, rtol=1e-12)
    # exposure per frame of two frequencies x 4 phases = 8 phase images
    cfg = tj.Config().replace("scene.integration_time_per", "frame").replace(
        "illumination_waveform.extra_modulation_frequencies_hz", [60.24e6])
    assert float(cfg.params.scene.integration_time_s) == pytest.approx(2e-3 / 8, rel=1e-15)
    assert tj.optics.phase_image_time_s(4e-3, "frequency", 4) == pytest.approx(1e-3)
    # a mixture's background electrons are the sum of its sources' (Eq 3.4 per source)
    sweep = tj.Sweep("illuminance", [300.0])
    mix = tj.predict(tj.Params(scene=tj.Scene(extra_backgrounds=("led",), extra_illuminances_lx=[500.0])), sweep)
    sun = tj.predict(tj.Params(), sweep)
    led = tj.predict(tj.Params(scene=tj.Scene(background="led")), tj.Sweep("illuminance", [500.0]))
    np.testing.assert_allclose(mix.noise.background_e, sun.noise.background_e + led.noise.background_e, rtol=1e-12)
    # a white LED has almost nothing at 850 nm behind a 20 nm filter, sunlight plenty
    filtered = lambda lamp: float(tj.optics.background_photon_irradiance(lamp, 1000.0, 850e-9, 20e-9, tj.PhysicalConstants()))  # noqa: E731
    assert 0 < filtered("led") < filtered("sunlight") / 100
    with pytest.raises(tj.ConfigError, match="extra_backgrounds.*names 1 source.*gives 0"):
        tj.Config().replace("scene.extra_backgrounds", ["led"])


def test_calibration_leaves_out_what_the_fitted_model_cannot_measure(files, tmp_path, capsys):
    """A depth-only file whose nearest row the camera saturates (made by the smooth model, which has
    values there): with ``leave_out_invalid`` the row is left out by name and refitted. The dark
    slope of these data is 0: flagged at its bound. An unconverged fit still writes its diagnostics;
    --mcmc works with one parameter."""
    r = tj.predict(tj.Params(pixel=tj.Pixel(dark_slope_mean_v_per_s=0.0)),
                   tj.Sweep("distance", np.concatenate([[0.12], D])), smooth=tj.Smooth())
    path = _file(tmp_path / "smooth.csv", {**_operating(np.concatenate([[0.12], D])),
                                           "depth_std_m": np.asarray(r.depth_std_m)})
    cal = ft.calibrate([path], fit=["pixel.demodulation_contrast", "pixel.dark_slope_mean_v_per_s"],
                       relative_error=0.02, leave_out_invalid=True)
    assert [(e["line"], e["reason"]) for e in cal.excluded_at_solution] == [(8, "the fitted model saturates the pixel here")]
    assert cal.least_squares.estimate[0] == pytest.approx(0.42, rel=1e-3)
    (flag,) = cal.least_squares.bound_flags
    assert flag["name"] == "pixel.dark_slope_mean_v_per_s" and flag["bound"] == "lower"
    # The dark slope walks to its bound, where chi^2 stops changing: the fit stops after a stalled
    # segment instead of walking its unconstrained coordinate on (666 steps before segments).
    assert cal.least_squares.converged and cal.least_squares.steps <= 2 * ft._least_squares.SEGMENT_STEPS
    assert "chi^2 fell by" in cal.least_squares.solver_message
    written = {p.name for p in cal.write(tmp_path / "out")}
    assert {"compare_initial.html", "compare_calibrated.csv", "fit_0_smooth.png", "residuals.png"} <= written
    # One figure per file: the comparisons' reports are tables, the fit figure shows the initial model.
    assert not [n for n in written if n.startswith("compare_") and n.endswith(".png")]
    assert "![" not in (tmp_path / "out" / "compare_initial.md").read_text()
    assert [ft._data.reason_kind(f"measured amplitude SNR {v} below the limit 5 (--min-snr)") for v in (4.1, 3)] \
        == ["amplitude SNR below --min-snr"] * 2
    report = (tmp_path / "out" / "report.md").read_text()
    assert "line 8: the fitted model saturates the pixel here" in report and "lower bound" in report
    out = tmp_path / "unconverged"
    assert main(["calibrate", str(path), "--fit", "pixel.demodulation_contrast", "--relative-error", "0.02",
                 "--initial", "pixel.demodulation_contrast=0.9", "--max-steps", "1", "--leave-out-invalid",
                 "--out", str(out), "--quiet"]) == 1
    assert "--max-steps 1" in capsys.readouterr().err and (out / "report.md").exists()
    out = tmp_path / "mcmc"
    assert main(["calibrate", str(path), "--fit", "pixel.demodulation_contrast", "--relative-error", "0.02",
                 "--mcmc", "--walkers", "4", "--steps", "30", "--leave-out-invalid", "--out", str(out), "--quiet"]) == 0
    assert (out / "corner.png").exists()


def test_every_measured_point_constrains_the_calibration(tmp_path):
    """Issue 34 item 1. A camera 30 % less noisy than the default model, measured from 0.34 m (where
    the default camera keeps 9 % of its range) out: a fit of the contrast that ignores validity
    follows the low noise until the ADC rails at 0.34 m and leaves that row out; the default fit
    keeps it measured (headroom above the margin, named at its edge in the report and on the
    console), never drops it, and its contrast lies between the two."""
    d = np.concatenate([[0.34], D])
    truth = tj.predict(tj.Params(), tj.Sweep("distance", d))
    assert 0.05 < float(truth.headroom[0]) < 0.1
    path = _file(tmp_path / "better.csv", {**_operating(d), "depth_std_m": 0.7 * np.asarray(truth.depth_std_m)})
    fit = ["pixel.demodulation_contrast", "pixel.dark_slope_mean_v_per_s"]
    free = ft.calibrate([path], fit=fit, relative_error=0.02, leave_out_invalid=True)
    assert [(e["line"], e["reason"]) for e in free.excluded_at_solution] == [(8, "the fitted model saturates the ADC here")]
    held = ft.calibrate([path], fit=fit, relative_error=0.02)
    assert held.excluded_at_solution == [] and held.unexplained == []
    (edge,) = held.at_limit  # the hard model's headroom at the solution: measured, at the margin
    assert edge["line"] == 8 and 0 < edge["headroom"] < 2 * ft._problem.VALID_MARGIN
    k_free, k_held = free.estimates[fit[0]], held.estimates[fit[0]]
    assert 0.42 < k_held < k_free
    assert "better.csv line 8: held at the edge" in ft._calibrate._report(held, []).markdown()


def test_the_systematic_error_is_an_observable(tmp_path):
    """Issue 34 item 2. A camera whose demodulation phase is offset by 0.3 rad reads every distance
    0.3 c / (4 pi f) = 89 mm long (plus the wiggling's change): calibrating the offset and the contrast
    on its mean readings, noise and amplitudes recovers both (exact data: to 1e-6), across the
    readings that wrap at the unambiguity range (2.0-2.6 m beyond 1.87 m)."""
    d = np.linspace(0.5, 2.6, 12)
    truth = tj.Config().replace("pixel.phase_offset_rad", 0.3).replace("pixel.demodulation_contrast", 0.4)
    r = tj.predict(truth.params, tj.Sweep("distance", d), smooth=tj.Smooth())
    du = float(truth.params.unambiguity_range_m)
    assert np.any(d > du) and np.all(np.asarray(r.depth_mean_m) < du)  # the far readings wrap
    # The offset reads as a path longer by 2 x shift: noise and ADC off, the offset camera's reading at d
    # is the plain camera's at d + shift (the light's fall-off changes the amplitude only).
    shift = 0.3 * 299792458.0 / (4 * np.pi * float(truth.params.illumination_waveform.modulation_frequency_hz))
    ideal = tj.Config().replace("pixel.noise", False).replace("adc.enabled", False)
    offset = tj.predict(ideal.replace("pixel.phase_offset_rad", 0.3).params, tj.Sweep("distance", [1.0]))
    np.testing.assert_allclose(offset.depth_mean_m, tj.predict(ideal.params, tj.Sweep("distance", [1.0 + shift])).depth_mean_m,
                               rtol=1e-9)
    columns = {"depth_mean_m": r.depth_mean_m, "depth_std_m": r.depth_std_m, "amplitude_mean_lsb": r.amplitude_mean_lsb,
               "amplitude_std_lsb": r.amplitude_std_lsb}
    path = _file(tmp_path / "offset.csv", {**_operating(d), **{k: np.asarray(v) for k, v in columns.items()}})
    cal = ft.calibrate([path], fit=["pixel.phase_offset_rad", "pixel.demodulation_contrast"])
    np.testing.assert_allclose(cal.least_squares.estimate, [0.3, 0.4], rtol=1e-6)
    assert cal.least_squares.chi2 < 1e-6
    (summary,) = [s for s in cal.least_squares.residual_summary if s["observable"] == "depth_mean_m"]
    assert summary["rows"] == len(d)
    # Without the offset the mean readings lie far off: calibrate's console says to fit it.
    from fitting.cli import offset_note

    off = {**summary, "mean": 40.0}
    assert offset_note(types.SimpleNamespace(residual_summary=[off], names=("pixel.demodulation_contrast",))) == (
        f"note: the mean readings of {path} lie +40.0 sigma from the model's on average: a camera's depth offset; "
        "fit it too (--fit ...,pixel.phase_offset_rad)")
    assert offset_note(cal.least_squares) is None
    assert offset_note(types.SimpleNamespace(residual_summary=[off], names=cal.least_squares.names)) is None


def test_compare_outputs_keep_files_apart_and_show_names_as_text(files, tmp_path, capsys):
    """Two files of one name get a report section each; a 240-character name, HTML, Markdown and a
    spreadsheet formula in file names are shown as text; a file's override of its phases is checked."""
    text = files[0].read_text()
    a, b = tmp_path / "a", tmp_path / "b"
    a.mkdir()
    b.mkdir()
    (a / "distance.csv").write_text(text)
    (b / "distance.csv").write_text(text)
    long = tmp_path / ("x" * 236 + ".csv")
    long.write_text(text)
    odd = tmp_path / "=HYPERLINK(1)<b>|x|[l](u).csv"
    odd.write_text(text)
    out = tmp_path / "cmp"
    assert main(["compare", str(a / "distance.csv"), str(b / "distance.csv"), str(long), str(odd),
                 "--out", str(out)]) == 0
    rows = len(D) + 1
    md = (out / "comparison.md").read_text()
    sections = md.split("\n## ")[2:]  # after the summary
    assert len(sections) == 4 and all(s.count("\n| ") == rows + 1 for s in sections)  # header + its own rows
    assert "<b>" not in md and "&lt;b&gt;" in md and "\\|x\\|\\[l\\](u)" in md
    html = (out / "comparison.html").read_text()
    assert "<b>" not in html and html.count("<h2>distance.csv</h2>") == 2
    table = (out / "comparison.csv").read_text().splitlines()
    assert len(table) == 1 + 4 * rows and sum(line.startswith("'=HYPERLINK(1)") for line in table) == rows
    pngs = sorted(p.name for p in out.glob("*.png"))
    assert len(pngs) == 4 and max(map(len, pngs)) < 80
    assert "comparison_3__HYPERLINK_1_b_x_l_u_.png" in pngs
    # "# pixel.n_phases: 3" beside "# n_phases: 4": refused, not applied after the check.
    lines = text.splitlines()
    lines.insert(1, "# pixel.n_phases: 3")
    (tmp_path / "phases.csv").write_text("\n".join(lines) + "\n")
    assert main(["compare", str(tmp_path / "phases.csv"), "--out", str(tmp_path / "c2")]) == 2
    assert "n_phases = 4 in the file, but the configuration has pixel.n_phases = 3" in capsys.readouterr().err


def test_compare_checks_a_specifications_bounds_with_their_margins(files, tmp_path, capsys):
    """A tofjax-sweep/4 file of bounds only, stated around the model's own prediction (10 % above it on
    the first rows, 10 % below on the rest): met exactly where the bound is above, with margin
    bound - model; the saturated near row meets no bound on its depth (the datasheet promises one)."""
    d = np.concatenate([[0.12], D])
    r = tj.predict(tj.Params(), tj.Sweep("distance", d))
    std = np.asarray(r.depth_std_m)
    factor = np.where(np.arange(len(d)) < 7, 1.1, 0.9)
    bound = np.where(np.isfinite(std), factor * std, 1e-3)
    path = _file(tmp_path / "spec.csv", {**_operating(d, frames=np.nan), "depth_std_m_le": bound},
                 source="specification", **{"bound.depth_std_m_le": "'noise <= x', a test"})
    (c,) = compare([path])
    (b,) = c.bounds
    np.testing.assert_array_equal(b.met, np.isfinite(std) & (factor > 1))
    np.testing.assert_allclose(b.margin[1:], bound[1:] - std[1:], rtol=1e-12)
    assert not b.met[0] and np.isnan(b.model[0])
    out = tmp_path / "out"
    assert main(["compare", str(path), "--out", str(out)]) == 0
    console = capsys.readouterr().out
    assert f"depth_std_m_le (depth_std_m <= bound): NOT met, 6 of {len(d)} rows meet it; the model has no value " \
           "(saturated) at distance [m] = 0.12" in console
    rows = (out / "bounds.csv").read_text().splitlines()
    assert rows[0] == "file,line,sweep_value,distance_m,bound,relation,bound_value,model_value,met,margin"
    assert len(rows) == 1 + len(d) and sum(r.split(",")[8] == "yes" for r in rows[1:]) == 6
    assert "## Published bounds" in (out / "comparison.md").read_text()


def test_a_file_under_another_lamp_is_compared_under_the_common_lamp():
    """compare models the example's halogen sweep under sunlight at the lux that give the same in-band
    photons (fitting._problem.under_common_lamp), so files of one camera under different lamps share
    one compiled program; its model equals the file's own (halogen) model at every row."""
    examples = Path(ft.__file__).parent / "examples"
    config = tj.load_config(examples / "camera.toml")
    m = ft.read_measurement(examples / "illuminance.csv", config)
    assert m.config.params.scene.background == "halogen"
    common, scale = ft._problem.under_common_lamp(m.config.params)
    assert common.scene.background == "sunlight" and abs(scale - 1.0) > 0.1
    (c,) = compare([examples / "illuminance.csv"], config)
    own = ft._problem.hard_observables(m.config.params, m.sweep, tuple(m.frequencies_hz), m.fusion)
    for name in ("amplitude_mean_lsb", "depth_std_m", "amplitude_std_lsb"):
        np.testing.assert_allclose(c.model[name], np.asarray(getattr(own, name)), rtol=1e-12, atol=0, err_msg=name)


# --- Issue 50 item 4: a datasheet's bounds calibrate a preset --------------------------------------
# One problem structure for both tests below (5 rows, one upper bound on the depth noise, the power
# and the filter fitted): a bounds-only file and one with measured rows share its compiled programs.
SPEC_D = np.array([1.0, 1.5, 2.0, 2.5, 3.0])
SPEC_FIT = ["illumination.peak_power_w", "scene.filter_half_width_m"]


def _spec(path, bound, depth_std=None, frames=np.nan):
    """Rows at :data:`SPEC_D` in the dark (2 ms), an upper bound on the depth noise (NaN: none there)
    and, where given, measured depth noise; ``source: specification`` without measured rows."""
    n = len(SPEC_D)
    columns = {"distance_m": SPEC_D, "integration_time_s": np.full(n, 2e-3), "illuminance_lx": np.zeros(n),
               "n_frames": np.broadcast_to(frames, (n,)).astype(float), "depth_std_m_le": bound}
    if depth_std is not None:
        columns["depth_std_m"] = depth_std
    return _file(path, columns, source="specification" if depth_std is None else "measurement",
                 **{"bound.depth_std_m_le": "'temporal noise <= x', a test"})


def _power_meeting(bound):
    """The power at which the hard model's worst row meets its bound with equality (bisection in log
    power between 1 and 12 W, where the nearest row is not yet saturated): the independent answer."""
    rows = np.isfinite(bound)

    def worst(power):
        p = tj.Config().replace("illumination.peak_power_w", power).params
        r = tj.predict(p, tj.Sweep.points("distance", SPEC_D[rows], np.zeros(rows.sum()), np.full(rows.sum(), 2e-3),
                                          np.full(rows.sum(), float(p.pixel.temperature_c))))
        return float(np.max(np.asarray(r.depth_std_m) / bound[rows]))

    lo, hi = 1.0, 12.0
    assert worst(lo) > 1 > worst(hi)
    for _ in range(26):  # to 1e-7
        mid = (lo * hi) ** 0.5
        lo, hi = (mid, hi) if worst(mid) > 1 else (lo, mid)
    return hi


def test_a_specification_alone_calibrates_to_the_smallest_change(tmp_path, capsys):
    """Issue 50 item 4. A file of bounds only (noise <= 5 mm at 1-3 m in the dark): the calibration
    finds the smallest change from the configuration that meets every bound. The power is the
    hard model's bisection for the worst row (3 m) met with equality, held 0.1 % inside it; the filter,
    which no bound sees (no ambient light), stays where it started, free over its whole range; the
    bounds pin the power from below (the 3 m row) and above (the 1.0 m row saturates); 9 W is beyond
    laser class 1 by the eye-safety estimate."""
    path = _spec(tmp_path / "spec.csv", np.full(len(SPEC_D), 5e-3))
    out = tmp_path / "cal"
    assert main(["calibrate", str(path), "--fit", ",".join(SPEC_FIT), "--initial", "scene.filter_half_width_m=2e-8",
                 "--out", str(out), "--quiet"]) == 0
    console = capsys.readouterr().out
    result = json.loads((out / "calibration.json").read_text())
    estimate = {k: v["estimate"] for k, v in result["least_squares"]["parameters"].items()}
    expected = _power_meeting(np.full(len(SPEC_D), 5e-3))
    assert 7.0 < expected < 12.0 and expected < estimate[SPEC_FIT[0]] < 1.005 * expected
    assert estimate[SPEC_FIT[1]] == pytest.approx(2e-8, rel=1e-6)
    lines = [int(x) for x in sf.read_sweep(path).lines]
    bounds = result["bounds"]
    assert (bounds["rows"], bounds["met"], bounds["unmet"]) == (5, 5, [])
    assert [a["line"] for a in bounds["active"]] == [lines[-1]]  # 3 m, met with equality
    power, width = bounds["parameters"]
    assert power["status"] == "pinned below" and power["lower_breaks"]["line"] == lines[-1]
    assert power["lower"] == pytest.approx(estimate[SPEC_FIT[0]], rel=3e-3)
    assert power["upper_breaks"]["line"] == lines[0] and 10.0 < power["upper"] < 15.0  # the 1 m row saturates
    assert width["status"] == "free" and width["upper_end"] == "range" and width["upper"] == pytest.approx(1e-6)
    (laser,) = bounds["physical"]
    assert laser["kind"] == "laser class" and laser["ratio"] > 1.0
    assert "least squares: converged" in console and "smallest change from the configuration" in console
    assert "bounds: 5 of 5 bound rows met by the hard model at the solution; 1 active" in console
    assert f"{SPEC_FIT[0]} = " in console and "pinned below" in console and ": free;" in console
    assert "warning: the fitted illumination" in console and "beyond laser class 1" in console
    assert "an estimate, not a classification" in console
    report = (out / "report.md").read_text()
    assert "## Published bounds" in report and "| illumination.peak_power_w | W | 1.2 |" in report
    assert f"active: spec.csv line {lines[-1]}: depth_std_m_le (bound 5 mm" in report
    assert {"compare_initial_bounds.csv", "compare_calibrated_bounds.csv", "calibrated.toml"} <= {p.name for p in out.iterdir()}


def test_a_bound_beside_measured_rows_constrains_the_fit(tmp_path):
    """Issue 50 item 4. Measured noise at 1-2 m of a 3 W camera (exact: the fit alone would return
    3 W) beside a datasheet's 8 mm at 2.5-3 m, which needs more light: the bound becomes active, the
    power is where the worst bounded row meets it (the hard model's bisection), and the data pay for
    it in chi^2. The change residuals weigh nothing beside measured rows."""
    truth = tj.predict(tj.Config().replace("illumination.peak_power_w", 3.0).params,
                       tj.Sweep.points("distance", SPEC_D, np.zeros(5), np.full(5, 2e-3), np.full(5, 25.0)),
                       smooth=tj.Smooth())
    measured = np.where(SPEC_D <= 2.0, np.asarray(truth.depth_std_m), np.nan)
    bound = np.where(SPEC_D > 2.0, 8e-3, np.nan)
    path = _spec(tmp_path / "mixed.csv", bound, depth_std=measured, frames=np.where(SPEC_D <= 2.0, 100.0, np.nan))
    cal = ft.calibrate([path], fit=SPEC_FIT, initial={SPEC_FIT[1]: 2e-8})
    assert not cal.problem.bounds_only and cal.least_squares.dof == 1
    expected = _power_meeting(bound)
    assert expected > 1.3 * 3.0 and expected < cal.estimates[SPEC_FIT[0]] < 1.005 * expected
    assert cal.least_squares.chi2 > 10.0  # the measured rows are pulled off their 3 W
    lines = [int(x) for x in sf.read_sweep(path).lines]
    assert [a["line"] for a in cal.bounds.active] == [lines[-1]] and cal.bounds.unmet == []
    assert cal.bounds.intervals[0]["status"] == "pinned below"


def test_fitted_values_beyond_a_physical_limit_are_reported_not_raised(tmp_path):
    """A responsivity whose quantum efficiency exceeds 1 (the configuration's check refuses it) and a
    contrast at 1, the top of its range (the bounds would ask for more), are flags of the report, not a
    traceback; without a valid configuration no calibrated.toml is written (Calibration.refused)."""
    path = _spec(tmp_path / "spec.csv", np.full(len(SPEC_D), 5e-3))
    config = tj.Config()
    rows = [ft.load_rows(path, config)]
    names = ["pixel.photo_responsivity_a_per_w", "pixel.demodulation_contrast"]
    problem = ft.build_problem(ft.make_parameters(names, {names[0]: 0.25, names[1]: 0.42}), rows)
    flags = ft.physical_flags(config, rows, problem, np.array([0.9, 1.0]))
    kinds = [f["kind"] for f in flags]
    assert kinds == ["configuration", "out of range"]
    assert "quantum efficiency above 1" in flags[0]["message"]
    assert flags[1]["message"].startswith("pixel.demodulation_contrast = 1 is at the edge of its physical range")
    assert "a value above 1, out of range" in flags[1]["message"]
    ls = types.SimpleNamespace(names=tuple(names), estimate=np.array([0.9, 1.0]))
    cal = ft.Calibration(config, rows, problem, ls, None)
    assert "quantum efficiency above 1" in cal.refused
    assert ft.Calibration(config, rows, problem, types.SimpleNamespace(names=tuple(names), estimate=np.array(
        [0.25, 0.5])), None).refused is None
