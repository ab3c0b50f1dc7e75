"""Calibration: inputs and their errors, parameter recovery, degeneracy reports, posterior, CLI.

The problem structures are kept few (compilation dominates): one three-file problem (the example
data set) serves the recovery, posterior and CLI tests.
"""

import math
import shutil
from pathlib import Path

import jax.numpy as jnp
import numpy as np
import pytest

import fitting as ft
import tofjax as tj
from tofjax import sweepfile as sf
from tofjax.cli import main

EXAMPLES = Path(ft.__file__).parent / "examples"
FILES = [EXAMPLES / f"{n}.csv" for n in ("distance", "integration_time", "illuminance")]
TRUE = {"pixel.demodulation_contrast": 0.38, "pixel.photo_responsivity_a_per_w": 0.25,
        "pixel.dark_slope_mean_v_per_s": 2.0}
NAMES = list(TRUE)


@pytest.fixture(scope="module")
def config():
    return tj.load_config(EXAMPLES / "camera.toml")


@pytest.fixture(scope="module")
def example_fit(config):
    return ft.calibrate(FILES, config, fit=NAMES)


def test_example_files_are_labelled_as_simulated():
    for path in FILES:
        meta = sf.read_sweep(path).metadata
        assert meta["source"] == "simulation" and "not a measurement" in meta["note"]
        assert float(meta["true.pixel.demodulation_contrast"]) == 0.38


def test_recovers_the_true_parameters_within_three_sigma(example_fit):
    ls = example_fit.least_squares
    assert ls.converged and ls.dof == pytest.approx(ls.chi2 / ls.chi2_per_dof, rel=1e-12)  # exact equality: rounding
    for name, value, estimate, sigma in zip(ls.names, TRUE.values(), ls.estimate, ls.sigma, strict=True):
        assert abs(estimate - value) < 3 * sigma, (name, estimate, sigma)
    assert 0.7 < ls.chi2_per_dof < 1.4
    # the data really moved the parameters away from the configuration's starting values
    assert abs(ls.estimate[0] - 0.42) > 2 * ls.sigma[0]


def test_files_under_another_lamp_join_the_group_at_the_same_photons(example_fit, config):
    """The example's illuminance sweep was taken under a halogen lamp, the other two under sunlight:
    one group (one model call per step), the halogen rows at the sunlight illuminance that gives the
    same in-band photons. The group's hard model at the solution equals each file's own (its lamp,
    its lux) to rounding; with the filter's band fitted, the lamps keep groups of their own."""
    problem, rows = example_fit.problem, example_fit.rows
    assert [r.params.scene.background for r in rows] == ["sunlight", "sunlight", "halogen"]
    (group,) = problem.groups
    theta = jnp.asarray(example_fit.least_squares.estimate)
    hard = ft._problem.hard_observables
    merged = hard(problem.with_values(group.params, theta), group.model_sweep(dense=False), group.frequencies_hz,
                  group.fusion)
    for i, (lo, hi) in zip(group.files, group.bounds, strict=True):
        own = hard(problem.with_values(rows[i].params, theta), rows[i].sweep, group.frequencies_hz, group.fusion)
        for name in ("amplitude_mean_lsb", "depth_std_m", "pixel_saturated_fraction"):
            np.testing.assert_allclose(getattr(merged, name)[lo:hi], getattr(own, name), rtol=1e-12, atol=0,
                                       err_msg=f"{name} of {Path(rows[i].path).name}")
    scale = np.asarray(group.lamp_scale)[: group.n_data]
    lo, hi = group.bounds[2]
    assert np.all(scale[:lo] == 1.0) and np.all(scale[lo:hi] == scale[lo]) and abs(scale[lo] - 1.0) > 0.1
    band = ft.make_parameters([*NAMES, "illumination.wavelength_m"],
                              {**dict(zip(NAMES, example_fit.least_squares.estimate, strict=True)),
                               "illumination.wavelength_m": float(rows[0].params.illumination.wavelength_m)})
    assert [g.files for g in ft.build_problem(band, rows).groups] == [(0, 1), (2,)]
    # With a spectral response (not flat) the lamps' ratio is the detected photons' (the model's own):
    # the halogen file's rows, merged, still equal its own model; fitting the response splits the group.
    deep = config.replace("pixel.collection_depth_m", 30e-6)
    rows_deep = [ft.load_rows(path, deep) for path in FILES]
    deep_problem = ft.build_problem(band[:3], rows_deep)
    (group,) = deep_problem.groups
    merged = hard(deep_problem.with_values(group.params, theta), group.model_sweep(dense=False), group.frequencies_hz,
                  group.fusion)
    lo, hi = group.bounds[2]
    own = hard(deep_problem.with_values(rows_deep[2].params, theta), rows_deep[2].sweep, group.frequencies_hz,
               group.fusion)
    np.testing.assert_allclose(merged.amplitude_mean_lsb[lo:hi], own.amplitude_mean_lsb, rtol=1e-12)
    np.testing.assert_allclose(merged.depth_std_m[lo:hi], own.depth_std_m, rtol=1e-12)
    response = ft.make_parameters([*NAMES, "pixel.collection_depth_m"],
                                  {**dict(zip(NAMES, example_fit.least_squares.estimate, strict=True)),
                                   "pixel.collection_depth_m": 30e-6})
    assert [g.files for g in ft.build_problem(response, rows_deep).groups] == [(0, 1), (2,)]


def test_transforms_are_bijective_and_never_clip():
    p = ft.make_parameters(["pixel.demodulation_contrast"], {"pixel.demodulation_contrast": 0.42})[0]
    assert (p.lower, p.upper) == (0.0, 1.0)
    for theta in (1e-9, 0.3, 0.999999):
        assert float(p.to_constrained(p.to_unconstrained(theta))) == pytest.approx(theta, rel=1e-9)
    assert 0 < float(p.to_constrained(jnp.asarray(-40.0))) < float(p.to_constrained(jnp.asarray(40.0))) <= 1
    # log-Jacobian matches the derivative of the transform
    u = 0.7
    h = 1e-6
    d = (float(p.to_constrained(u + h)) - float(p.to_constrained(u - h))) / (2 * h)
    assert float(p.log_abs_jacobian(jnp.asarray(u))) == pytest.approx(math.log(d), rel=1e-7)


def test_a_bound_flag_needs_the_data_to_push_the_parameter_there():
    """A parameter the data cannot see (sigma inf) stays at its start: it is not "at its lower bound 0"
    because its interval is wide (a frame rate of 5 within 0-10 000 Hz was), nor is a well-measured
    50 +- 2 e- within 0-1e5 (1e-3 of the interval); a dark slope pushed onto 0 is."""
    from types import SimpleNamespace

    from fitting._least_squares import bound_flags

    problem = SimpleNamespace(names=("timing.frame_rate_hz", "pixel.readout_noise_e", "pixel.dark_slope_mean_v_per_s"),
                              kinds=("both", "both", "both"), lower=np.zeros(3), upper=np.array([1e4, 1e5, 100.0]),
                              initial=np.array([5.0, 50.0, 1.0]))
    flags = bound_flags(problem, np.array([5.0, 50.0, 1e-6]), np.array([np.inf, 2.0, 0.1]))
    assert [(f["name"], f["bound"]) for f in flags] == [("pixel.dark_slope_mean_v_per_s", "lower")]
    assert flags[0]["message"].startswith("pixel.dark_slope_mean_v_per_s = 1e-06 is at its lower bound 0: the data")
    near = bound_flags(problem, np.array([5.0, 3.0, 1.0]), np.array([np.inf, 2.0, 0.1]))
    assert [f["message"][:58] for f in near] == ["pixel.readout_noise_e = 3 is within 1.5 sigma of its lower"]


@pytest.mark.parametrize(
    "kwargs, pattern",
    [
        ({"fit": ["pixel.contrast"]}, r"unknown parameter 'pixel.contrast' \(did you mean"),
        ({"fit": ["scene.distance_m"]}, "operating-point column"),
        ({"fit": ["pixel.demodulation_contrast"], "bounds": {"pixel.demodulation_contrast": (0.6, 0.2)}},
         "bounds of pixel.demodulation_contrast are reversed"),
        ({"fit": ["pixel.demodulation_contrast"], "bounds": {"pixel.demodulation_contrast": (0.5, 0.9)}},
         r"initial value of pixel.demodulation_contrast = 0.42 is not strictly inside its bounds \[0.5, 0.9\]"),
        ({"fit": ["pixel.demodulation_contrast"], "bounds": {"pixel.demodulation_contrast": (0.1, 1.5)}},
         "upper bound of pixel.demodulation_contrast = 1.5 is outside the physical range"),
        ({"fit": ["camera.k_lens"], "priors": {"pixel.demodulation_contrast": (0.4, 0.1)}}, "which is not fitted"),
        ({"fit": []}, "no parameter to fit"),
    ],
)
def test_bad_parameter_specifications(kwargs, pattern):
    with pytest.raises(ft.CalibrationInputError, match=pattern):
        ft.calibrate(FILES[:1], **kwargs)


def _edit(tmp_path, source, replace=None, drop_meta=None, name="edited.csv"):
    text = Path(source).read_text()
    if replace:
        text = text.replace(*replace)
    if drop_meta:
        text = "\n".join(line for line in text.splitlines() if not line.startswith(f"# {drop_meta}:")) + "\n"
    path = tmp_path / name
    path.write_text(text)
    return path


def test_mismatched_files_and_bad_cells_name_file_line_and_column(tmp_path, config):
    f_mod = _edit(tmp_path, FILES[0], ("# modulation_frequency_hz: 80320000.0", "# modulation_frequency_hz: 60240000.0"))
    with pytest.raises(ft.CalibrationInputError, match=r"edited.csv: modulation frequency 1 = 60240000.0 Hz in the "
                                                       r"file, but the configuration has illumination_waveform."
                                                       r"modulation_frequency_hz = 80320000.0"):
        ft.calibrate([f_mod], config, fit=NAMES)
    phases = _edit(tmp_path, FILES[0], ("# n_phases: 4", "# n_phases: 3"))
    with pytest.raises(ft.CalibrationInputError, match="n_phases = 3 in the file"):
        ft.calibrate([phases], config, fit=NAMES)
    lines = FILES[0].read_text().splitlines()
    row = next(i for i, line in enumerate(lines) if line.startswith("0.5,"))
    cells = lines[row].split(",")
    cells[5] = "n/a"
    lines[row] = ",".join(cells)
    bad = tmp_path / "cell.csv"
    bad.write_text("\n".join(lines) + "\n")
    with pytest.raises(sf.SweepFileError, match=rf"cell.csv:{row + 1}:\d+: column depth_std_m: 'n/a' is not a finite"):
        ft.calibrate([bad], config, fit=NAMES)
    cells[5] = "-0.01"
    lines[row] = ",".join(cells)
    bad.write_text("\n".join(lines) + "\n")
    with pytest.raises(sf.SweepFileError, match="depth_std_m = -0.01 is out of range"):
        ft.calibrate([bad], config, fit=NAMES)
    cells[0] = ""
    lines[row] = ",".join(cells).replace(",-0.01,", ",0.01,")
    bad.write_text("\n".join(lines) + "\n")
    with pytest.raises(ft.CalibrationInputError, match=rf"cell.csv:{row + 1}: column distance_m \(field 1\) is empty"):
        ft.calibrate([bad], config, fit=NAMES)
    header_only = tmp_path / "empty.csv"
    header_only.write_text("\n".join(lines[:row]) + "\n")
    with pytest.raises(sf.SweepFileError, match="no data rows"):
        ft.calibrate([header_only], config, fit=NAMES)
    missing = _edit(tmp_path, FILES[0], ("amplitude_std_lsb,valid_fraction", "amplitude_sd,valid_fraction"))
    with pytest.raises(sf.SweepFileError, match="missing required column"):
        ft.calibrate([missing], config, fit=NAMES)


def test_empty_cells_mean_not_measured(tmp_path, config):
    """A file with only depth noise is valid: its amplitude rows contribute no residual."""
    data = sf.read_sweep(FILES[1])
    cols = dict(data.columns)
    cols["amplitude_mean_lsb"] = np.full(data.n_rows, np.nan)
    cols["amplitude_std_lsb"] = np.full(data.n_rows, np.nan)
    meta = {k: v for k, v in data.metadata.items() if k != "format"}
    sf.write_sweep(tmp_path / "noise_only.csv", meta, cols)
    rows = ft.load_rows(tmp_path / "noise_only.csv", config)
    assert len(rows.used("amplitude_mean_lsb")) == 0 and len(rows.used("depth_std_m")) > 20


def test_rows_left_out_are_counted(config):
    rows = ft.load_rows(FILES[0], config)
    assert rows.excluded["low_snr"] > 0  # far rows of the distance sweep
    assert len(rows.used("depth_std_m")) + rows.excluded["low_snr"] + rows.excluded["saturated"] == rows.n_rows
    strict = ft.load_rows(FILES[0], config, min_snr=50.0)
    assert len(strict.used("depth_std_m")) < len(rows.used("depth_std_m"))


def test_analytic_files_need_a_relative_error(tmp_path, config):
    out = tmp_path / "analytic.csv"
    assert main(["simulate", "--sweep", "distance", "--method", "analytic", "--samples", "5", "--out", str(out)]) == 0
    with pytest.raises(ft.CalibrationInputError, match="n_frames = 0: uncertainties need at least 2 frames"):
        ft.load_rows(out, config)
    rows = ft.load_rows(out, config, relative_error=0.02)
    assert len(rows.used("depth_std_m")) + rows.excluded["low_snr"] == 5 and len(rows.used("depth_std_m")) >= 3


def test_responsivity_and_lens_loss_degeneracy_is_reported(config):
    cal = ft.calibrate(FILES, config, fit=["pixel.photo_responsivity_a_per_w", "camera.k_lens"])
    notes = " ".join(cal.least_squares.degeneracies)
    assert "pixel.photo_responsivity_a_per_w and camera.k_lens cannot be separated" in notes
    assert "product" in notes
    assert np.all(np.isinf(cal.least_squares.sigma))
    product = cal.least_squares.estimate[0] * cal.least_squares.estimate[1]
    # The amplitude fixes contrast x responsivity x k_lens; contrast stays at the configured 0.42.
    assert product == pytest.approx(0.38 * 0.25 * 0.9 / 0.42, rel=0.05)


def test_posterior_agrees_with_least_squares(example_fit):
    with pytest.warns(ft.ShortChainWarning):
        cal = example_fit.with_posterior(walkers=16, steps=200, seed=3)
    post = cal.posterior
    assert cal.least_squares is example_fit.least_squares and example_fit.posterior is None  # no refit, a copy
    ratio = post.std / example_fit.least_squares.sigma
    assert np.all((ratio > 0.7) & (ratio < 1.3)), ratio
    # medians need not equal the least-squares point (skew, sigma(theta) normalisation) but stay close
    assert np.all(np.abs(post.median - example_fit.least_squares.estimate) < example_fit.least_squares.sigma)
    assert 0.2 < post.acceptance_fraction < 0.8
    with pytest.raises(ValueError, match="walkers = 5 is out of range: allowed an even number >= 6"):
        ft.sample_posterior(example_fit.problem, example_fit.least_squares, walkers=5, steps=10)


def test_the_posterior_computes_what_depends_on_the_problem_once(example_fit):
    """sample_posterior's log-posterior (fitting._hoist): the camera's tables (the correlation's FFTs)
    run once, in the problem's own program, not in the per-call one, and its values are the whole
    program's, to the bit."""
    from fitting._hoist import hoisted
    from fitting._problem import batched_log_posterior

    problem, ls = example_fit.problem, example_fit.least_squares
    u = np.asarray(ls.unconstrained) + 0.05 * np.random.default_rng(0).standard_normal((8, problem.n_params))
    call = hoisted(batched_log_posterior, problem, np.zeros_like(u))
    np.testing.assert_array_equal(np.asarray(call(u)), np.asarray(batched_log_posterior(problem, u)))

    def primitives(jaxpr):  # every primitive, inner programs' (jit, scan, ...) too
        for eqn in jaxpr.eqns:
            yield eqn.primitive.name
            for value in eqn.params.values():
                inner = getattr(value, "jaxpr", value)
                if hasattr(inner, "eqns"):
                    yield from primitives(inner)

    assert "fft" in set(primitives(call.once.jaxpr)) and "fft" not in set(primitives(call.per_call.jaxpr))
    with pytest.raises(ValueError, match="structure"):
        call((u, u))


def test_a_gaussian_prior_pulls_the_posterior(config, example_fit):
    """A prior 10 x narrower than the data's sigma, centred 3 sigma away, dominates that parameter."""
    ls = example_fit.least_squares
    mu, sigma = ls.estimate[2] + 3 * ls.sigma[2], ls.sigma[2] / 10
    parameters = ft.make_parameters(NAMES, dict(zip(NAMES, ls.estimate, strict=True)),
                                    priors={NAMES[2]: (mu, sigma)})
    problem = ft.build_problem(parameters, example_fit.rows)
    with pytest.warns(ft.ShortChainWarning):
        post = ft.sample_posterior(problem, ls, walkers=16, steps=150, seed=4, progress=False)
    assert abs(post.median[2] - mu) < 3 * sigma
    assert post.std[2] < 0.3 * ls.sigma[2]


def test_posterior_backend_resumes(example_fit, tmp_path):
    path = tmp_path / "chain.h5"
    with pytest.warns(ft.ShortChainWarning):
        first = ft.sample_posterior(example_fit.problem, example_fit.least_squares, walkers=8, steps=30,
                                    backend_path=path, progress=False)
        more = ft.sample_posterior(example_fit.problem, example_fit.least_squares, walkers=8, steps=20,
                                   backend_path=path, resume=True, progress=False)
    assert (first.steps, more.steps) == (30, 50)


def test_work_meanwhile_runs_once_and_its_errors_change_nothing(example_fit):
    """``meanwhile`` (work the caller needs after the fit, done while the first linearisation is
    prepared on its own thread) runs exactly once, and an exception in it is dropped: the fit is the
    fixture's to the last bit (the same problem from the same start)."""
    calls = []

    def work():
        calls.append(1)
        raise RuntimeError("dropped: the caller repeats this work after the fit")

    ls = ft.fit_least_squares(example_fit.problem, example_fit.rows, max_steps=1000, throw=False, meanwhile=work)
    assert calls == [1]
    np.testing.assert_array_equal(ls.estimate, example_fit.least_squares.estimate)
    assert ls.steps == example_fit.least_squares.steps


def test_unconverged_fit_is_never_silent(config):
    cal = ft.calibrate(FILES, config, fit=NAMES, max_steps=2)  # returned for its diagnostics
    assert not cal.least_squares.converged and cal.least_squares.steps == 2
    with pytest.raises(ft.ConvergenceError, match="did not converge after 2 steps"):
        ft.fit_least_squares(cal.problem, cal.rows, max_steps=2)
    with pytest.raises(ft.ConvergenceError, match="no posterior to sample"):
        cal.with_posterior(walkers=8, steps=10)


@pytest.mark.parametrize(
    "args, pattern",
    [
        (["--fit", "pixel.nope"], "unknown parameter 'pixel.nope'"),
        (["--fit", "pixel.demodulation_contrast", "--bounds", "pixel.demodulation_contrast=0.9"],
         "argument --bounds: 'pixel.demodulation_contrast=0.9' is not NAME=A:B"),
    ],
)
def test_calibrate_command_errors(tmp_path, capsys, args, pattern):
    try:
        code = main(["calibrate", str(FILES[0]), "--out", str(tmp_path / "x"), *args])
    except SystemExit as exc:
        code = exc.code
    assert code == 2
    err = capsys.readouterr().err
    assert "tofjax: error:" in err and "Traceback" not in err and pattern in err


def test_example_generator_reproduces_the_shipped_files(tmp_path, monkeypatch):
    """The example data set is what make_examples.py makes (reproducible, seed 2026): the same
    draws, equal to 1e-12 relative (compilers and CPUs may round the last bit differently)."""
    import fitting.examples.make_examples as mk

    for name in ("camera.toml",):
        shutil.copy(EXAMPLES / name, tmp_path / name)
    monkeypatch.setattr(mk, "HERE", tmp_path)
    mk.main()
    for path in FILES:
        new = sf.read_sweep(tmp_path / path.name)
        old = sf.read_sweep(path)
        for column, values in old.columns.items():
            np.testing.assert_allclose(new.columns[column], values, rtol=1e-12, atol=0.0)


def test_a_parameter_where_it_started_is_not_at_its_bound():
    """A capacitance of 4e-17 F the fit left where it started is not 'at its lower bound 0' of its range
    (0, 1e-12] (issue 49 item 7: a parameter the data cannot see stood at 5 and was called at 0); pushed
    from there towards 0, it is."""
    from fitting._least_squares import at_edge

    assert not at_edge(4e-17, 0.0, 4e-17, 1e-12)
    assert not at_edge(5.0, 0.0, 5.0, 100.0)
    assert at_edge(1e-25, 0.0, 4e-17, 1e-12) and at_edge(1e-4, 0.0, 5.0, 100.0)
