"""Every bad input gets one clear line and exit status 2: the named regressions of the cases that
once ended in a traceback, a silent accept or an unclear message, a hypothesis fuzz over command
arguments, configuration files, sweep files and campaign files, and the recording crash test
(SIGKILL, resume: no row lost or duplicated; a mismatched resume refused).

Fuzzed runs use ``--check`` (validate everything, compute nothing), so they cost milliseconds."""

import io
import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import tofjax as tj
from tofjax import sweepfile as sf
from tofjax.cli import main

EXAMPLES = Path(__file__).resolve().parents[1] / "fitting" / "examples"
DISTANCE_CSV = EXAMPLES / "distance.csv"
CAMERA = EXAMPLES / "camera.toml"
FUZZ = settings(max_examples=60, deadline=None, derandomize=True,
                suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])


def _run(args, capsys):
    """(exit status, stderr) of ``tofjax ARGS`` in this process; any exception escaping is a defect."""
    try:
        code = main([str(a) for a in args])
    except SystemExit as exc:  # argparse's own errors
        code = exc.code
    return code, capsys.readouterr().err


def _one_clear_line(err: str) -> str:
    """The error line: the last line, 'tofjax: error: ...', one line, no traceback."""
    assert "Traceback" not in err, err
    line = err.strip().splitlines()[-1]
    assert line.startswith("tofjax: error: "), err
    assert len(line) < 1200, f"{len(line)} characters"
    return line


RECORD = ["record", "--sweep", "distance", "--from", "1", "--to", "2", "--samples", "2", "--frames", "4", "--quiet"]


def _campaign(tmp_path, text: str) -> Path:
    path = tmp_path / "c.toml"
    path.write_text(text, encoding="utf-8")
    return path


# -- the cases, each a named regression ----------------------------------------------------
@pytest.mark.parametrize("extra, campaign, pattern", [
    (["--roi", "abc"], None, r"argument --roi: 'abc' is not two comma-separated numbers: allowed W,H"),
    ([], "[campaign]\nroi = \"a,b\"\n", r"c.toml: campaign.roi = 'a,b' is not an integer: allowed W,H"),
    ([], "campaign = 5\n", r"c.toml: campaign = 5 must be a table"),
    ([], "[campaign]\nout = 5\n", r"c.toml: campaign.out = 5 has the wrong type: allowed a non-empty text"),
    ([], "[campaign]\nconfig = 5\n", r"c.toml: campaign.config = 5 has the wrong type"),
    ([], "[campaign]\nsamples = 2.7\n", r"c.toml: campaign.samples = 2.7 is not an integer: allowed an integer 1 <="),
    ([], "[campaign]\ncamera = \"kinect\"\n", r"campaign.camera = 'kinect' is not allowed: allowed one of virtual, "),
    ([], "[campaign]\nlux = \"sun\"\n", r"campaign.lux = 'sun' is not allowed: allowed one of virtual, manual"),
    ([], "[campaign]\nstage = 7\n", r"campaign.stage = 7 has the wrong type: allowed virtual, fake or a URL ftdi://"),
    (["--stage", "bogus"], None, r"argument --stage: 'bogus' is not a stage"),
    (["--travel", "5,1"], None, r"argument --travel: '5,1' is reversed or empty"),
    (["--integration-time", "5"], None, r"argument --integration-time: '5' is out of range: allowed 0 < value <= 1"),
    (["--roi", "100000,100000"], None, r"argument --roi: '100000,100000' is out of range"),
    (["--frames", "100000", "--roi", "100,100"], None, r"1,000,000,000 pixel samples per point \(about 100 GB in "
                                                       r"memory\): allowed frames x W x H <= 4,194,304"),
    (["--to", "9"], None, r"stage positions 1 .. 9 m .* 1 of 2 are outside --travel 0,4.5 m; nothing moved"),
    ([], "frames = 4\n", r"unknown table or key 'frames'.*put it under \[campaign\]"),
    ([], "[campaign]\nframs = 4\n", r"unknown campaign key 'frams' \(did you mean \"frames\"\?\)"),
])
def test_record_refuses_bad_settings(tmp_path, capsys, extra, campaign, pattern):
    args = [*RECORD, *extra, "--out", tmp_path / "r.csv"]
    if campaign is not None:
        args += ["--campaign", _campaign(tmp_path, campaign)]
    code, err = _run(args, capsys)
    assert code == 2 and re.search(pattern, _one_clear_line(err)), err
    assert not (tmp_path / "r.csv").exists()


def test_record_without_stage_hardware_is_one_line(tmp_path, capsys):
    code, err = _run([*RECORD, "--stage", "ftdi://0x0403:0xfaf0/1", "--out", tmp_path / "r.csv"], capsys)
    assert code == 2 and "cannot open the stage at ftdi://0x0403:0xfaf0/1" in _one_clear_line(err)


def test_record_output_is_checked_first(tmp_path, capsys):
    code, err = _run([*RECORD, "--out", "/proc/r.csv"], capsys)
    assert code == 2 and "--out /proc/r.csv: cannot write there" in _one_clear_line(err)


def test_manual_lux_meter_without_an_operator(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr("sys.stdin", io.StringIO(""))  # standard input closed: input() meets its end
    code, err = _run([*RECORD, "--lux", "manual", "--out", tmp_path / "r.csv"], capsys)
    assert code == 2 and "--lux manual needs an operator" in _one_clear_line(err)


def test_campaign_file_with_a_byte_order_mark_is_read(tmp_path, capsys):
    path = tmp_path / "bom.toml"
    path.write_bytes("\ufeff[campaign]\nframes = 4\n".encode())
    code, err = _run([*RECORD, "--campaign", path, "--check", "--out", tmp_path / "r.csv"], capsys)
    assert code == 0, err


@pytest.mark.parametrize("args, pattern", [
    (["calibrate", "{tmp}", "--fit", "pixel.demodulation_contrast", "--out", "{tmp}/o"],
     r"is a directory, not a sweep file"),
    (["calibrate", DISTANCE_CSV, "--fit", "pixel.demodulation_contrast", "--mcmc", "--backend", "/proc/x.h5",
      "--out", "{tmp}/o"], r"--backend /proc/x.h5: cannot write there"),
    (["calibrate", DISTANCE_CSV, "--fit", "pixel.demodulation_contrast", "--resume", "--out", "{tmp}/o"],
     r"--resume continues the chain stored in --backend"),
    (["calibrate", DISTANCE_CSV, "--fit", "pixel.demod", "--out", "{tmp}/o"],
     r"unknown parameter 'pixel.demod' \(did you mean \"pixel.demodulation_contrast\"\?\)"),
    (["calibrate", DISTANCE_CSV, "--fit", "pixel.n_phases", "--out", "{tmp}/o"],
     r"pixel.n_phases is not fittable \(an integer"),
    (["calibrate", DISTANCE_CSV, "--fit", "pixel.sbi", "--out", "{tmp}/o"], r"pixel.sbi is not fittable \(true/false"),
    (["simulate", "--sweep", "distance", "--from", "-1", "--to", "1", "--samples", "1000", "--out", "{tmp}/x.csv"],
     r"^tofjax: error: --from = -1.0 is out of range for the distance sweep: allowed 0 < value <= 1000 \[m\]$"),
    (["simulate", "--sweep", "distance", "--samples", "3", "--out", "/proc/x.csv"], r"--out /proc/x.csv: cannot write"),
    (["simulate", "--sweep", "distance", "--samples", "3", "--report", "/proc/r"], r"--report /proc/r: cannot write"),
    (["simulate", "--sweep", "distance", "--samples", "3", "--method", "analytic", "--fixed-pattern", "--out",
      "{tmp}/x.csv"], r"^tofjax: error: --fixed-pattern needs the Monte Carlo \(--method 'mc'\)"),
])
def test_calibrate_and_simulate_refuse_before_any_work(tmp_path, capsys, args, pattern):
    code, err = _run([str(a).replace("{tmp}", str(tmp_path)) for a in args], capsys)
    assert code == 2 and re.search(pattern, _one_clear_line(err)), err


def test_a_fixed_pattern_is_refused_where_a_run_would_drop_it():
    """The analytic and the multi-frequency sweeps draw no pattern: asking for one is an error, not a
    file that says ``fixed_pattern: true`` of a run without it."""
    from tofjax._run import run_sweep

    config = tj.config_from_dict({"illumination_waveform": {"extra_modulation_frequencies_hz": [60.24e6]}})
    sweep = tj.Config().sweep("distance", 1.0, 2.0, 2)
    with pytest.raises(ValueError, match="needs one modulation frequency: the multi-frequency run draws no pattern"):
        run_sweep(config, sweep, "mc", 8, fixed_pattern=True)
    with pytest.raises(ValueError, match=r"needs the Monte Carlo \(method 'mc'\)"):
        run_sweep(tj.Config(), sweep, "analytic", fixed_pattern=True)


@pytest.mark.parametrize("text, pattern", [
    ("distance_m = 1\n", r"key distance_m = 1 is outside any section: write it under \[scene\]"),
    (b"\x89PNG\r\n\x1a\n\x00", r"line 1, column 1: not a text configuration file: byte 0x89 is not UTF-8"),
    ("[scene\n", r"line 1, column 7: malformed TOML"),
    ("[scene]\nsamples = ", r"line 2, column 11: malformed TOML"),
])
def test_configuration_files_are_named_with_line_and_column(tmp_path, capsys, text, pattern):
    path = tmp_path / "cam.toml"
    path.write_bytes(text if isinstance(text, bytes) else text.encode())
    code, err = _run(["simulate", "--config", path, "--sweep", "distance", "--check", "--out", tmp_path / "x.csv"],
                     capsys)
    assert code == 2 and re.search(pattern, _one_clear_line(err)), err


def test_configuration_with_a_byte_order_mark_is_read(tmp_path, capsys):
    path = tmp_path / "cam.toml"
    path.write_bytes("\ufeff[scene]\nsamples = 3\n".encode())
    assert _run(["simulate", "--config", path, "--sweep", "distance", "--check", "--out", tmp_path / "x.csv"],
                capsys)[0] == 0


def test_config_out_makes_its_directory_as_simulate_does(tmp_path, capsys):
    out = tmp_path / "new" / "dir" / "x.toml"
    assert _run(["config", "--out", out], capsys)[0] == 0 and out.read_text().startswith("# tofjax")


def _sweep_text(**replace) -> str:
    text = DISTANCE_CSV.read_text(encoding="utf-8")
    for old, new in replace.items():
        text = text.replace(old, new)
    return text


def _calibrate_check(tmp_path, capsys, text: str | bytes):
    path = tmp_path / "s.csv"
    path.write_bytes(text if isinstance(text, bytes) else text.encode())
    return _run(["calibrate", path, "--config", CAMERA, "--fit", "pixel.demodulation_contrast", "--check", "--out",
                 tmp_path / "o"], capsys)


def _rows(text: str) -> tuple[list[str], int]:
    lines = text.splitlines()
    header = next(i for i, line in enumerate(lines) if not line.startswith("#"))
    return lines, header


def test_sweep_files_bom_header_zero_noise_and_negative_amplitude(tmp_path, capsys):
    text = DISTANCE_CSV.read_text(encoding="utf-8")
    assert _calibrate_check(tmp_path, capsys, "\ufeff" + text)[0] == 0  # a byte-order mark is fine
    lines, header = _rows(text)
    no_header = "\n".join(lines[:header] + lines[header + 1:]) + "\n"
    code, err = _calibrate_check(tmp_path, capsys, no_header)
    assert code == 2 and re.search(rf"s.csv:{header + 1}:1: missing header row", _one_clear_line(err)), err
    names = lines[header].split(",")
    row = lines[header + 1].split(",")
    for column, value, pattern in (("depth_std_m", "0", r"column depth_std_m \(field \d+\) = 0 over \d+ frames"),
                                   ("amplitude_mean_lsb", "-3", r":\d+: column amplitude_mean_lsb = -3.0 is out of "
                                                                r"range: allowed value >= 0"),
                                   ("distance_m", "2000", r"column distance_m = 2000.0 is out of range: allowed "
                                                          r"0 < value <= 1000 \[m\], as scene.distance_m")):
        bad = list(row)
        bad[names.index(column)] = value
        edited = "\n".join(lines[:header + 1] + [",".join(bad)] + lines[header + 2:]) + "\n"
        code, err = _calibrate_check(tmp_path, capsys, edited)
        assert code == 2 and re.search(rf"s.csv:{header + 2}", err) and re.search(pattern, _one_clear_line(err)), err


def test_summary_table_pads_missing_cells_and_explains_a_coarse_unwrap(tmp_path, capsys):
    assert main(["simulate", "--sweep", "distance", "--from", "0.1", "--to", "8", "--samples", "3", "--method",
                 "analytic", "--out", str(tmp_path / "x.csv")]) == 0
    text = capsys.readouterr().out
    assert "note: 'unwrapped' is the depth unwrapped along the sweep" in text
    lines = text.splitlines()
    assert any(" - " in line for line in lines[2:5])  # the 0.1 m point saturates: '-' cells
    for line in lines[2:5]:
        assert len(line) == len(lines[0]), line  # '-' cells padded to the column width


# -- the fuzz --------------------------------------------------------------------------------------
_TOKENS = st.one_of(st.sampled_from(["-1", "0", "1", "2.5", "1e9", "nan", "inf", "abc", "", "3,3", "0,4.5", "5,1",
                                     "1,2,3", "virtual", "fake", "royale", "manual", "distance", "ftdi://x",
                                     "/proc/x", "1e-3", "-0", "１"]),
                    st.text(max_size=8), st.floats(allow_nan=True).map(repr), st.integers(-10**12, 10**12).map(str))
_RECORD_FLAGS = ["--sweep", "--from", "--to", "--samples", "--frames", "--roi", "--stage", "--counts-per-mm",
                 "--travel", "--distance-offset", "--camera", "--lux", "--lux-value", "--distance",
                 "--integration-time", "--settle", "--seed", "--use-case"]
_SIM_FLAGS = ["--sweep", "--from", "--to", "--samples", "--iterations", "--method", "--seed"]
_CAL_FLAGS = ["--fit", "--bounds", "--prior", "--relative-error", "--min-snr", "--max-steps", "--walkers", "--steps",
              "--seed"]


def _assert_answer(code, err, names):
    """Exit 0, or 2 with one line naming an option, a key or a file."""
    assert code in (0, 2), (code, err)
    if code == 2:
        line = _one_clear_line(err)
        assert any(n in line for n in names) or re.search(r"argument --|--[a-z-]+|[a-z_]+\.[a-z_]+ =|"
                                                          r"\.(toml|csv)", line), line


@FUZZ
@given(st.lists(st.tuples(st.sampled_from(_RECORD_FLAGS), _TOKENS), max_size=5))
def test_fuzz_record_arguments(tmp_path, capsys, pairs):
    args = ["record", "--sweep", "distance", "--from", "1", "--to", "2", "--samples", "3"]
    for flag, value in pairs:
        args += [flag, value]
    code, err = _run([*args, "--check", "--out", tmp_path / "r.csv"], capsys)
    _assert_answer(code, err, [flag for flag, _ in pairs])


@FUZZ
@given(st.lists(st.tuples(st.sampled_from(_SIM_FLAGS), _TOKENS), max_size=4))
def test_fuzz_simulate_arguments(tmp_path, capsys, pairs):
    args = ["simulate", "--sweep", "distance"]
    for flag, value in pairs:
        args += [flag, value]
    code, err = _run([*args, "--check", "--out", tmp_path / "x.csv"], capsys)
    _assert_answer(code, err, [flag for flag, _ in pairs])


@FUZZ
@given(st.lists(st.tuples(st.sampled_from(_CAL_FLAGS),
                          st.one_of(_TOKENS, st.sampled_from(["pixel.demodulation_contrast", "pixel.demod",
                                                              "pixel.n_phases", "pixel.demodulation_contrast=0.1:0.9",
                                                              "pixel.demodulation_contrast=0.9:0.1", "scene.distance_m",
                                                              "x=1:2"]))), max_size=4))
def test_fuzz_calibrate_arguments(tmp_path, capsys, pairs):
    args = ["calibrate", DISTANCE_CSV, "--config", CAMERA, "--fit", "pixel.demodulation_contrast"]
    for flag, value in pairs:
        args += [flag, value]
    code, err = _run([*args, "--check", "--out", tmp_path / "o"], capsys)
    _assert_answer(code, err, [flag for flag, _ in pairs])


_TOML_VALUES = st.one_of(st.integers(-10**6, 10**6).map(str), st.floats().map(repr),
                         st.sampled_from(["true", "\"sine\"", "\"x\"", "[1, 2]", "[]", "{}", "1e400", "nan", "-inf",
                                          "[1.0, \"a\"]", "\"\"", "0x10"]), st.text(max_size=6))
_CONFIG_LINES = None


def _default_config_lines() -> list[str]:
    global _CONFIG_LINES
    if _CONFIG_LINES is None:
        from tofjax.schema import default_config_text

        _CONFIG_LINES = default_config_text().splitlines()
    return _CONFIG_LINES


@FUZZ
@given(st.lists(st.tuples(st.integers(0, 10**6), _TOML_VALUES, st.booleans()), min_size=1, max_size=3),
       st.binary(max_size=6))
def test_fuzz_configuration_files(tmp_path, capsys, edits, noise):
    lines = list(_default_config_lines())
    for where, value, replace_value in edits:
        i = where % len(lines)
        if replace_value and " = " in lines[i]:
            lines[i] = lines[i].split(" = ")[0] + " = " + value
        else:
            lines.insert(i, value)
    path = tmp_path / "cam.toml"
    path.write_bytes("\n".join(lines).encode() + noise)
    code, err = _run(["simulate", "--config", path, "--sweep", "distance", "--check", "--out", tmp_path / "x.csv"],
                     capsys)
    _assert_answer(code, err, [str(path)])


@FUZZ
@given(st.lists(st.tuples(st.integers(0, 10**6), st.integers(0, 40), _TOKENS), min_size=1, max_size=3),
       st.sampled_from(["", "\ufeff", "drop-header", "drop-line", "bytes"]))
def test_fuzz_sweep_files(tmp_path, capsys, edits, damage):
    lines = DISTANCE_CSV.read_text(encoding="utf-8").splitlines()
    for row, column, value in edits:
        i = row % len(lines)
        cells = lines[i].split(",")
        cells[column % len(cells)] = value
        lines[i] = ",".join(cells)
    if damage == "drop-header":
        lines = [line for line in lines if not line.startswith("distance_m")]
    elif damage == "drop-line":
        del lines[edits[0][0] % len(lines)]
    data = ("\ufeff" if damage == "\ufeff" else "").encode() + "\n".join(lines).encode()
    if damage == "bytes":
        data = data[:200] + b"\xff\xfe\x00" + data[200:]
    code, err = _calibrate_check(tmp_path, capsys, data)
    _assert_answer(code, err, ["s.csv"])


_CAMPAIGN_KEYS = ["sweep", "start", "stop", "samples", "frames", "roi", "stage", "counts_per_mm", "travel",
                  "distance_offset", "camera", "use_case", "lux", "lux_value", "distance", "integration_time",
                  "settle", "seed", "raw_dir", "resume", "out", "config", "bogus", "campaign"]


@FUZZ
@given(st.lists(st.tuples(st.sampled_from(_CAMPAIGN_KEYS), _TOML_VALUES), max_size=4), st.booleans())
def test_fuzz_campaign_files(tmp_path, capsys, pairs, with_table):
    body = "\n".join(f"{key} = {value}" for key, value in pairs)
    path = _campaign(tmp_path, ("[campaign]\n" if with_table else "") + body + "\n")
    code, err = _run(["record", "--campaign", path, "--sweep", "distance", "--from", "1", "--to", "2", "--samples",
                      "2", "--check", "--out", tmp_path / "r.csv"], capsys)
    _assert_answer(code, err, ["c.toml"])


# -- recording under SIGKILL ------------------------------------------------------------------------
def _record_process(out: Path, cache: Path, *extra) -> subprocess.Popen:
    env = {**os.environ, "TOFJAX_CACHE_DIR": str(cache), "JAX_PLATFORMS": "cpu"}
    return subprocess.Popen([sys.executable, "-m", "tofjax.cli", "record", "--sweep", "distance", "--from", "0.6",
                             "--to", "2.4", "--samples", "8", "--frames", "40", "--roi", "2,2", "--settle", "0.15",
                             "--quiet", "--out", str(out), *extra], env=env, stdout=subprocess.DEVNULL,
                            stderr=subprocess.PIPE, text=True)


def _rows_in(path: Path) -> int:
    try:
        return sf.read_sweep(path, allow_empty=True).n_rows
    except (sf.SweepFileError, OSError):
        return 0


def test_sigkill_at_random_points_then_resume_loses_and_repeats_nothing(tmp_path, capsys):
    out, cache = tmp_path / "lts.csv", tmp_path / "cache"
    rng = np.random.default_rng(12)
    for kill_after in sorted(rng.choice(np.arange(1, 7), size=2, replace=False)):
        proc = _record_process(out, cache, *(["--resume"] if out.exists() else []))
        deadline = time.monotonic() + 120
        while _rows_in(out) < kill_after and proc.poll() is None and time.monotonic() < deadline:
            time.sleep(0.02)
        time.sleep(rng.uniform(0, 0.15))  # anywhere within the next point
        proc.send_signal(signal.SIGKILL)
        proc.communicate()
        assert _rows_in(out) >= kill_after  # the file stays valid, with every completed row
    proc = _record_process(out, cache, "--resume")
    _, err = proc.communicate(timeout=300)
    assert proc.returncode == 0, err
    done = sf.read_sweep(out).columns["requested_value"]
    np.testing.assert_allclose(np.sort(done), np.linspace(0.6, 2.4, 8))  # none lost, none twice
    # A resume with another grid is refused, naming what differs; the file is untouched.
    before = out.read_bytes()
    code, err = _run(["record", "--sweep", "distance", "--from", "0.6", "--to", "2.4", "--samples", "4", "--frames",
                      "20", "--roi", "2,2", "--resume", "--quiet", "--out", out], capsys)
    line = _one_clear_line(err)
    assert code == 2 and "cannot resume with different settings" in line
    assert "grid_samples = 8 in the file, 4 now" in line and "frames = 40 in the file, 20 now" in line
    assert out.read_bytes() == before
