"""README.md stays true: CI runs exactly its test command, the main job runs, and every other code
block runs as written (bash blocks command by command, Python blocks each on its own), in one
folder, in order, with the repository's `fitting/` beside them."""

import contextlib
import glob
import io
import os
import re
import shlex
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from tofjax import sweepfile as sf
from tofjax.cli import main

from helpers import examples_as_scripts, out_of_the_collectors_way

ROOT = Path(__file__).resolve().parents[1]


def _blocks() -> list[tuple[str, str]]:
    """(language, text) of every fenced block of README.md, in order."""
    return re.findall(r"```(\w+)\n(.+?)\n```", (ROOT / "README.md").read_text(), re.S)


def _readme_commands():
    return [text for lang, text in _blocks() if lang == "bash"][:2]


def test_ci_runs_exactly_the_readme_test_command():
    _, test_command = _readme_commands()
    ci_lines = [line.strip() for line in (ROOT / ".ci" / "run").read_text().splitlines()]
    assert test_command in ci_lines
    # ... and that command names its ten slowest tests (pyproject.toml's addopts), so the next
    # person sees where the suite's time goes.
    assert "--durations=10" in (ROOT / "pyproject.toml").read_text()


def test_the_suite_rewrites_the_asserts_of_its_own_modules_only():
    """tests/conftest.py: the packages of plugin-shipping distributions (hypothesis here) load as
    they are, the suite's modules with pytest's assertion messages."""
    import hypothesis
    from _pytest.assertion.rewrite import AssertionRewritingHook

    assert not isinstance(hypothesis.__spec__.loader, AssertionRewritingHook)
    assert isinstance(sys.modules[__name__].__spec__.loader, AssertionRewritingHook)


def test_the_workers_and_their_subprocesses_allocate_with_jemalloc_where_it_is_installed():
    """tests/conftest.py: where jemalloc is installed (CI installs it: .ci/run), the processes the run
    starts preload it: this one, a pytest-xdist worker, has it mapped, and a process it starts has it
    too. Run without workers, only the processes it starts have it."""
    import ctypes.util

    if not sys.platform.startswith("linux"):
        pytest.skip("LD_PRELOAD is Linux's (ld.so)")
    if ctypes.util.find_library("jemalloc") is None:
        assert "libjemalloc2" in (ROOT / ".ci" / "run").read_text()  # CI has it; a fresh machine may not
        pytest.skip("jemalloc is not installed here (Debian: libjemalloc2)")
    maps = subprocess.run([sys.executable, "-c", "print(open('/proc/self/maps').read())"], capture_output=True,
                          text=True, check=True).stdout
    assert "libjemalloc" in maps
    if os.environ.get("PYTEST_XDIST_WORKER"):
        assert "libjemalloc" in Path("/proc/self/maps").read_text()


def test_readme_cites_the_thesis_explains_its_terms_and_names_the_extras():
    """A first reader meets "Table 4.9", "§5.5.1", SBI, LSB, PMD, kTC and LTS: the README gives the
    thesis' full reference and links a glossary that explains each; recording's USB packages come with
    the record extra, not with tofjax (the README said they did)."""
    readme = (ROOT / "README.md").read_text()
    flat = " ".join(readme.replace("> ", "").split())
    assert ('Matthias Almer, "Time-of-Flight 3D-Camera Performance Modeling", master\'s thesis, Institute for '
            "Technical Informatics, Graz University of Technology") in flat
    assert "[glossary](docs/model.md#glossary)" in readme
    model = (ROOT / "docs" / "model.md").read_text()
    glossary = model.split("\n## Glossary\n", 1)[1].split("\n## ", 1)[0]
    for term in ("SBI", "LSB", "PMD", "kTC", "LTS"):
        assert f"**{term}" in glossary, term
    assert "come with tofjax" not in readme
    assert 'the `record` extra, `pip install ".[record]"` (pyusb, pyftdi and thorlabs-apt-protocol' in flat


def test_readme_main_job_runs_on_defaults(tmp_path, monkeypatch, capsys):
    main_command, _ = _readme_commands()
    install, job = main_command.split(" && ")
    assert install == "pip install ."
    argv = shlex.split(job)
    assert argv[0] == "tofjax"
    monkeypatch.chdir(tmp_path)
    assert main(argv[1:]) == 0
    data = sf.read_sweep(tmp_path / argv[argv.index("--out") + 1])
    assert data.n_rows == 1000 and set(data.columns["n_frames"]) == {2000.0}
    printed = capsys.readouterr().out
    assert "1000 samples (Monte Carlo, 2000 frames/sample)" in printed
    # The summary's unwrapped depth and the file's wrapped one cannot be taken for each other.
    assert "unwrapped [m]" in printed.splitlines()[0] and "depth mean" not in printed
    assert data.metadata["depth_columns"].startswith("depth_mean_m is wrapped into [0, unambiguity_range_m)")
    assert float(data.metadata["unambiguity_range_m"]) > 1.8


def _shell_lines(text: str) -> list[str]:
    """A bash block's commands: continuation lines joined, blank lines dropped."""
    return [line for line in text.replace("\\\n", " ").splitlines() if line.strip()]


def _run_command(line: str) -> None:
    """One command line of a bash block, as a shell would run it here: ``tofjax ...`` in this
    process (``> FILE`` redirected, globs expanded), ``python -c CODE`` in a new one."""
    argv = shlex.split(line, comments=True)
    target = None
    if ">" in argv:
        at = argv.index(">")
        argv, target = argv[:at], argv[at + 1]
    argv = [match for arg in argv for match in (sorted(glob.glob(arg)) if "*" in arg else [arg])]
    if argv[:2] == ["python", "-c"]:
        done = subprocess.run([sys.executable, "-c", argv[2]], capture_output=True, text=True)
        assert done.returncode == 0, (line, done.stderr)
        return
    assert argv[0] == "tofjax", f"README block command the test cannot run: {line}"
    out = io.StringIO()
    with contextlib.redirect_stdout(out) if target else contextlib.nullcontext():
        code = main(argv[1:])
    assert code == 0, line
    if target:
        Path(target).write_text(out.getvalue(), encoding="utf-8")


def test_every_readme_block_runs_as_written(tmp_path, monkeypatch, capsys):
    """The blocks after the two commands above, in order, in one folder (files one block writes,
    such as camera.toml, are the next one's); each Python block in a namespace of its own, so that
    it cannot lean on names an earlier one defined. Progress lines on, as a long run in a log has them."""
    from tofjax import progress

    monkeypatch.setattr(progress, "QUIET_FOR_S", 0.0)
    monkeypatch.setattr(progress, "EVERY_S", 0.0)
    (tmp_path / "fitting").symlink_to(ROOT / "fitting", target_is_directory=True)
    monkeypatch.chdir(tmp_path)
    blocks = _blocks()
    first_two = [i for i, (lang, _) in enumerate(blocks) if lang == "bash"][:2]
    ran = 0
    with examples_as_scripts():  # the rest of this worker's tests as before: no notice, the suite's cache threshold
        for i, (lang, text) in enumerate(blocks):
            if i in first_two:
                continue  # the tests above
            if lang == "bash":
                for line in _shell_lines(text):
                    _run_command(line)
                    out_of_the_collectors_way()  # each command's survivors too (README test alone: gen-2 gc 1.9 -> 1.1 s)
            elif lang == "python":
                # A cold start compiles for a minute: the snippet turns the cache (and its notice) on.
                assert "tj.enable_compilation_cache()" in text, f"README.md block {i + 1} never turns the cache on"
                exec(compile(text, f"README.md block {i + 1}", "exec"), {"__name__": "__readme__"})
            else:
                pytest.fail(f"README.md block {i + 1} is {lang!r}: add how to run it here")
            ran += 1
            out_of_the_collectors_way()  # a long test: each block's survivors out of the collector's way
    captured = capsys.readouterr()
    assert "Traceback" not in captured.err
    assert ran >= 7
    # What the blocks promise: the calibration is well posed, the renders and the recording complete.
    assert "strongly correlated" not in captured.out and "shorter than 50 autocorrelation times" not in captured.out
    for folder in ("render", "corner", "mine", "comparison", "calibration"):
        assert (tmp_path / folder / ".tofjax-output.json").is_file(), folder
    from tofjax._flags import delivered
    from tofjax.frameio import distance_error_m

    render = np.load(tmp_path / "render" / "frame.npz")
    assert render["raw_codes"].shape == (1, 1, 4, 172, 224)  # --raw
    # The step edge shows what the text says it shows: a column of flying (mixed) pixels among good ones
    # (at edge_x_m = 0 the edge fell between two columns: none).
    mixed = np.nonzero(render["flags"] & 16)
    assert np.unique(mixed[1]).size == 1 and mixed[0].size == 172 and np.mean(delivered(render["flags"])) > 0.9
    # The corner, rendered by a real camera's preset, delivers depth on its walls (the truth's "mixed" removes none) with the two-bounce
    # light's bias in its error map: long on the walls, least on the corner line.

    corner = dict(np.load(tmp_path / "corner" / "frame.npz"))
    good = delivered(corner["flags"])
    assert good.mean() > 0.9 and ((corner["flags"] & 16) != 0)[good].mean() > 0.5
    error = np.where(good, distance_error_m(corner), np.nan)
    centre_row = error[error.shape[0] // 2]
    assert np.nanmedian(error) > 0.01  # multipath reads long
    assert np.nanmin(np.abs(centre_row[len(centre_row) // 2 - 3:len(centre_row) // 2 + 4])) < 0.5 * np.nanmax(centre_row)
    assert sf.read_sweep(tmp_path / "virtual.csv").n_rows == 20
    assert not [p for p in os.listdir(tmp_path) if ".partial-" in p]
    _calibration_as_promised(tmp_path / "calibration", captured)


def _calibration_as_promised(out: Path, captured) -> None:
    """The README's calibration: every output, estimates consistent with the example's truth, the
    calibrated camera usable by simulate; its log holds tofjax's own progress lines (whole counts,
    no carriage-return bar), the estimates come as soon as the least squares ends (before the
    posterior's) and it says when it writes."""
    import json

    import tofjax as tj

    printed = captured.out
    assert printed.index("least squares: converged") < printed.index("posterior: 32 walkers x 2000 steps")
    # A unitless value prints no unit (it printed "8.39e-05 1"); where the posterior's 68 % interval
    # excludes the least-squares estimate (the dark slope: 2.51 against [1.11, 2.42]) a note says
    # why, where the numbers are, and which to quote.
    assert re.search(r"^  pixel\.demodulation_contrast += [0-9.]+ \+- [0-9.e-]+$", printed, re.M), printed
    notes = [line for line in printed.splitlines() if line.startswith("note: pixel.dark_slope_mean_v_per_s: the "
                                                                      "least-squares estimate")]
    assert len(notes) == 1 and "outside the posterior's 68 % interval" in notes[0]
    assert "normalisation -sum log sigma_i" in notes[0] and "Quote the posterior: median" in notes[0]
    assert "\r" not in captured.err and "posterior: 100 % (2000/2000 steps)" in captured.err
    assert f"writing the results, figures and report into {out.name} ..." in captured.err
    names = {p.name for p in out.iterdir()}
    assert {"calibrated.toml", "calibration.json", "residuals.png", "corner.png", "report.md"} <= names
    assert sum(n.startswith("fit_") for n in names) == 3
    result = json.loads((out / "calibration.json").read_text())
    assert result["least_squares"]["converged"] and result["posterior"]["walkers"] == 32
    assert {t["name"]: t["verdict"] for t in result["true_values"]} == {
        "pixel.demodulation_contrast": "consistent", "pixel.dark_slope_mean_v_per_s": "consistent"}
    calibrated = tj.load_config(out / "calibrated.toml")
    for name, fitted in result["least_squares"]["parameters"].items():
        section, key = name.split(".")
        assert calibrated.values[section][key] == pytest.approx(fitted["estimate"])
    assert main(["simulate", "--config", str(out / "calibrated.toml"), "--sweep", "distance", "--method", "analytic",
                 "--samples", "4", "--out", str(out.parent / "calibrated_sim.csv")]) == 0


def test_every_fitting_doc_python_block_runs_and_shows_what_it_says(tmp_path, monkeypatch, capsys):
    """docs/fitting.md's Python blocks (its bash blocks are the README's commands, run above), each in a
    namespace of its own, from a folder with the repository's fitting/ beside it: the calibration
    converges to the example's truth and writes what the command writes; the comparison has one entry
    per file with finite ratios. In this file, after the README's calibration, so its programs are
    compiled once."""
    (tmp_path / "fitting").symlink_to(ROOT / "fitting", target_is_directory=True)
    monkeypatch.chdir(tmp_path)
    blocks = re.findall(r"```python\n(.+?)\n```", (ROOT / "docs" / "fitting.md").read_text(), re.S)
    assert len(blocks) == 2
    namespaces = []
    with examples_as_scripts():
        for i, text in enumerate(blocks):
            assert "tj.enable_compilation_cache()" in text, f"docs/fitting.md block {i + 1}: a cold start is silent"
            namespaces.append({"__name__": "__fitting_doc__"})
            exec(compile(text, f"docs/fitting.md block {i + 1}", "exec"), namespaces[-1])
    ls = namespaces[0]["ls"]
    assert ls.converged and ls.estimate[0] == pytest.approx(0.38, abs=3e-3)
    assert {"calibrated.toml", "calibration.json", "report.md"} <= {p.name for p in (tmp_path / "calibration-api").iterdir()}
    comparisons = namespaces[1]["comparisons"]
    assert len(comparisons) == 3 and all(np.all(np.isfinite(c.ratio("depth_std_m"))) for c in comparisons)
    written = {p.suffix for p in (tmp_path / "comparison-api").iterdir()}
    assert {".csv", ".md", ".html", ".png"} <= written
    assert "Traceback" not in capsys.readouterr().err
