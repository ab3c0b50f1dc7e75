"""README's two commands stay true: CI runs exactly the test command, and the main job runs."""

import re
import shlex
from pathlib import Path

from tofjax import sweepfile as sf
from tofjax.cli import main

ROOT = Path(__file__).resolve().parents[1]


def _readme_commands():
    return re.findall(r"```bash\n(.+?)\n```", (ROOT / "README.md").read_text())[:2]


def test_ci_runs_exactly_the_readme_test_command():
    _, test_command = _readme_commands()
    ci_lines = [line.strip() for line in (ROOT / ".ci" / "run").read_text().splitlines()]
    assert test_command in ci_lines


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
