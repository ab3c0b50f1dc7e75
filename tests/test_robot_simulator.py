"""The worked example (issue 51 item 4; notebooks/robot_simulator.py, docs/simulators.md): MuJoCo's arm
in a room streamed through ToFSensor. notebooks/10_robot_simulator.ipynb runs it for real at a small
size and asserts what its GIF promises (good pixels, the corner reading long, flying pixels, the
noise growing with distance, nothing wrapped, the GIF written whole; tests/test_notebooks.py runs
it): one run of the example in the suite. Here: an existing GIF is kept unless --overwrite, refused
before any work."""

import os
import sys
from pathlib import Path

import pytest

os.environ.setdefault("MUJOCO_GL", "egl")
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "notebooks"))

import robot_simulator as rs  # noqa: E402


def test_an_existing_gif_is_kept_unless_overwrite(tmp_path, capsys):
    gif = tmp_path / "robot_simulator.gif"
    gif.write_bytes(b"GIF89a a recorded run")
    with pytest.raises(SystemExit) as stop:
        rs.main(["--steps", "1", "--scale", "8", "--out", str(tmp_path)])
    assert stop.value.code == 2 and "robot_simulator.gif exists: give --overwrite" in capsys.readouterr().err
    with pytest.raises(FileExistsError, match="give --overwrite"):
        rs.run(1, tmp_path, scale=8)
    assert gif.read_bytes() == b"GIF89a a recorded run" and [p.name for p in tmp_path.iterdir()] == [gif.name]
