"""Outputs are never lost, overwritten by surprise or half-written (tofjax.outputs, README "Outputs"):
every command refuses an existing output unless told, a measurement is replaced only by name, a run
killed at any moment leaves the previous output or the complete new one, and Ctrl-C is one line and
exit status 130."""

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from tofjax import outputs
from tofjax import sweepfile as sf
from tofjax.cli import main

# A 32 x 24 camera: every command's run is short, its outputs complete.
SMALL_CAMERA = "[camera]\noptical_area_m = [0.00056, 0.00042]\n"
RECORD = ["record", "--sweep", "distance", "--from", "1", "--to", "2", "--samples", "2", "--frames", "4",
          "--roi", "2,2", "--quiet"]
META = {"sweep": "distance", "source": "measurement", "modulation_frequency_hz": "80320000.0", "n_phases": "4"}


def _run(args, capsys):
    code = main([str(a) for a in args])
    return code, capsys.readouterr()


def _error(captured) -> str:
    err = captured.err.strip()
    assert "Traceback" not in err and len(err.splitlines()) == 1, err
    assert err.startswith("tofjax: error: "), err
    return err


def _measurement(path: Path, rows: int = 3) -> bytes:
    cols = {c: np.full(rows, 1.0) for c in sf.REQUIRED_COLUMNS}
    cols["valid_fraction"] = np.ones(rows)
    sf.write_sweep(path, META, cols)
    return path.read_bytes()


# -- refusals ---------------------------------------------------------------------------------------
def test_a_recording_is_never_replaced_by_a_second_recording_or_a_simulation(tmp_path, capsys):
    out = tmp_path / "ow.csv"
    assert _run([*RECORD, "--out", out], capsys)[0] == 0
    data = sf.read_sweep(out)
    assert data.n_rows == 2
    # The virtual camera's file says source: simulation; a real camera's says measurement.
    text = out.read_text().replace("# source: simulation", "# source: measurement")
    out.write_text(text)
    before = out.read_bytes()
    code, captured = _run([*RECORD, "--out", out], capsys)
    line = _error(captured)
    assert code == 2 and f"{out} holds 2 measured points (source: measurement, created 20" in line
    assert "use --resume to continue it" in line and "--force-replace-measurement" in line
    for extra in ([], ["--overwrite"]):  # a simulation never replaces it, --overwrite or not
        code, captured = _run(["simulate", "--sweep", "distance", "--samples", "3", "--iterations", "20", "--out", out,
                               *extra], capsys)
        assert code == 2 and "a measurement is replaced only with --force-replace-measurement" in _error(captured)
    assert _run([*RECORD, "--out", out, "--overwrite"], capsys)[0] == 2
    assert out.read_bytes() == before
    # Named explicitly, it is replaced.
    assert _run(["simulate", "--sweep", "distance", "--samples", "3", "--iterations", "20", "--out", out, "--overwrite",
                 "--force-replace-measurement", "--quiet"], capsys)[0] == 0
    assert sf.read_sweep(out).metadata["source"] == "simulation"


def test_every_writing_command_refuses_an_existing_output_before_any_work(tmp_path, capsys):
    sim = tmp_path / "s.csv"
    assert _run(["simulate", "--sweep", "distance", "--samples", "3", "--iterations", "20", "--out", sim, "--quiet"],
                capsys)[0] == 0
    before = sim.read_bytes()
    code, captured = _run(["simulate", "--sweep", "distance", "--samples", "3", "--out", sim], capsys)
    assert code == 2 and "holds 3 simulated points (source: simulation" in _error(captured)
    assert "use --overwrite to replace it" in _error(captured) and sim.read_bytes() == before
    toml = tmp_path / "camera.toml"
    toml.write_text("[pixel]\nsbi = false\n")
    code, captured = _run(["config", "--out", toml], capsys)
    assert code == 2 and f"--out {toml} exists (" in _error(captured) and toml.read_text() == "[pixel]\nsbi = false\n"
    assert _run(["config", "--out", toml, "--overwrite"], capsys)[0] == 0 and "[scene]" in toml.read_text()
    folder = tmp_path / "done"
    folder.mkdir()
    (folder / "notes.txt").write_text("mine")
    for args in (["render", "--scene", "wall", "--out", folder],
                 ["compare", sim, "--out", folder],
                 ["calibrate", sim, "--fit", "pixel.demodulation_contrast", "--out", folder],
                 ["simulate", "--sweep", "distance", "--report", folder]):
        code, captured = _run(args, capsys)
        assert code == 2 and f"--{'report' if args[0] == 'simulate' else 'out'} {folder} holds 1 file;" in _error(captured)
        # --overwrite replaces only a directory tofjax wrote: notes.txt could be the user's data.
        code, captured = _run([*args, "--overwrite"], capsys)
        assert code == 2 and "holds files tofjax did not write (notes.txt)" in _error(captured)
    assert sorted(p.name for p in folder.iterdir()) == ["notes.txt"]
    # A backend file (the posterior chain) is continued with --resume, never replaced by surprise.
    chain = tmp_path / "chain.h5"
    chain.write_bytes(b"\x89HDF")
    code, captured = _run(["calibrate", sim, "--fit", "pixel.demodulation_contrast", "--mcmc", "--backend", chain,
                           "--out", tmp_path / "cal"], capsys)
    assert code == 2 and "use --resume to continue or --overwrite to replace" in _error(captured)
    code, captured = _run(["calibrate", sim, "--fit", "pixel.demodulation_contrast", "--mcmc", "--backend",
                           tmp_path / "cal" / "chain.h5", "--out", tmp_path / "cal"], capsys)
    assert code == 2 and "lies inside --out" in _error(captured)


def test_a_render_folder_is_replaced_as_a_whole(tmp_path, capsys):
    config = tmp_path / "small.toml"
    config.write_text(SMALL_CAMERA)
    out = tmp_path / "render"
    common = ["render", "--scene", "wall", "--config", config, "--frames", "4", "--quiet", "--out", out]
    assert _run([*common, "--keep-frames", "1"], capsys)[0] == 0
    first = {p.name for p in out.iterdir()}
    assert "frame_radial_m.png" in first and outputs.MARKER in first
    marker = json.loads((out / outputs.MARKER).read_text())
    assert marker["command"] == "tofjax render" and set(marker["files"]) == first - {outputs.MARKER}
    assert _run(common, capsys)[0] == 2
    assert _run([*common, "--keep-frames", "0", "--overwrite"], capsys)[0] == 0
    # The earlier run's kept-frame map is gone with it: nothing of two runs side by side.
    assert {p.name for p in out.iterdir()} == first - {"frame_radial_m.png"}
    assert not [p for p in tmp_path.iterdir() if ".partial-" in p.name]


# Spellings of a measurement that the reader reads (issue 49 item 10): each once replaced by
# --overwrite alone, the recogniser comparing the first line's bytes with "# format: tofjax-sweep/"
# (a byte-order mark it already skipped).
SPELLINGS = {
    "no blank after #": lambda t: t.replace("# format:", "#format:", 1),
    "blank before #": lambda t: " " + t,
    "tab after #": lambda t: t.replace("# format:", "#\tformat:", 1),
    "no blank after format:": lambda t: t.replace("# format: ", "# format:", 1),
    "CR line ends": lambda t: t.replace("\n", "\r"),
}


def _spelt(path: Path, spelling: str) -> bytes:
    """A 3-row measurement spelt ``spelling``, which the reader reads as one."""
    text = _measurement(path).decode()
    path.write_bytes(SPELLINGS[spelling](text).encode("utf-8"))
    data = sf.read_sweep(path)
    assert data.metadata["source"] == "measurement" and data.n_rows == 3
    return path.read_bytes()


@pytest.mark.parametrize("spelling", SPELLINGS)
def test_a_measurement_is_recognised_however_the_reader_reads_it(tmp_path, capsys, spelling):
    out = tmp_path / "lts.csv"
    before = _spelt(out, spelling)
    assert outputs.is_measurement(out) and "holds 3 measured points" in outputs.describe(out)
    code, captured = _run(["config", "--out", out, "--overwrite"], capsys)
    assert code == 2 and "a measurement is replaced only with --force-replace-measurement" in _error(captured)
    assert out.read_bytes() == before


def test_every_writer_refuses_a_measurement_spelt_otherwise(tmp_path, capsys):
    """simulate --out, a render or report folder holding one, and the explorer's Export CSV."""
    out = tmp_path / "lts.csv"
    before = _spelt(out, "CR line ends")
    code, captured = _run(["simulate", "--sweep", "distance", "--samples", "3", "--out", out, "--overwrite"], capsys)
    assert code == 2 and "--force-replace-measurement" in _error(captured) and out.read_bytes() == before
    folder = tmp_path / "report"  # a folder tofjax wrote, holding the measurement among its files
    with outputs.OutputDir(folder, "tofjax simulate") as staged:
        staged.file("sweep.csv").write_bytes(before)
    for args in (["simulate", "--sweep", "distance", "--report", folder],
                 ["render", "--scene", "wall", "--out", folder]):
        code, captured = _run([*args, "--overwrite"], capsys)
        assert code == 2 and f"{folder} holds the measurement sweep.csv" in _error(captured)
    assert (folder / "sweep.csv").read_bytes() == before
    from types import SimpleNamespace

    from tofjax._explorer_state import ExplorerState

    state = ExplorerState(folder=tmp_path)
    state.run, state.figures = SimpleNamespace(sweep=SimpleNamespace(variable="distance")), {"snr": None}
    target = tmp_path / "distance_snr.csv"  # what Export CSV of the snr plot writes
    target.write_bytes(before)

    def export(overwrite=False):
        return state.write_plots("camera.toml", ["snr"], "csv", lambda path, _fig: outputs.write_text(path, "x"),
                                 overwrite, export)

    assert export()[1].text.startswith("distance_snr.csv exists: press Overwrite")
    written, message = state.confirm()  # the Overwrite button
    assert written is None and message.error and "holds 3 measured points" in message.text
    assert target.read_bytes() == before


def test_long_names_are_written_or_refused_before_any_work(tmp_path, capsys, monkeypatch):
    """Issue 49 item 12: a legal name of 230-255 bytes failed with "File name too long" once the
    temporary name added its characters (a traceback from render, compare and the explorer's
    save); a name longer than the file system allows raised OSError; --out . ran, then failed."""
    legal = tmp_path / ("r" * 250)
    assert _run(["config", "--out", f"{legal}.toml"], capsys)[0] == 0
    assert "[scene]" in Path(f"{legal}.toml").read_text()
    with outputs.OutputDir(legal, "tofjax render") as folder:  # render's, compare's, calibrate's folder
        outputs.write_text(folder.file("report.html"), "<html></html>")
    assert (legal / "report.html").is_file() and not [p for p in tmp_path.iterdir() if ".partial-" in p.name]
    too_long = tmp_path / ("m" * 300 + ".toml")
    code, captured = _run(["config", "--out", too_long], capsys)
    assert code == 2 and "the name is 305 bytes long: this file system allows at most 255 bytes" in _error(captured)
    code, captured = _run(["simulate", "--sweep", "distance", "--report", tmp_path / ("d" * 256) / "x"], capsys)
    assert code == 2 and "is 256 bytes long" in _error(captured)
    # An output folder named . (or a folder above it) cannot be swapped in whole: refused first.
    empty = tmp_path / "empty"
    empty.mkdir()
    monkeypatch.chdir(empty)
    for out in (".", ".."):
        code, captured = _run(["render", "--scene", "wall", "--frames", "2", "--out", out], capsys)
        assert code == 2 and f"--out {out}: " in _error(captured) and "the working directory" in _error(captured)
    assert list(empty.iterdir()) == []


# -- atomic files -----------------------------------------------------------------------------------
def test_a_failed_write_leaves_the_previous_file_and_no_partial_file(tmp_path):
    path = tmp_path / "sweep.csv"
    path.write_text("previous")
    with pytest.raises(RuntimeError), outputs.atomic_path(path) as tmp:
        tmp.write_text("half")
        raise RuntimeError("killed")
    assert path.read_text() == "previous" and sorted(p.name for p in tmp_path.iterdir()) == ["sweep.csv"]


def test_a_file_that_appears_meanwhile_is_kept_and_this_output_beside_it(tmp_path):
    """Two runs writing one name: the second to finish neither replaces nor mixes with the first."""
    path = tmp_path / "out.csv"
    with pytest.raises(outputs.OutputError, match="appeared while this run was writing it") as err:
        with outputs.atomic_path(path, replace=False) as tmp:
            tmp.write_text("second")
            path.write_text("first")  # the other run finishes first
    assert path.read_text() == "first"
    kept = [p for p in tmp_path.iterdir() if p.name.startswith("out-")]
    assert len(kept) == 1 and kept[0].read_text() == "second" and str(kept[0]) in str(err.value)


def test_the_api_writers_never_replace_a_measurement(tmp_path):
    path = tmp_path / "lts.csv"
    before = _measurement(path)
    cols = {c: np.ones(2) for c in sf.REQUIRED_COLUMNS}
    with pytest.raises(outputs.OutputError, match="holds 3 measured points"):
        sf.write_sweep(path, {**META, "source": "simulation"}, cols)
    with pytest.raises(outputs.OutputError):
        sf.SweepWriter(path, META, sf.REQUIRED_COLUMNS)
    assert path.read_bytes() == before
    sf.write_sweep(path, {**META, "source": "simulation"}, cols, replace_measurement=True)
    assert sf.read_sweep(path).n_rows == 2


def test_stale_partials_of_killed_runs_are_removed_and_live_ones_kept(tmp_path):
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    stale = tmp_path / f".out.csv.partial-{dead.pid}-abc123"
    live = tmp_path / f".out.csv.partial-{os.getpid()}-def456"
    aside = tmp_path / f".out.csv.replaced-{dead.pid}-aaa111"
    for p in (stale, live, aside):
        p.write_text("x")
    outputs.write_text(tmp_path / "out.csv", "new")
    assert not stale.exists() and live.exists() and aside.exists()


# -- killed and interrupted runs --------------------------------------------------------------------
def _tofjax(*args, stderr=subprocess.DEVNULL) -> subprocess.Popen:
    env = {**os.environ, "JAX_PLATFORMS": "cpu"}
    return subprocess.Popen([sys.executable, "-m", "tofjax.cli", *map(str, args)], env=env, stdout=subprocess.DEVNULL,
                            stderr=stderr, text=True)


def _ok(*args, capsys) -> None:
    """The command run to its end in this process (no process start and import; it leaves its
    programs in the run's compilation cache for the processes started after it)."""
    assert main([str(a) for a in args]) == 0, capsys.readouterr().err


def _wait_for(predicate, proc, timeout=120.0) -> None:
    deadline = time.monotonic() + timeout
    while not predicate() and proc.poll() is None and time.monotonic() < deadline:
        time.sleep(0.01)


def _whole(out: Path) -> dict[str, bytes]:
    """An output folder is whole: its marker lists exactly its files, and they read."""
    files = {p.name: p.read_bytes() for p in out.iterdir()}
    assert set(json.loads(files[outputs.MARKER])["files"]) == set(files) - {outputs.MARKER}
    for p in out.iterdir():
        if p.suffix == ".html":
            assert p.read_text().rstrip().endswith("</html>")
        if p.suffix == ".npz":
            with np.load(p) as data:
                assert data["radial_m"].shape == (24, 32)
    return files


@pytest.mark.parametrize("command", ["render", "calibrate"])
def test_sigkill_at_any_moment_leaves_the_previous_output_or_the_complete_new_one(tmp_path, command, capsys):
    config = tmp_path / "small.toml"
    config.write_text(SMALL_CAMERA)
    out = tmp_path / "out"
    if command == "render":
        args = ["render", "--scene", "step_edge", "--config", config, "--frames", "200", "--quiet", "--out", out]
        other = ["--seed", "1"]  # every file of the killed runs differs from the first run's
    else:
        sweep = tmp_path / "s.csv"  # the model's own expected values, written here (no process of its own)
        import tofjax as tj

        d = np.linspace(0.5, 3.0, 6)
        r = tj.predict(tj.Params(), tj.Sweep("distance", d))
        cols = {c: np.asarray(getattr(r, c)) for c in ("distance_m", "integration_time_s", "illuminance_lx",
                                                         "depth_mean_m", "depth_std_m", "amplitude_mean_lsb",
                                                         "amplitude_std_lsb", "valid_fraction")}
        sf.write_sweep(sweep, {**META, "source": "simulation"}, {**cols, "n_frames": np.full(6, 300.0)})
        args = ["calibrate", sweep, "--fit", "pixel.demodulation_contrast", "--quiet", "--out", out]
        other = ["--initial", "pixel.demodulation_contrast=0.3"]
    _ok(*args, capsys=capsys)
    previous = _whole(out)
    rng = np.random.default_rng(7)
    staging = lambda: any(".partial-" in p.name for p in tmp_path.rglob("*"))  # noqa: E731
    # Killed while the outputs are being written (the staging folder exists), and for render at a
    # random moment too (a calibration's random kills cost 5 s each and catch nothing more).
    for when in ("writing", rng.uniform(0.5, 4.0))[: 2 if command == "render" else 1]:
        proc = _tofjax(*args, *other, "--overwrite")
        if when == "writing":
            _wait_for(staging, proc)
            time.sleep(rng.uniform(0.1, 0.6))
        else:
            time.sleep(when)
        proc.send_signal(signal.SIGKILL)
        proc.communicate()
        now = _whole(out)
        assert set(now) == set(previous)
        if now[outputs.MARKER] == previous[outputs.MARKER]:  # the previous output, to the byte, or a new whole one
            assert now == previous


def test_a_ctrl_c_inside_a_garbage_collector_callback_is_raised_just_after_it(capfd):
    """Python prints and drops an exception raised inside a gc callback (JAX registers one) or a weakref
    callback: while a command runs, its unraisable hook prints nothing and signals again, and that
    second signal, outside the callback, raises. It once printed "Exception ignored in: <function
    _xla_gc_callback ...>" with a traceback before the one line of a Ctrl-C."""
    import gc

    from tofjax import cli, progress

    raised = []

    def callback(phase, info):
        if phase == "start" and not raised:
            raised.append(1)
            signal.raise_signal(signal.SIGINT)  # handled here, inside the collector's callback

    gc.callbacks.append(callback)
    try:
        with cli.interrupts(), pytest.raises(KeyboardInterrupt):
            gc.collect()
            time.sleep(5.0)  # the second SIGINT arrives in 20 ms and raises here
    finally:
        gc.callbacks.remove(callback)
        progress.clear_interrupt()
    assert raised == [1] and "Exception ignored" not in capfd.readouterr().err


def test_ctrl_c_is_one_line_and_exit_status_130(tmp_path):
    # simulate: long enough never to end by itself; interrupted while it computes.
    proc = _tofjax("simulate", "--sweep", "distance", "--samples", "200", "--iterations", "10000000", "--quiet",
                   "--out", tmp_path / "s.csv", stderr=subprocess.PIPE)
    time.sleep(4.0)
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 130, err
    assert err.strip() == "tofjax: interrupted before anything was written (no output exists yet)", err
    assert not (tmp_path / "s.csv").exists()
    # record: interrupted after its first points; every completed point stays in the file.
    out = tmp_path / "r.csv"
    proc = _tofjax("record", "--sweep", "distance", "--from", "0.6", "--to", "2.4", "--samples", "8", "--frames", "40",
                   "--roi", "2,2", "--settle", "0.3", "--quiet", "--out", out, stderr=subprocess.PIPE)
    _wait_for(lambda: out.exists() and sf.read_sweep(out, allow_empty=True).n_rows >= 2, proc)
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=60)
    rows = sf.read_sweep(out).n_rows
    assert proc.returncode == 130, err
    assert err.strip() == (f"tofjax: interrupted after {rows} of 8 points; every completed point is in {out}; "
                           "continue with --resume"), err


# The tofjax command in a process that sends itself SIGINT once a compilation (a persistent-cache
# request not yet ended by its backend compile) has run 0.3 s: the Ctrl-C lands inside jaxlib's wait
# for the compilation, which goes on in XLA's thread pool. The marker shows whether the interpreter's
# teardown ran after the command: the C++ destructors it runs under that compiling thread aborted
# about half of such runs (SIGABRT or SIGSEGV, after the interrupt's line); the marker makes every
# such exit visible, crashing or not.
_MID_COMPILE = """
import atexit, os, signal, sys, threading, time
from jax import monitoring

started, sent = [], []
def event(name, **_):
    if name == "/jax/compilation_cache/compile_requests_use_cache":
        started.append(time.monotonic())
def duration(name, _seconds, **_):
    if name == "/jax/core/compile/backend_compile_duration":
        started.clear()
def watch():
    while not sent:
        time.sleep(0.005)
        since = list(started)
        if since and time.monotonic() - since[0] > 0.3:
            sent.append(1)
            os.kill(os.getpid(), signal.SIGINT)
monitoring.register_event_listener(event)
monitoring.register_event_duration_secs_listener(duration)
threading.Thread(target=watch, daemon=True).start()
atexit.register(lambda: os.write(2, b"(the interpreter's teardown ran)\\n"))
sys.argv = ["tofjax", *sys.argv[1:]]
from tofjax.cli import entry_point
entry_point()
"""


def test_ctrl_c_while_jax_compiles_is_one_line_and_exit_status_130(tmp_path):
    """Issue 49 item 9: `record` interrupted before its first point, while JAX compiled (a cold cache),
    printed its line and then aborted (exit status 134 or 139) in the interpreter's teardown."""
    out = tmp_path / "v.csv"
    env = {**os.environ, "JAX_PLATFORMS": "cpu", "TOFJAX_CACHE_DIR": "off"}
    env.pop("XLA_FLAGS", None)  # a user's compilation, not the suite's quicker one (tests/conftest.py)
    proc = subprocess.run([sys.executable, "-c", _MID_COMPILE, *RECORD, "--out", str(out)], env=env,
                          capture_output=True, text=True, timeout=120)
    if proc.returncode == 0:
        pytest.skip("no compilation of the recording lasted 0.3 s on this machine")
    assert proc.returncode == 130, proc.stderr
    assert proc.stderr.strip() == "tofjax: interrupted before the first point was measured; nothing was recorded", \
        proc.stderr
    assert not out.exists() or sf.read_sweep(out, allow_empty=True).n_rows == 0
