"""The tofjax-sweep CSV format: round trips and clear errors with file, line and column."""

import math

import jax
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import tofjax as tj
from tofjax import sweepfile as sf

META = {"sweep": "distance", "source": "measurement", "modulation_frequency_hz": "80320000.0", "n_phases": "4",
        "created_utc": "2026-11-21T09:00:00+00:00"}
HEADER = ",".join(sf.REQUIRED_COLUMNS)
GOOD_ROW = "1.0,0.002,20.0,100,0.998,0.005,180.5,1.2,1.0"
NAN_ROW = "1.0,0.002,20,100,nan,0.005,180.5,1.2,1.0"
NEG_ROW = "1.0,0.002,20,100,0.99,-0.005,180.5,1.2,1.0"
VF_ROW = "1.0,0.002,20,100,0.99,0.005,180.5,1.2,1.5"
FRAMES_ROW = "1.0,0.002,20,10.5,0.99,0.005,180.5,1.2,1.0"
ABC_ROW = "1.0,0.002,abc,100,0.998,0.005,180.5,1.2,1.0"


def _text(meta=META, header=HEADER, rows=(GOOD_ROW,), first="# format: tofjax-sweep/1"):
    lines = [first] + [f"# {k}: {v}" for k, v in meta.items()] + [header, *rows]
    return "\n".join(lines) + "\n"


def test_round_trip_of_a_simulation(tmp_path):
    # 64 frames: the program of test_camera's sweeps of the default camera.
    result = tj.simulate(tj.Params(), tj.Sweep.linspace("distance", 0.2, 2.0, 7), jax.random.key(0), 64)
    cols = sf.columns_from_result(result)
    meta = {**META, "source": "simulation"}
    sf.write_sweep(tmp_path / "s.csv", meta, cols)
    data = sf.read_sweep(tmp_path / "s.csv")
    assert data.metadata["format"] == "tofjax-sweep/1" and data.sweep == "distance" and data.n_phases == 4
    assert list(data.columns) == list(cols)
    for name, values in cols.items():
        np.testing.assert_array_equal(np.isnan(data.columns[name]), np.isnan(values))
        np.testing.assert_array_equal(data.columns[name][~np.isnan(values)], values[~np.isnan(values)])
    assert np.isnan(data.columns["depth_std_m"][0])  # 0.2 m saturates: empty cell, not 0


@settings(max_examples=50, deadline=None)
@given(st.lists(st.floats(0.01, 1e3, allow_nan=False), min_size=1, max_size=20))
def test_float_values_round_trip_exactly(tmp_path_factory, values):
    path = tmp_path_factory.mktemp("h") / "x.csv"
    cols = {c: np.asarray(values) for c in sf.REQUIRED_COLUMNS}
    cols["n_frames"] = np.full(len(values), 10.0)
    cols["valid_fraction"] = np.full(len(values), 0.5)
    cols["integration_time_s"] = np.asarray(values) / 1e3  # within its range, 0 < value <= 1 s
    sf.write_sweep(path, META, cols)
    back = sf.read_sweep(path).columns
    for c in cols:
        np.testing.assert_array_equal(back[c], cols[c])


def test_empty_cell_means_not_measured():
    row = "1.0,0.002,20.0,100,0.998,,180.5,1.2,1.0"
    data = sf.parse_sweep(_text(rows=(row,)))
    assert math.isnan(data.columns["depth_std_m"][0]) and data.columns["amplitude_mean_lsb"][0] == 180.5


@pytest.mark.parametrize(
    "kwargs, line, column, pattern",
    [
        ({"first": "distance_m,depth"}, 1, 1, "not a tofjax sweep file"),
        ({"first": "# format: tofjax-sweep/5"}, 1, 1, "unsupported format version .tofjax-sweep/5."),
        ({"meta": {k: v for k, v in META.items() if k != "n_phases"}}, None, None, 'missing required metadata line "# n_phases'),
        ({"meta": {**META, "sweep": "depth"}}, 2, None, "sweep = 'depth' is not one of"),
        ({"meta": {**META, "modulation_frequency_hz": "-5"}}, 4, None, "is not a number > 0"),
        ({"header": HEADER.replace(",valid_fraction", "")}, 7, None, "missing required column.*valid_fraction"),
        ({"header": HEADER + ",depth_std_m"}, 7, len(HEADER) + 2, "column 'depth_std_m' appears twice"),
        ({"rows": (GOOD_ROW + ",7",)}, 8, len(GOOD_ROW) + 2, "row has 10 cells, the header has 9"),
        ({"rows": ("1.0,0.002,20",)}, 8, 13, "row has 3 cells, the header has 9"),
        ({"rows": (GOOD_ROW, ABC_ROW)}, 9, ABC_ROW.index("abc") + 1,
         "column illuminance_lx: 'abc' is not a finite number"),
        ({"rows": (NAN_ROW,)}, 8, NAN_ROW.index("nan") + 1, "column depth_mean_m: 'nan' is not a finite"),
        ({"rows": (NEG_ROW,)}, 8, NEG_ROW.index("-0.005") + 1, "depth_std_m = -0.005 is out of range"),
        ({"rows": (VF_ROW,)}, 8, VF_ROW.rindex("1.5") + 1, "valid_fraction = 1.5 is out of range"),
        ({"rows": (FRAMES_ROW,)}, 8, FRAMES_ROW.index("10.5") + 1, "n_frames = 10.5 is out of range"),
        ({"rows": ()}, 8, None, "no data rows"),
    ],
)
def test_malformed_files_name_line_and_column(tmp_path, kwargs, line, column, pattern):
    path = tmp_path / "bad.csv"
    path.write_text(_text(**kwargs))
    with pytest.raises(sf.SweepFileError, match=pattern) as info:
        sf.read_sweep(path)
    err = info.value
    assert err.path == str(path) and err.line == line and err.column == column
    assert str(err).startswith(str(path))


def test_writer_leaves_a_valid_file_after_every_row(tmp_path):
    path = tmp_path / "live.csv"
    with sf.SweepWriter(path, META, sf.REQUIRED_COLUMNS) as writer:
        for i in range(3):
            writer.write_row({c: 1.0 for c in sf.REQUIRED_COLUMNS} | {"n_frames": 5.0, "distance_m": 1.0 + i})
            data = sf.read_sweep(path)  # readable while still open: every row is flushed
            assert data.n_rows == i + 1
        with pytest.raises(ValueError, match="unknown column"):
            writer.write_row({"bogus": 1.0})


def test_writer_rejects_incomplete_metadata(tmp_path):
    with pytest.raises(ValueError, match="missing metadata"):
        sf.SweepWriter(tmp_path / "x.csv", {"sweep": "distance"}, sf.REQUIRED_COLUMNS)
    with pytest.raises(sf.SweepFileError, match="n_phases"):
        sf.SweepWriter(tmp_path / "x.csv", {**META, "n_phases": "9"}, sf.REQUIRED_COLUMNS)
