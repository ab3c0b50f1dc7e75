"""Progress of long runs, with an estimate of the time left, on standard error.

One reporter for every command (``simulate``'s Monte Carlo, ``calibrate``'s least squares and
posterior, ``record``'s points, ``render``'s frames): on a terminal a bar (tqdm) that shows up after
the first :data:`QUIET_FOR_S` seconds; otherwise (a log file, CI, a pipe) one line every
:data:`EVERY_S` seconds, ``simulating: 40 % (400/1000 chunks), 12 s elapsed, about 18 s left``, so a
run that takes minutes is never silent and a run that takes a second prints nothing.
:class:`Stages` names the stages of a run made of several (``render: casting rays ...``), and
:class:`compiling` says when a cold run spends its first seconds compiling. ``enabled=False`` (the
commands' ``--quiet``) turns them off. A Ctrl-C is recorded here (:func:`interrupt`) and raised again
at the next step, stage or output (:func:`check_interrupt`) if Python dropped it.
"""

from __future__ import annotations

import contextlib
import sys
import threading
import time

_interrupted = threading.Event()


def interrupt() -> None:
    """Record that the user interrupted the run (the commands' SIGINT handler calls it, then raises
    ``KeyboardInterrupt``). Python drops an exception raised inside a finaliser or a weak-reference
    callback, where a signal may land; :func:`check_interrupt` raises it again at the next progress
    step, stage or output, so a Ctrl-C is never lost."""
    _interrupted.set()


def clear_interrupt() -> None:
    _interrupted.clear()


_holding = 0


@contextlib.contextmanager
def held_interrupt():
    """Hold a Ctrl-C until the block ends, then raise it: for a step that must finish once begun
    (``record`` writes a measured row and counts it, so the line an interrupt prints names every row
    in the file). Only the main thread's SIGINT handler honours it (:func:`interrupt_now`)."""
    global _holding
    _holding += 1
    try:
        yield
    finally:
        _holding -= 1
    check_interrupt()


def interrupt_now() -> bool:
    """Whether a SIGINT handler should raise ``KeyboardInterrupt`` now (not inside :func:`held_interrupt`)."""
    return _holding == 0


def check_interrupt() -> None:
    """Raise ``KeyboardInterrupt`` if the run was interrupted (:func:`interrupt`)."""
    if _interrupted.is_set():
        raise KeyboardInterrupt


#: A run shorter than this prints nothing.
QUIET_FOR_S = 2.0
#: Seconds between lines when standard error is not a terminal.
EVERY_S = 10.0


def _duration(seconds: float) -> str:
    if seconds < 90:
        return f"{seconds:.0f} s"
    if seconds < 5400:
        return f"{seconds / 60:.1f} min"
    return f"{seconds / 3600:.1f} h"


def _count(x: float) -> int | float:
    """A count as an integer where it is one (tqdm shows ``1.0/16.0`` for floats)."""
    return int(x) if float(x).is_integer() else x


class Progress:
    """``total`` steps of ``unit`` (``initial`` already done); :meth:`update` adds steps (thread-safe:
    a JAX host callback may call it); a context manager that finishes the bar or the lines.

    ``upper_bound``: ``total`` is the most steps the run may take, not what it will take (the least
    squares' ``--max-steps``): the lines then say "at most" instead of a percentage and "about".
    ``clock``: seconds, monotonic (tests pass their own).
    """

    def __init__(self, total: float, desc: str, *, unit: str = "step", initial: float = 0, enabled: bool = True,
                 stream=None, every_s: float | None = None, quiet_for_s: float | None = None,
                 upper_bound: bool = False, clock=time.monotonic):
        self.total, self.desc, self.unit = float(total), desc, unit
        self.done = float(initial)
        self.upper_bound = upper_bound
        self.enabled = enabled and total > 0
        self.stream = sys.stderr if stream is None else stream
        self.every_s = EVERY_S if every_s is None else every_s
        self.quiet_for_s = QUIET_FOR_S if quiet_for_s is None else quiet_for_s
        self._clock = clock
        self._start = clock()
        self._first: tuple[float, float] | None = None  # (time, steps done) at the first update
        self._last_line = self._start
        self._bar = None
        self._lock = threading.Lock()
        self._tty = bool(getattr(self.stream, "isatty", lambda: False)())

    def __enter__(self) -> Progress:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def eta_s(self) -> float | None:
        """Seconds left at the rate since the first update (``None`` until a step after it is done).
        The first step carries what a run does once, above all the compilation: 10 s or more where
        a least-squares step then takes 30 ms, so a rate that counted it made ``calibrate``'s first
        line say "about 12.3 h left" for a fit of a minute."""
        if self._first is None:
            return None
        t0, done0 = self._first
        made = self.done - done0
        if made <= 0:
            return None
        return (self._clock() - t0) / made * max(self.total - self.done, 0.0)

    def line(self) -> str:
        elapsed = self._clock() - self._start
        eta = self.eta_s()
        left = "" if eta is None else f", {'at most' if self.upper_bound else 'about'} {_duration(eta)} left"
        count = (f"{self.unit} {self.done:g} of at most {self.total:g}" if self.upper_bound else
                 f"{100 * self.done / self.total:.0f} % ({self.done:g}/{self.total:g} {self.unit}s)")
        return f"{self.desc}: {count}, {_duration(elapsed)} elapsed{left}"

    def set(self, done: float) -> None:
        """Set the steps done so far (for loops that count themselves)."""
        self.update(done - self.done)

    def update(self, n: float = 1) -> None:
        check_interrupt()
        if not self.enabled:
            self.done += n
            return
        with self._lock:
            self.done = min(self.done + n, self.total)
            now = self._clock()
            if self._first is None:
                self._first = (now, self.done)
            if now - self._start < self.quiet_for_s and self.done < self.total:
                return
            if self._tty:
                if self._bar is None:
                    from tqdm import tqdm

                    self._bar = tqdm(total=_count(self.total), initial=_count(self.done), desc=self.desc,
                                     unit=self.unit, file=self.stream, leave=False, dynamic_ncols=True)
                else:
                    self._bar.total = _count(self.total)
                    self._bar.update(_count(self.done) - self._bar.n)
            elif now - self._last_line >= self.every_s and now - self._start >= self.quiet_for_s:
                self._last_line = now
                print(self.line(), file=self.stream, flush=True)

    def close(self) -> None:
        if self._bar is not None:
            self._bar.close()
            self._bar = None


_current: Progress | None = None


class reporting:  # noqa: N801 - used as a context manager, like a function
    """Make ``progress`` the reporter of :func:`tick` while the ``with`` block runs: ``with
    reporting(Progress(1, "simulating", unit="chunk")): simulate(..., progress=True)``. The Monte
    Carlo ticks once per chunk of frames, from the host loop that runs the chunks (or from a host
    callback, :func:`chunk_done`, where the chunks run in one program); each tick sets the total."""

    def __init__(self, progress: Progress):
        self.progress = progress

    def __enter__(self) -> Progress:
        global _current
        self._previous, _current = _current, self.progress
        return self.progress

    def __exit__(self, *exc) -> None:
        global _current
        _current = self._previous
        self.progress.close()


def tick(total: int) -> None:
    """One more of ``total`` steps is done, for the reporter of :class:`reporting` (if any)."""
    check_interrupt()
    progress = _current
    if progress is not None:
        progress.total = float(total)
        progress.update(1)


def chunk_done(_dependency, total: int) -> None:
    """Host callback of a compiled loop (its first argument only orders it after the chunk)."""
    tick(total)


#: Compiling longer than this (seconds, summed over the programs) is announced by :func:`compiling`.
COMPILING_NOTICE_S = 2.0


class compiling:  # noqa: N801 - used as a context manager, like a function
    """Say ``compiling (first run; cached for next time) ...`` on standard error, once, when JAX
    has spent more than :data:`COMPILING_NOTICE_S` compiling during the block (a cold run spends
    most of its first seconds there, and would otherwise say nothing). It listens to JAX's own
    monitoring events: a persistent-cache miss starts a compilation, the backend's compile duration
    ends one; a thread looks every 0.1 s while one is under way (and after each one ends), and waits
    otherwise. ``enabled=False`` (``--quiet``) turns it off; ``stream``: default the standard error
    of the moment it speaks. Scripts and notebooks get it from :func:`compile_notice`."""

    def __init__(self, *, enabled: bool = True, stream=None, notice_s: float | None = None):
        self.enabled = enabled
        self.stream = stream
        self.notice_s = COMPILING_NOTICE_S if notice_s is None else notice_s
        self.announced = False
        self._spent = 0.0
        self._since: float | None = None
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._wake = threading.Event()  # a compilation started or ended, or the block ends

    def _event(self, event: str, **_kwargs) -> None:
        if event == "/jax/compilation_cache/cache_misses":
            with self._lock:
                self._since = time.monotonic()
                self._wake.set()

    def _duration(self, event: str, duration_s: float, **_kwargs) -> None:
        if event == "/jax/core/compile/backend_compile_duration":
            with self._lock:
                self._spent += duration_s
                self._since = None
                self._wake.set()

    def spent_s(self) -> float:
        """Seconds spent compiling so far (a compilation under way included)."""
        with self._lock:
            return self._spent + (time.monotonic() - self._since if self._since is not None else 0.0)

    def _watch(self) -> None:
        while True:
            self._wake.wait()
            if self._stop.is_set():
                return
            if self.spent_s() > self.notice_s:
                import jax

                cached = bool(jax.config.jax_compilation_cache_dir)
                print("compiling (first run; cached for next time) ..." if cached else
                      "compiling (the compilation cache is off) ...", file=self.stream or sys.stderr, flush=True)
                self.announced = True
                return
            with self._lock:
                if self._since is None:  # nothing under way: wait for the next compilation
                    self._wake.clear()
            self._stop.wait(0.1)

    def __enter__(self) -> compiling:
        if self.enabled:
            from jax import monitoring

            monitoring.register_event_listener(self._event)
            monitoring.register_event_duration_secs_listener(self._duration)
            self._thread = threading.Thread(target=self._watch, daemon=True, name="tofjax-compiling")
            self._thread.start()
        return self

    def __exit__(self, *exc) -> None:
        if self.enabled:
            from jax import monitoring

            self._stop.set()
            self._wake.set()
            self._thread.join()
            with contextlib.suppress(Exception):  # already unregistered: nothing to do
                monitoring.unregister_event_listener(self._event)
                monitoring.unregister_event_duration_listener(self._duration)


#: The notice of :func:`compile_notice` (``None``: off).
_notice: compiling | None = None


def compile_notice(enabled: bool = True, *, stream=None, notice_s: float | None = None) -> None:
    """For scripts and notebooks, what the commands say: ``compiling (first run; cached for next
    time) ...`` on standard error, once in this process, when JAX has spent more than
    :data:`COMPILING_NOTICE_S` compiling from now on (:class:`compiling`; a cold start of the README's
    frame snippet compiles for a minute and would otherwise say nothing).
    :func:`tofjax.enable_compilation_cache` turns it on; ``enabled=False`` turns it off."""
    global _notice
    if _notice is not None:
        _notice.__exit__(None, None, None)
        _notice = None
    if enabled:
        _notice = compiling(stream=stream, notice_s=notice_s).__enter__()


class Stages:
    """The named stages of a run (``render``: the ray cast, the two-bounce light, the frames, the
    analytic image, the writing), one line each on standard error, ``render: casting rays ...``.
    As with :class:`Progress`, a run shorter than :data:`QUIET_FOR_S` prints nothing: a stage is
    announced when it starts after that, or, if it started before, when the run reaches it (a
    thread waits for that moment). A context manager; calling it starts the next stage."""

    def __init__(self, desc: str, *, enabled: bool = True, stream=None, quiet_for_s: float | None = None,
                 clock=time.monotonic):
        self.desc, self.enabled = desc, enabled
        self.stream = sys.stderr if stream is None else stream
        self.quiet_for_s = QUIET_FOR_S if quiet_for_s is None else quiet_for_s
        self._clock = clock
        self._start = clock()
        self._current: str | None = None
        self._shown: str | None = None
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None

    def _show(self) -> None:  # with the lock held
        if self._current is not None and self._shown != self._current:
            elapsed = self._clock() - self._start
            print(f"{self.desc}: {self._current} ... ({_duration(elapsed)} elapsed)", file=self.stream, flush=True)
            self._shown = self._current

    def __call__(self, label: str) -> None:
        check_interrupt()
        if not self.enabled:
            return
        with self._lock:
            self._current = label
            if self._clock() - self._start >= self.quiet_for_s:
                self._show()

    def _watch(self) -> None:
        if not self._stop.wait(max(self.quiet_for_s - (self._clock() - self._start), 0.0)):
            with self._lock:
                self._show()

    def __enter__(self) -> Stages:
        if self.enabled:
            self._thread = threading.Thread(target=self._watch, daemon=True, name="tofjax-stages")
            self._thread.start()
        return self

    def __exit__(self, *exc) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join()
