"""Published specifications as checks (issue 34 item 5): the tofjax-sweep/4 bound columns, their
version rules and provenance, and met / not met with the margin (closed cases, no model here; the
model end to end is in test_compare)."""

import numpy as np
import pytest

import fitting
from fitting import check_bounds
from tofjax import sweepfile as sf

HEAD = """# format: tofjax-sweep/4
# sweep: distance
# source: specification
# modulation_frequency_hz: 100000000.0
# n_phases: 4
# created_utc: 2026-11-26T00:00:00+00:00
# bound.depth_std_m_lt: 'temporal noise < 1 mm', a datasheet
# bound.depth_error_m_le: 'accuracy +-5 mm', the same datasheet
distance_m,integration_time_s,illuminance_lx,n_frames,depth_std_m_lt,depth_error_m_le
"""
ROWS = "0.5,0.001,0,,0.001,\n1.0,0.001,0,,0.001,0.005\n"


def test_bound_columns_are_read_with_their_statements():
    data = sf.parse_sweep(HEAD + ROWS, "spec.csv")
    assert data.bounds == ["depth_std_m_lt", "depth_error_m_le"] and data.version == 4
    assert sf.bound_column("depth_std_m_lt") == ("depth_std_m", "lt")
    assert sf.bound_column("amplitude_mean_lsb_ge") == ("amplitude_mean_lsb", "ge")
    assert sf.bound_column("depth_std_m") is None and sf.bound_column("depth_std_m_max") is None
    np.testing.assert_array_equal(data.columns["depth_error_m_le"], [np.nan, 0.005])  # empty: no bound there
    assert data.metadata["bound.depth_std_m_lt"] == "'temporal noise < 1 mm', a datasheet"


@pytest.mark.parametrize("edit, message", [
    (lambda t: t.replace("tofjax-sweep/4", "tofjax-sweep/3", 1), r"spec\.csv:3: source = 'specification' needs format "
                                                                 r"tofjax-sweep/4"),
    (lambda t: t.replace("tofjax-sweep/4", "tofjax-sweep/3", 1).replace("specification", "measurement"),
     r"spec\.csv:9:55: column depth_std_m_lt needs format tofjax-sweep/4"),
    (lambda t: t.replace("# bound.depth_error_m_le: 'accuracy +-5 mm', the same datasheet\n", ""),
     r"spec\.csv:8:70: bound column depth_error_m_le needs its source: a metadata line \"# bound.depth_error_m_le: "),
    (lambda t: t.replace("1.0,0.001,0,,0.001,0.005", "1.0,0.001,0,,-0.001,0.005"),
     r"spec\.csv:11:14: column depth_std_m_lt = -0.001 is out of range: allowed value >= 0"),
    # Issue 49 item 16: each was read with exit status 0 and the bound it states checked nowhere.
    (lambda t: t.replace(",depth_error_m_le\n", "\n").replace(",\n", "\n").replace(",0.005\n", "\n"),
     r"spec\.csv:8:3: metadata bound\.depth_error_m_le states a bound, but the header \(line 9\) has no column "
     r"depth_error_m_le"),
    (lambda t: t.replace("depth_error_m_le", "depth_error_m_lte"),
     r"spec\.csv:9:70: column depth_error_m_lte has a bound statement \(line 8\) but is not a bound: a bound column is "
     r"named <quantity>_<relation> .* \(did you mean \"depth_error_m_le\"\?\)"),
    (lambda t: t.replace("depth_error_m_le", "depth_error_m_lte").replace("specification", "measurement"),
     r"spec\.csv:9:70: column depth_error_m_lte has a bound statement \(line 8\) but is not a bound"),
    (lambda t: t.replace("depth_std_m_lt", "depth_noise_m_lt"),
     r"spec\.csv:9:55: column depth_noise_m_lt has a bound statement \(line 7\) but is not a bound: .* \(did you "
     r"mean \"depth_std_m_lt\"\?\)"),
    (lambda t: t.replace("depth_error_m_le", "depth_err_m_le").replace("# bound.depth_err_m_le: 'accuracy +-5 mm', "
                                                                       "the same datasheet\n", ""),
     r"spec\.csv:8:70: column depth_err_m_le is neither a bound nor a column of a specification"),
    (lambda t: t.replace(",0.001,", ",,"),
     r"spec\.csv:9:55: bound column depth_std_m_lt has no value in any row"),
])
def test_bad_bound_files_are_refused_with_file_line_and_column(edit, message):
    with pytest.raises(sf.SweepFileError, match=message):
        sf.parse_sweep(edit(HEAD + ROWS), "spec.csv")


def test_writers_write_version_4_only_for_bounds(tmp_path):
    cols = {"distance_m": [1.0], "integration_time_s": [1e-3], "illuminance_lx": [0.0], "n_frames": [np.nan]}
    meta = {"sweep": "distance", "source": "specification", "modulation_frequency_hz": 1e8, "n_phases": 4,
            "bound.depth_std_m_le": "a datasheet"}
    path = sf.write_sweep(tmp_path / "spec.csv", meta, {**cols, "depth_std_m_le": [1e-3]})
    assert path.read_text().startswith("# format: tofjax-sweep/4\n") and sf.read_sweep(path).bounds == ["depth_std_m_le"]
    assert sf.needed_format({"sweep": "temperature"}, ["temperature_c"]) == sf.FORMAT_V3
    assert sf.needed_format({"sweep": "distance"}, sf.REQUIRED_COLUMNS) == sf.FORMAT_V1


def _data(columns, statements=None):
    n = len(next(iter(columns.values())))
    fields = {name: i + 1 for i, name in enumerate(columns)}
    meta = {f"bound.{c}": (statements or {}).get(c, "stated") for c in columns}
    return sf.SweepData(meta, {k: np.asarray(v, dtype=float) for k, v in columns.items()}, "spec.csv",
                        np.arange(n) + 10, fields)


def test_met_and_margin_follow_the_relation_at_the_boundary():
    """At equality <= and >= are met, < and > are not; a row without a model value (saturated) meets
    no bound; the margin is positive on the met side; the worst row is the smallest margin."""
    model = {"depth_std_m": np.array([1e-3, 2e-3, np.nan, 0.5e-3]), "amplitude_mean_lsb": np.array([100.0, 50, 10, 200]),
             "depth_mean_m": np.array([1.004, 2.0, 3.0, 3.99])}
    truth = np.array([1.0, 2.0, 3.0, 4.0])
    bound = [2e-3, 2e-3, 2e-3, np.nan]
    checks = {b.column: b for b in check_bounds(_data({"depth_std_m_le": bound, "depth_std_m_lt": bound,
                                                       "amplitude_mean_lsb_ge": [50, 50, 50, 50],
                                                       "amplitude_mean_lsb_gt": [50, 50, 50, 50],
                                                       "depth_error_m_lt": [5e-3, 5e-3, 5e-3, 5e-3]}), model, truth,
                                                model["depth_mean_m"], np.zeros(4, bool))}
    np.testing.assert_array_equal(checks["depth_std_m_le"].met, [True, True, False, False])
    np.testing.assert_array_equal(checks["depth_std_m_lt"].met, [True, False, False, False])
    np.testing.assert_allclose(checks["depth_std_m_le"].margin[:2], [1e-3, 0.0], atol=1e-15)
    np.testing.assert_array_equal(checks["amplitude_mean_lsb_ge"].met, [True, True, False, True])
    np.testing.assert_array_equal(checks["amplitude_mean_lsb_gt"].met, [True, False, False, True])
    np.testing.assert_allclose(checks["amplitude_mean_lsb_ge"].margin, [50, 0, -40, 150])
    np.testing.assert_allclose(checks["depth_error_m_lt"].model, [4e-3, 0, 0, 10e-3], atol=1e-12)  # |mean - truth|
    np.testing.assert_array_equal(checks["depth_error_m_lt"].met, [True, True, True, False])
    s = checks["depth_std_m_le"].summary()
    assert (s["rows"], s["met"], s["worst"]) == (3, 2, 2) and np.isnan(s["margin"])  # no value is worst
    s = checks["depth_error_m_lt"].summary()
    assert (s["rows"], s["met"], s["worst"]) == (4, 3, 3)
    assert s["margin"] == pytest.approx(-5e-3) and s["model_over_bound"] == pytest.approx(2.0)


def test_depth_bounds_are_judged_on_the_cameras_reading():
    """A camera of one frequency (1.87 m range) reads 2.5 m as 0.63 m: no accuracy bound is met there,
    however close the distance continued to the nearest period; a row whose phase is a guess (the
    low-SNR caveat) meets no depth bound, but its amplitude bound stands."""
    model = {"depth_std_m": np.array([1e-3, 1e-3, 1e-3]), "amplitude_mean_lsb": np.array([100.0, 100.0, 100.0]),
             "depth_mean_m": np.array([1.0, 2.5, 3.0])}  # as if continued to the nearest period
    truth = np.array([1.0, 2.5, 3.0])
    reading = np.array([1.0, 2.5 - 1.8662, 3.0])
    guess = np.array([False, False, True])
    checks = {b.column: b for b in check_bounds(_data({"depth_std_m_le": [2e-3] * 3, "depth_error_m_lt": [5e-3] * 3,
                                                       "amplitude_mean_lsb_ge": [50] * 3}), model, truth, reading,
                                                guess)}
    np.testing.assert_array_equal(checks["depth_error_m_lt"].met, [True, False, False])
    assert checks["depth_error_m_lt"].model[1] == pytest.approx(1.8662)
    np.testing.assert_array_equal(checks["depth_std_m_le"].met, [True, True, False])
    np.testing.assert_array_equal(checks["amplitude_mean_lsb_ge"].met, [True, True, True])


def _spec_file(tmp_path, text=HEAD + ROWS):
    path = tmp_path / "spec.csv"
    path.write_text(text.replace("100000000.0", "80320000.0"), encoding="utf-8")  # the default camera's frequency
    return path


def test_calibration_takes_a_file_of_bounds_only(tmp_path):
    """Issue 50 item 4: a specification is calibration input (it was refused: 'holds bounds only'). Its
    rows need no n_frames and no relative error; its bounds are kept per column with their statements."""
    import tofjax as tj

    rows = fitting.load_rows(_spec_file(tmp_path), tj.Config())
    assert [(b.column, b.quantity, b.upper) for b in rows.bounds] == [("depth_std_m_lt", "depth_std_m", True),
                                                                      ("depth_error_m_le", "depth_error_m", True)]
    np.testing.assert_array_equal(rows.bounds[1].values, [np.nan, 0.005])
    assert rows.bounds[0].statement == "'temporal noise < 1 mm', a datasheet"
    assert rows.bounded.tolist() == [True, True] and sum(len(rows.used(n)) for n in rows.data) == 0


def test_a_bound_the_calibration_cannot_judge_is_refused_in_one_line(tmp_path, capsys):
    """A depth-noise bound on a camera without noise (the model predicts none), and an upper bound of 0,
    are refused naming the file and column, before any computation; the command prints one line."""
    import tofjax as tj
    from tofjax.cli import main

    path = _spec_file(tmp_path)
    quiet = tj.Config().replace("pixel.noise", False)
    with pytest.raises(fitting.CalibrationInputError, match=r"spec\.csv: column depth_std_m_lt \(field 5\) bounds the "
                                                            r"depth noise, but the configuration has pixel\.noise = "
                                                            r"false: the model predicts no noise"):
        fitting.load_rows(path, quiet)
    config = tmp_path / "quiet.toml"
    config.write_text("[pixel]\nnoise = false\n")
    assert main(["calibrate", str(path), "--config", str(config), "--fit", "illumination.peak_power_w",
                 "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("tofjax: error: ") and err.count("\n") == 1 and "Traceback" not in err
    zero = _spec_file(tmp_path, HEAD + ROWS.replace("1.0,0.001,0,,0.001,0.005", "1.0,0.001,0,,0.001,0"))
    with pytest.raises(fitting.CalibrationInputError, match=r"spec\.csv:11: column depth_error_m_le \(field 6\) = 0: an "
                                                            r"upper bound of 0 leaves no room"):
        fitting.load_rows(zero, tj.Config())
