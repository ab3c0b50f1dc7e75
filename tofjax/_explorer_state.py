"""The explorer without its widgets: the configuration being edited and its validation, the last run
and whether the settings still match it, and the files it writes, in one folder, never replacing one
without a confirmation (docs/model.md, "The GUI"). :class:`tofjax._explorer.Explorer` is its view:
widgets that show this state and call its methods; a test or a script can drive it headlessly.

Every outcome is a :class:`Message` (its text plain; the view escapes and colours it), and nothing
here imports ipywidgets.
"""

from __future__ import annotations

import copy
import os
import re
from collections.abc import Callable
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np

from . import plots
from ._config import Config, config_from_dict, load_config
from ._run import run_sweep, sweep_file_contents
from ._schema import ConfigError, Key
from .outputs import OutputDir, OutputError, check_output, name_problem, save_figure, shown_path, write_text
from .report import Summary

#: The resolution of saved PNGs.
SAVE_DPI = 150


class Message(NamedTuple):
    """What an action did (``error``: or why it could not)."""

    text: str
    error: bool = False


def file_stem(variable: str, name: str) -> str:
    """A saved plot's file name without its suffix: the run's sweep variable and the plot."""
    return f"{variable}_{name}"


def save_png(path: Path, fig) -> None:
    save_figure(fig, path, dpi=SAVE_DPI)


def names_key(text: str, dotted: str) -> bool:
    """Whether ``text`` names the key ``dotted`` (whole: not ``pixel.v_reset_v_x`` or ``a.pixel...``)."""
    return re.search(rf"(?<![\w.]){re.escape(dotted)}(?!\w)", text) is not None


class ExplorerState:
    """The explorer's state (module docstring).

    **Attributes:** ``folder`` (the only folder it reads and writes in), ``config`` (the last valid
    configuration), ``error`` (the current validation message or ``None``), ``changed`` (sections
    edited since the last valid configuration), ``run`` (the last :class:`tofjax._run.Run`),
    ``figures`` (plot name -> Figure of the last run), ``headlines`` (its headline numbers),
    ``pending`` (``(targets, action)`` waiting for the user's confirmation to overwrite).
    """

    def __init__(self, config: Config | str | os.PathLike | None = None, *, folder: str | os.PathLike | None = None):
        self.folder = Path(os.getcwd() if folder is None else folder).expanduser().resolve()
        if not self.folder.is_dir():
            raise ValueError(f"folder = {str(self.folder)!r} is not a directory: the explorer reads and writes files "
                             "only in an existing folder")
        if config is None:
            config = Config()
        elif not isinstance(config, Config):
            config = load_config(config)
        self.run = None
        self.figures: dict = {}
        self.headlines: dict = {}
        self.pending: tuple[list[Path], Callable] | None = None
        self.replace(config)

    # --- editing ------------------------------------------------------------------------------
    def replace(self, config: Config) -> None:
        """Make ``config`` the configuration being edited (a load, a reset)."""
        self.config = config
        self.raw = copy.deepcopy({s: dict(t) for s, t in config.values.items()})
        self.error: str | None = None
        self.unparsed: dict[str, str] = {}
        self.changed: set[str] = set()

    def edit(self, key: Key, read: Callable[[], Any]) -> str | None:
        """Take one key's new value (``read()``, which raises :class:`ConfigError` for text that is
        not a value at all: remembered until fixed) and re-validate the whole configuration; returns
        the validation message, or ``None`` when it is valid (then :attr:`config` is the new one)."""
        self.changed.add(key.section)
        try:
            self.raw[key.section][key.name] = read()
            self.unparsed.pop(key.dotted, None)
        except ConfigError as err:
            self.unparsed[key.dotted] = str(err)
        try:
            if self.unparsed:
                raise ConfigError(next(iter(self.unparsed.values())))
            self.config = config_from_dict(self.raw)
        except ConfigError as err:
            self.error = str(err)
            return self.error
        self.error = None
        return None

    def take_changed(self) -> set[str]:
        """The sections edited since the last call (what the previews must redraw)."""
        changed, self.changed = self.changed, set()
        return changed

    def stale(self, sweep: str, method: str, seed: int) -> bool:
        """Whether the last run differs from what Calculate would run now."""
        run = self.run
        return run is not None and (self.error is not None or run.config.values != self.config.values
                                    or run.sweep.variable != sweep or run.method != method
                                    or (run.method == "mc" and run.seed != seed))

    # --- runs ---------------------------------------------------------------------------------
    def check_calculate(self, busy: bool, seed: int) -> Message | None:
        """Why Calculate cannot run now, or ``None``."""
        if busy:
            return Message("a run is going: wait for it or press Cancel", True)
        if self.error is not None:
            return Message(f"cannot calculate: {self.error}", True)
        if seed < 0:
            return Message(f"seed = {seed} is out of range: allowed integer >= 0", True)
        return None

    def compute(self, config: Config, sweep, method: str, seed: int, names: list[str], overlay: bool):
        """The run, its figures (the previous run's curves of the same sweep grey behind them with
        ``overlay``) and headline numbers; changes nothing (:meth:`accept` keeps them)."""
        from .report import headlines

        run = run_sweep(config, sweep, method, seed=seed, keep_frames=200, progress=method == "mc")
        figures = draw(run, names)
        previous = self.run
        if overlay and previous is not None and previous.sweep.variable == sweep.variable:
            for name, fig in figures.items():
                if name in self.figures:
                    plots.overlay(fig, self.figures[name])
        return run, figures, headlines(config.params, run.result)

    def accept(self, run, figures: dict, numbers: dict) -> None:
        self.run, self.figures, self.headlines = run, figures, numbers

    # --- frames (the Frame tab) -------------------------------------------------------------------
    def frame(self, config: Config, scene: str, frames: int, seed: int) -> tuple[dict, str] | Message:
        """A frame of ``scene`` (``wall``, ``step_edge:near_m=1,far_m=1.6``, or an NPZ file in
        :attr:`folder`: a depth map or returns) on ``config``'s camera, as ``tofjax render`` makes
        it: the analytic frame, and ``frames`` Monte Carlo frames beside it when ``frames`` > 0
        (their chunks reported to :mod:`tofjax.progress`, which may cancel them). Returns the
        frame's arrays (:func:`tofjax.frameio.frame_arrays`) and its headline text, or a
        :class:`Message` saying why not."""
        import jax

        from . import frameio
        from ._camera import Camera
        from ._framescene import check_size, load_npz_scene, parse_scene
        from .optics import frame_shape

        if self.error is not None:
            return Message(f"cannot render: {self.error}", True)
        if isinstance(frames, bool) or not isinstance(frames, int) or not 0 <= frames <= 10_000:
            return Message(f"frames = {frames!r} is out of range: allowed integer 0 <= value <= 10000", True)
        if seed < 0:
            return Message(f"seed = {seed} is out of range: allowed integer >= 0", True)
        text = scene.strip()
        if text.lower().endswith(".npz"):
            path = self.resolve(text)
            if isinstance(path, Message):
                return path
            text = str(path)
        try:
            builder, name, kwargs = parse_scene(text, option="scene")
            params, settings = config.params, config.frame
            camera = Camera.from_config(config)
            prepared = camera.prepare()  # first: its own errors before any ray cast
            geometry = None if builder is None else builder(**kwargs)
            room = check_size(name, geometry, settings, frame_shape(params))  # the memory a frame needs
            returns = (load_npz_scene(name, params, settings, room, option="scene") if geometry is None
                       else camera.returns(geometry))
            exposed = prepared.prepare(returns)
            predicted = exposed.predict()
            result = exposed.render(jax.random.key(seed), frames, progress=True) if frames else predicted
        except ValueError as err:
            return Message(str(err).strip().splitlines()[0], True)
        arrays = frameio.frame_arrays(result, predicted)
        return arrays, frameio.headline_text(frameio.headlines(arrays), monte_carlo=frames > 0)

    # --- files --------------------------------------------------------------------------------
    def resolve(self, text: str) -> Path | Message:
        """The file ``text`` names inside :attr:`folder` (relative, or absolute inside it), or why not:
        a path outside it, a folder (the folder itself, ``.``, would put the plots and the report
        beside it, in its parent), or a name the file system cannot hold."""
        text = text.strip()
        if not text:
            return Message("give a file name in the path box", True)
        target = Path(text).expanduser()
        target = target if target.is_absolute() else self.folder / target
        problem = name_problem(target)
        if problem:
            return Message(f"{shown_path(text)}: {problem}; choose a shorter name", True)
        target = target.resolve()
        if target != self.folder and self.folder not in target.parents:
            return Message(f"{text}: the explorer reads and writes files only in {self.folder} (its folder, chosen "
                           "when it started)", True)
        if target.is_dir():
            return Message(f"{text}: is a folder, not a file: give the name of a file in {self.folder} (e.g. "
                           "camera.toml)", True)
        return target

    def unless_overwriting(self, targets: list[Path], action: Callable, overwrite: bool) -> Message | None:
        """``None`` if ``action`` may write ``targets`` now (none exists, or ``overwrite`` was
        confirmed for them); else it waits in :attr:`pending` and the message says so."""
        existing = [p for p in targets if p.exists()]
        if existing and not (overwrite and self.pending is not None and self.pending[0] == targets):
            self.pending = (targets, action)
            shown = existing[0].name + (f" and {len(existing) - 1} more" if len(existing) > 1 else "")
            one = len(existing) == 1
            return Message(f"{shown} exist{'s' if one else ''}: press Overwrite to replace {'it' if one else 'them'}, "
                           "or change the file name", True)
        self.pending = None
        return None

    def confirm(self):
        """Run the action that waits for the Overwrite confirmation."""
        return self.pending[1](overwrite=True) if self.pending is not None else None

    def load(self, text: str) -> tuple[Config | None, Message]:
        """The configuration of the TOML file ``text`` names and what was loaded, or ``None`` and why not."""
        path = self.resolve(text)
        if isinstance(path, Message):
            return None, path
        try:
            return load_config(path), Message(f"loaded {path}")
        except ConfigError as err:
            return None, Message(str(err), True)

    def save(self, text: str, overwrite: bool, again: Callable) -> Message | None:
        """Write the configuration as commented TOML; ``None`` while it waits for Overwrite
        (``again(overwrite=True)`` then runs)."""
        path = self.resolve(text)
        if isinstance(path, Message):
            return path
        if self.error is not None:
            return Message(f"not saved: fix the invalid value first ({self.error})", True)
        waiting = self.unless_overwriting([path], again, overwrite)
        if waiting is not None:
            return waiting
        try:
            write_text(path, self.config.to_toml())
        except (OSError, OutputError) as err:
            return Message(f"cannot write {path}: {getattr(err, 'strerror', None) or err}", True)
        return Message(f"saved {path}")

    def write_plots(self, text: str, names: list[str], suffix: str, write, overwrite: bool,
                    again: Callable) -> tuple[list[Path] | None, Message]:
        """One file per plot of ``names`` beside the TOML file ``text`` names, with ``write(path,
        figure)``, asking before any existing one is replaced."""
        missing = [n for n in names if n not in self.figures]
        if missing:
            return None, Message(f"no plot {missing[0]!r} in the last run: Calculate with it ticked", True)
        path = self.resolve(text)
        if isinstance(path, Message):
            return None, path
        targets = [path.parent / f"{file_stem(self.run.sweep.variable, name)}.{suffix}" for name in names]
        waiting = self.unless_overwriting(targets, again, overwrite)
        if waiting is not None:
            return None, waiting
        written = []
        for name, target in zip(names, targets, strict=True):
            try:
                write(target, self.figures[name])
            except (OSError, OutputError) as err:
                return None, Message(f"cannot write {target}: {getattr(err, 'strerror', None) or err}", True)
            written.append(target)
        return written, Message(f"saved {written[0]}" if len(written) == 1
                                else f"saved {len(written)} figures into {written[0].parent}")

    def write_report(self, text: str, overwrite: bool, again: Callable) -> tuple[Path | None, Message]:
        """The last run's tofjax-sweep CSV and HTML report in ``report_<sweep>/`` beside the TOML
        file ``text`` names (the folder replaced as a whole, once confirmed)."""
        if self.run is None:
            return None, Message("no run yet: Calculate first", True)
        from .report import write_report
        from .sweepfile import write_sweep

        path = self.resolve(text)
        if isinstance(path, Message):
            return None, path
        run, folder = self.run, path.parent / f"report_{self.run.sweep.variable}"
        waiting = self.unless_overwriting([folder], again, overwrite)
        if waiting is not None:
            return None, waiting
        try:
            check_output(folder, "report", overwrite=True, directory=True)  # never over files tofjax did not write
            with OutputDir(folder, "the tofjax explorer", replace=True) as out:
                metadata, columns = sweep_file_contents(run, "(the explorer)")
                write_sweep(out.file("sweep.csv"), metadata, columns)
                write_report(out.staging, run.config, run.result, run.elapsed_s, folder / "sweep.csv",
                             multifrequency=run.multifrequency)
        except (OSError, OutputError) as err:
            return None, Message(f"cannot write into {folder}: {getattr(err, 'strerror', None) or err}", True)
        return folder / "report.html", Message(f"wrote {folder / 'report.html'} and sweep.csv")


def draw(run, names: list[str]) -> dict:
    """The figures of plots ``names`` of a run, titled (and the multi-frequency distance where it applies)."""
    figures = {}
    for name in names:
        func, _, ref = plots.PLOTS[name]
        figures[name] = func(run.result)
        figures[name].suptitle(f"{name.replace('_', ' ')} ({ref})", fontsize=10)
    if run.multifrequency is not None and run.sweep.variable == "distance":
        fig = plots.multifrequency_distance(run.multifrequency)
        if not fig.get_suptitle():
            fig.suptitle("several modulation frequencies: unwrapped distance (§2.2)", fontsize=10)
        figures["multifrequency_distance"] = fig
    return figures


def summary(run, numbers: dict) -> Summary:
    """A run's summary: its samples and noise range, ranges, and the headline numbers."""
    r = run.result
    valid = np.asarray(r.valid_fraction)
    std = np.asarray(r.depth_std_m if run.multifrequency is None else run.multifrequency.depth_std_m)
    kind = f"Monte Carlo, {r.n_frames} frames per sample" if r.method == "mc" else "analytic"
    noise = (f"depth noise {1e3 * np.nanmin(std):.3g}-{1e3 * np.nanmax(std):.3g} mm"
             if np.any(np.isfinite(std)) else "no valid sample")
    if run.multifrequency is not None:
        freqs = run.config.modulation_frequencies_hz
        ranges = f"extended range {float(run.multifrequency.extended_range_m):.4g} m " \
                 f"({len(freqs)} frequencies, {run.multifrequency.fusion} fusion; unambiguity range of the first " \
                 f"{float(r.unambiguity_range_m):.4g} m)"
    else:
        ranges = f"unambiguity range {float(r.unambiguity_range_m):.4g} m"
    lines = [f"{len(valid)} samples ({kind}); {noise}; {np.mean(valid == 1):.0%} of the samples fully valid; "
             f"{ranges}"]
    from .report import headline_figure

    n = numbers

    def at(key, unit):  # the figure and where it comes from (this sweep, or an analytic scan)
        value, source = headline_figure(n, key, unit, digits=3)
        return f"{value} ({source})"

    lines.append(
        f"at the nominal point ({n['nominal_distance_m']:.3g} m, {n['nominal_illuminance_lx']:.3g} lx, "
        f"{1e3 * n['nominal_integration_time_s']:.3g} ms, {n['nominal_temperature_c']:.3g} °C; analytic): depth noise "
        f"{1e3 * n['nominal_depth_std_m']:.3g} mm ({100 * n['nominal_relative_depth_std']:.2g} %), amplitude "
        f"{n['nominal_amplitude_lsb']:.4g} LSB.")
    lines.append(f"Valid from: {at('valid_from_m', 'm')}; 1 % depth noise at: {at('relative_noise_1pct_at_m', 'm')}; "
                 f"2 % at: {at('relative_noise_2pct_at_m', 'm')}.")
    lines.append(f"SBI engages at: {at('sbi_engages_at_lx', 'lx')}; the pixel saturates at: "
                 f"{at('pixel_saturates_at_lx', 'lx')}.")
    from ._camera import Camera
    from ._timing import summary_lines

    try:
        lines.extend(summary_lines(Camera.from_config(run.config)))  # the frame's timing and eye safety
    except ValueError as err:  # a frame rate the phase images do not fit: said, not raised
        lines.append(str(err))
    return Summary("explorer", lines)
