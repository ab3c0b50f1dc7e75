"""docs/simulators.md stays true: each Python block runs as written, in a namespace of its own, turns
the compilation cache on, and prints what the page says it prints (its numbers to 5 %), and its
objects hold what the text claims (the MuJoCo loop's frames, the messages' bytes)."""

import contextlib
import io
import os
import re
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
PAGE = ROOT / "docs" / "simulators.md"
NUMBER = r"[-+]?\d+(?:\.\d+)?"


def _blocks() -> list[tuple[str, str]]:
    """(code, what the page says it prints) of each Python block: the backquoted text after "prints"."""
    text = PAGE.read_text()
    out = []
    for match in re.finditer(r"```python\n(.+?)\n```\n\nprints `(.+?)`", text, re.S):
        out.append((match.group(1), " ".join(match.group(2).split())))
    assert len(out) == len(re.findall(r"```python\n", text)), "every Python block is followed by what it prints"
    return out


def _same_text(printed: str, stated: str) -> bool:
    """The printed line is the stated one, its numbers within 5 % (or 0.15 of a unit: percentages)."""
    if re.sub(NUMBER, "#", printed) != re.sub(NUMBER, "#", stated):
        return False
    pairs = zip(map(float, re.findall(NUMBER, printed)), map(float, re.findall(NUMBER, stated)), strict=True)
    return all(abs(a - b) <= max(0.05 * abs(b), 0.15) or abs(a - b) <= 1.0 and abs(b) >= 5 for a, b in pairs)


def test_every_simulators_block_runs_and_shows_what_it_says():
    from helpers import examples_as_scripts

    os.environ.setdefault("MUJOCO_GL", "egl")
    blocks = _blocks()
    assert len(blocks) == 2
    spaces = []
    with examples_as_scripts():  # the rest of this worker's tests compile as before, without the notice
        for i, (code, stated) in enumerate(blocks):
            assert "tj.enable_compilation_cache()" in code, f"docs/simulators.md block {i + 1}: a cold start is silent"
            out, space = io.StringIO(), {"__name__": "__simulators_doc__"}
            with contextlib.redirect_stdout(out):  # warnings are errors here
                exec(compile(code, f"docs/simulators.md block {i + 1}", "exec"), space)
            printed = " ".join(out.getvalue().split())
            assert _same_text(printed, stated), (i + 1, printed, stated)
            spaces.append(space)
    # The MuJoCo loop: three steps of MuJoCo's planar depth, resampled from its wider field.
    mj = spaces[0]
    frame, render, sensor = mj["frame"], mj["render"], mj["sensor"]
    assert render.depth_type == "z" and render.depth_m.shape == (600, 800) and sensor.steps == 3
    assert not sensor.plan(dict(render.intrinsics)).identity  # resampled onto the ToF camera's rays
    ok = frame.delivered
    assert ok.mean() > 0.9 and np.nanpercentile(np.abs(frame.depth_m - frame.true_depth_m)[ok], 90) < 0.05
    assert set(np.unique(render.segmentation)) >= {0, 1, 2}  # floor, wall, box
    # Any simulator's buffer: the messages hold the frame.
    any_sim = spaces[1]
    frame, z, mm, cloud = any_sim["frame"], any_sim["z"], any_sim["mm"], any_sim["cloud"]
    np.testing.assert_array_equal(z, frame.depth_m)
    assert np.array_equal(np.isnan(z), ~frame.delivered) and np.all(mm[np.isnan(z)] == 0)
    assert cloud["height"] * cloud["width"] * cloud["point_step"] == len(cloud["data"])
    assert abs(np.nanmedian(z[any_sim["crate"]]) - 0.6) < 0.03
