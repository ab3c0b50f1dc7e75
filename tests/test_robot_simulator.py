"""The worked example (issue 51 item 4; notebooks/robot_simulator.py, docs/simulators.md): MuJoCo's arm
in a room streamed through ToFSensor, run for real at a small size, shows what its GIF promises:
good pixels, the corner reading long (two-bounce light), flying pixels between an edge's two
surfaces, the noise growing with distance, nothing wrapped; the GIF written whole, an existing one
kept unless --overwrite. The notebook runs it at this same size (tests/test_notebooks.py), so one of
the two compiles and the other loads the program from the compilation cache."""

import os
import sys
from pathlib import Path

import numpy as np
import pytest

os.environ.setdefault("MUJOCO_GL", "egl")
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "notebooks"))

import robot_simulator as rs  # noqa: E402

#: notebooks/10_robot_simulator.ipynb's size: the Kinect's 512 x 424 pixels over 8 (64 x 53), 3 steps.
STEPS, SCALE = 3, 8


@pytest.fixture(scope="module")
def result(tmp_path_factory):
    return rs.run(STEPS, tmp_path_factory.mktemp("robot"), scale=SCALE)


def test_the_example_shows_multipath_flying_pixels_and_noise_growing_with_distance(result):
    from PIL import Image

    depth, truth = result.depth_m, result.true_depth_m
    assert depth.shape == (STEPS, 53, 64) and result.preset == "kinect-v2"
    assert np.isfinite(depth).mean() > 0.85  # good pixels: delivered
    assert result.wrapped.mean() < 0.01  # the room is within the fused range (18.7 m)
    error = depth - truth
    ok = np.isfinite(depth) & ~result.wrapped
    # The corner reads long: two-bounce light, 35-65 mm here (the walls' direct returns are within mm).
    corner = error[result.corner & ok]
    assert corner.size > 100 and np.median(corner) > 0.015, (corner.size, np.median(corner))
    walls_away = np.median(np.abs(error[ok & ~result.corner & ~result.flying & (truth > 4.0)]))
    assert np.median(corner) > 2 * walls_away
    # Flying pixels: delivered depths between the two surfaces of a depth edge (the arm, the table).
    assert result.flying.sum() >= 5
    # The noise grows with distance: frame to frame, still pixels.
    near, far = result.noise_m(ok & (truth < 2.5)), result.noise_m(ok & (truth > 4.5))
    assert 0 < near < far, (near, far)
    assert "corner: median error +" in result.summary()
    # The GIF: one frame per step, whole (written under a temporary name and renamed), small.
    gif = result.gif
    assert gif.name == "robot_simulator.gif" and gif.stat().st_size < 2e6
    assert [p.name for p in gif.parent.iterdir()] == [gif.name]
    with Image.open(gif) as im:
        assert im.n_frames == STEPS


def test_an_existing_gif_is_kept_unless_overwrite(result, capsys):
    out = result.gif.parent
    before = result.gif.read_bytes()
    with pytest.raises(SystemExit) as stop:
        rs.main(["--steps", "1", "--scale", str(SCALE), "--out", str(out)])
    assert stop.value.code == 2 and "robot_simulator.gif exists: give --overwrite" in capsys.readouterr().err
    with pytest.raises(FileExistsError, match="give --overwrite"):
        rs.run(1, out, scale=SCALE)
    assert result.gif.read_bytes() == before
