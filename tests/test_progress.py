"""tofjax.progress: the time left is estimated from the steps after the first (which carries the
compilation), the least squares' bound is said as a bound, and lines come at their interval."""

import io
import time

from tofjax.progress import Progress


class Clock:
    def __init__(self):
        self.t = 0.0

    def __call__(self):
        return self.t


def _steps(progress, clock, times):
    for t in times:
        clock.t = t
        progress.update(1)


def test_time_left_leaves_out_the_first_step():
    """A first step of 10 s (compiling) and then steps of 0.03 s: 997 steps left take 29.9 s, not
    the 3.3 h that the average rate since the start (10.06 s / 3 steps) would say."""
    clock = Clock()
    p = Progress(1000, "least squares", stream=io.StringIO(), clock=clock)
    assert p.eta_s() is None
    _steps(p, clock, [10.0])
    assert p.eta_s() is None  # one step: no rate yet
    _steps(p, clock, [10.03, 10.06])
    assert abs(p.eta_s() - 0.03 * 997) < 1e-9


def test_lines_say_at_most_for_an_upper_bound_and_about_otherwise():
    clock = Clock()
    out = io.StringIO()
    bound = Progress(1000, "least squares", stream=out, clock=clock, upper_bound=True, every_s=1.0, quiet_for_s=2.0)
    _steps(bound, clock, [10.0, 10.5, 11.0])
    line = bound.line()
    assert line == "least squares: step 3 of at most 1000, 11 s elapsed, at most 8.3 min left", line
    clock.t = 5.0
    plain = Progress(4, "simulating", unit="chunk", stream=io.StringIO(), clock=clock)
    _steps(plain, clock, [12.0, 14.0])
    assert plain.line() == "simulating: 50 % (2/4 chunks), 9 s elapsed, about 4 s left", plain.line()


def test_quiet_at_first_then_a_line_per_interval():
    """No line before quiet_for_s, then one every every_s (not a terminal: a StringIO)."""
    clock = Clock()
    out = io.StringIO()
    p = Progress(100, "recording", unit="point", stream=out, clock=clock, every_s=10.0, quiet_for_s=2.0)
    _steps(p, clock, [0.5, 1.0, 1.5])
    assert out.getvalue() == ""
    _steps(p, clock, [11.0, 12.0, 20.0, 21.5])
    lines = out.getvalue().splitlines()
    assert [line.split(":")[0] for line in lines] == ["recording", "recording"]
    assert lines[0].startswith("recording: 4 % (4/100 points), 11 s elapsed")


def test_stages_are_quiet_in_a_short_run_and_each_announced_in_a_long_one():
    from tofjax.progress import Stages

    clock = Clock()
    out = io.StringIO()
    with Stages("render", stream=out, quiet_for_s=2.0, clock=clock) as stage:
        stage("casting rays")
        clock.t = 1.0
        stage("frames")
    assert out.getvalue() == ""  # a second's run says nothing
    with Stages("render", stream=out, quiet_for_s=2.0, clock=clock) as stage:
        clock.t = 4.0
        stage("frames")
        clock.t = 95.0
        stage("writing")
    assert out.getvalue().splitlines() == ["render: frames ... (3 s elapsed)", "render: writing ... (1.6 min elapsed)"]


def test_a_long_compilation_is_announced_once():
    import jax
    import jax.numpy as jnp

    from tofjax.progress import compiling

    out = io.StringIO()
    with compiling(stream=out, notice_s=0.0) as notice:
        jax.jit(lambda x: jnp.sin(x) * 1.2345678 + jnp.cos(x) ** 3)(jnp.arange(7.0)).block_until_ready()
        for _ in range(40):  # the thread looks every 0.1 s
            if notice.announced:
                break
            time.sleep(0.05)
    assert notice.spent_s() > 0 and out.getvalue() == "compiling (first run; cached for next time) ...\n"
    quiet = io.StringIO()
    with compiling(stream=quiet, notice_s=60.0):
        jax.jit(lambda x: x * 7.654321)(1.0)
    assert quiet.getvalue() == ""


def test_render_reports_every_stage_and_its_frames_in_a_log(tmp_path, capsys, monkeypatch):
    """Not a terminal (capsys): one line per stage and per progress interval, counts as integers."""
    from tofjax import progress
    from tofjax.cli import main

    monkeypatch.setattr(progress, "QUIET_FOR_S", 0.0)
    monkeypatch.setattr(progress, "EVERY_S", 0.0)
    config = tmp_path / "small.toml"
    config.write_text("[camera]\noptical_area_m = [0.00056, 0.00042]\n")
    out = tmp_path / "corner"
    assert main(["render", "--scene", "corner", "--config", str(config), "--frames", "3",
                 "--out", str(out)]) == 0
    err = capsys.readouterr().err
    stages = [line.split(" ... ")[0] for line in err.splitlines() if " ... (" in line]
    assert stages == ["render: casting 3^2 rays per pixel of 24 x 32 pixels and the two-bounce light",
                      "render: 3 Monte Carlo frames", "render: the analytic noise image", f"render: writing {out}"]
    assert "render: 3 frames: 100 % (1/1 chunks)" in err


class _Terminal(io.StringIO):
    def isatty(self):
        return True


def test_a_terminal_bar_counts_in_whole_numbers():
    """tqdm shows a float total as 1.0/16.0; the bar's counts are integers."""
    clock = Clock()
    out = _Terminal()
    with Progress(1, "simulating", unit="chunk", stream=out, clock=clock, quiet_for_s=0.0) as p:
        p.total = 16.0
        clock.t = 1.0
        p.update(1)
        clock.t = 2.0
        p.update(1)
    text = out.getvalue()
    assert "1/16 " in text and ".0/" not in text and "/16.0" not in text


def test_scripts_and_notebooks_turn_the_compilation_cache_on(capsys, monkeypatch):
    """... and hear what the commands say when they compile for long (a cold README frame snippet
    compiled for a minute in silence), on standard error, once."""
    import functools
    import json
    import random
    from pathlib import Path

    import jax
    import jax.numpy as jnp

    import tofjax as tj
    from tofjax import progress

    before = (jax.config.jax_compilation_cache_dir, jax.config.jax_persistent_cache_min_compile_time_secs)
    monkeypatch.setattr(progress, "COMPILING_NOTICE_S", 0.0)
    try:
        path = tj.enable_compilation_cache()
        assert path is not None and jax.config.jax_compilation_cache_dir == path
        assert jax.config.jax_persistent_cache_min_compile_time_secs == 0.0  # every program is kept
        for scale in (random.random(), random.random()):  # programs no run has compiled before (their constants)
            jax.jit(functools.partial(lambda c, x: jnp.sin(x) * c, scale))(jnp.arange(3.0)).block_until_ready()
            for _ in range(40):  # the notice's thread looks every 0.1 s
                if progress._notice.announced:
                    break
                time.sleep(0.05)
    finally:  # the rest of this worker's tests compile as before, without the notice
        progress.compile_notice(False)
        jax.config.update("jax_compilation_cache_dir", before[0])
        jax.config.update("jax_persistent_cache_min_compile_time_secs", before[1])
    assert capsys.readouterr().err == "compiling (first run; cached for next time) ...\n"
    for notebook in sorted((Path(__file__).resolve().parents[1] / "notebooks").glob("*.ipynb")):
        cells = [c for c in json.loads(notebook.read_text())["cells"] if c["cell_type"] == "code"]
        assert "tj.enable_compilation_cache()" in "".join(cells[1]["source"]), notebook.name
