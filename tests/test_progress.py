"""tofjax.progress: the time left is estimated from the steps after the first (which carries the
compilation), the least squares' bound is said as a bound, and lines come at their interval."""

import io

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
