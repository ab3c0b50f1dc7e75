"""docs/api.md stays true: each Python block runs as written, in a namespace of its own, turns the
compilation cache on, and shows what it says (good pixels and a point cloud: its frame had been a
wall beyond the unambiguity range, every pixel flagged wrapped, the cloud empty, without a word)."""

import contextlib
import io
import re
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]


def _python_blocks() -> list[str]:
    return re.findall(r"```python\n(.+?)\n```", (ROOT / "docs" / "api.md").read_text(), re.S)


def test_every_api_doc_block_runs_and_shows_what_it_says():
    from helpers import examples_as_scripts

    blocks = _python_blocks()
    assert blocks
    namespaces, out = [], io.StringIO()
    with examples_as_scripts():  # the rest of this worker's tests compile as before, without the notice
        for i, text in enumerate(blocks):
            assert "tj.enable_compilation_cache()" in text, f"docs/api.md block {i + 1}: a cold start is silent"
            namespace = {"__name__": "__api_doc__"}
            with contextlib.redirect_stdout(out):  # warnings are errors here: an all-flagged frame fails
                exec(compile(text, f"docs/api.md block {i + 1}", "exec"), namespace)
            namespaces.append(namespace)
    first = namespaces[0]
    image, expected, frames = first["image"], first["expected"], first["frames"]
    flags = np.asarray(image.flags)
    assert np.all(flags == 0) and len(image.points_m()) == flags.size  # every pixel good, all in the cloud
    assert np.all(np.isfinite(expected.depth_std_m)) and np.all(np.asarray(frames.valid_fraction) == 1.0)
    assert f"100% good pixels, {flags.size} points" in out.getvalue()
