"""The interactive explorer: the thesis' GUI (§4.3, Figs 4.8-4.11) as an ipywidgets app.

Four tabs as in the thesis: **Main** (background light, the nominal distance, illuminance and
integration time, sweep with from/to/samples/iterations, method, plot choice, Calculate and Cancel
with a progress bar, a ready/busy lamp and the simulation time, the messages, TOML load/save/reset,
the result's headline numbers, its plots (zoomable with ipympl, each with "save PNG" and "export
CSV", the previous run of the same sweep grey behind), "save figures" and "write report"),
**Pixel** (pixel, illumination and reference waveforms, with live previews of the waveforms and of
the phase images' correlation functions),
**Scene & Camera** (illumination unit, scene, camera, with a live FoV preview and the derived lens),
**Physical & ADC** (physical constants, read-only, and the ADC) and **Processing** (the camera's
own depth processing: calibration, filters, invalidation; not in the thesis' GUI).

Every configuration key of the schema has one input with its unit and allowed range next to it.
Each change re-validates the whole configuration (:func:`tofjax.config_from_dict`): an invalid
value shows the validation message beside Calculate and at the field (highlighted), disables
Calculate instead of raising, and the explorer keeps the last valid configuration; the previews
say that they show it. A preview is drawn when its tab is shown (an edit on another tab costs
nothing). A run goes in a background thread (the kernel stays responsive): one run at a time, its
progress per chunk of frames, cancellable between chunks. Plots and summary of a run are marked
stale as soon as the settings differ from the run's.

The explorer is a state and a view. :class:`tofjax._explorer_state.ExplorerState` holds what does not
need widgets (the configuration being edited and its validation, the last run and whether it is
stale, the files written in one folder after a confirmation); :class:`Explorer`, here, is the view:
the widgets, their layout and reactions, the previews, the background thread of a run. The logic
lives in modules, not in a notebook, so that the tests can drive it headlessly: set widget values,
press buttons with ``.click()`` (Calculate's button runs in the background: :meth:`wait`), read
:attr:`config`, :attr:`preview`, :attr:`figures` and :attr:`message`.
"""

from __future__ import annotations

import html
import logging
import os
import re
import threading
import warnings
from pathlib import Path
from typing import Any

import numpy as np

try:
    import ipywidgets as w
except ImportError as err:  # pragma: no cover - exercised only without the extra
    raise ImportError('the explorer needs ipywidgets: pip install "tofjax[notebooks]"') from err

from . import frameio, plots
from . import progress as _progress
from ._config import Config
from ._explorer_state import ExplorerState, Message, file_stem, names_key, save_png, summary
from ._optics import lens, spot_area_m2
from ._params import PhysicalConstants
from ._scene import BUILTIN_SCENES
from ._schema import KEYS, SWEEP_AXES, ConfigError, Key, keys_of
from .outputs import write_text

#: Sweep choices as the thesis' GUI names them (§4.3).
SWEEP_CHOICES = tuple((axis.title, name) for name, axis in SWEEP_AXES.items())
#: The configured sweeps' ranges, per sweep: ``scene.<start key>``, ``scene.<end key>``.
_RANGE_KEYS = {name: tuple(f"scene.{k}" for k in axis.range_keys) for name, axis in SWEEP_AXES.items()}
#: Plots ticked when the explorer opens.
DEFAULT_PLOTS = ("depth_noise", "amplitude", "photon_transfer_curve")

#: The operating point the sweeps vary one quantity of (thesis Fig 4.8: on the Main tab).
_NOMINAL_KEYS = tuple(axis.key for axis in SWEEP_AXES.values())
_MAIN_KEYS = ("scene.background", *_NOMINAL_KEYS, "scene.samples", "pixel.iterations",
              *(k for pair in _RANGE_KEYS.values() for k in pair))
_TAB_SECTIONS = {
    "Pixel": ("pixel", "illumination_waveform", "reference_waveform"),
    "Scene & Camera": ("illumination", "scene", "camera", "timing", "interference", "frame"),
    "Physical & ADC": ("adc",),
    "Processing": ("processing",),
}
_CONSTANT_UNITS = {"boltzmann_j_per_k": "J/K", "elementary_charge_c": "C", "speed_of_light_m_per_s": "m/s",
                   "planck_j_s": "J s", "luminous_efficacy_lm_per_w": "lm/W"}
_DESCRIPTION = {"description_width": "210px"}


def _wide() -> w.Layout:  # a new Layout per widget: a shared one would hide/show them all together
    return w.Layout(width="380px")


def _narrow() -> w.Layout:
    return w.Layout(width="170px")

_READY = '<span style="color:#2a2">&#9679;</span> ready'
_BUSY = '<span style="color:#d22">&#9679;</span> busy'
_INVALID = '<span style="color:#c80">&#9679;</span> invalid settings'
#: The pixels per inch the plots are drawn at and shown at (no scaling: sharp).
_PLOT_DPI = 96
#: The style of the stale run's class.
_STYLE = "<style>.tofjax-stale{opacity:0.4}</style>"
#: The outline of a field whose value is invalid.
_INVALID_BORDER = "2px solid #cc0000"
_STALE = ("<b style='color:#c60'>&#9888; stale</b>: the settings changed after this run; the summary and "
          "the plots below are of the previous settings. Calculate to update them.")


def _plain(markup: str) -> str:
    """An HTML widget's value as text: ``<br>`` a new line, tags dropped, entities read (what a
    script prints: ``print(ex.message.value)`` showed ``<span style=...>`` and ``&#x27;``)."""
    return html.unescape(re.sub(r"<[^>]*>", "", markup.replace("<br>", "\n")))


def _error_html(text: str) -> str:
    return f'<span style="color:#c00">{html.escape(text)}</span>'


def _shown(value: Any) -> Any:
    """A value as the field shows it: floats (also in lists) at 12 significant digits (0.00301, not
    0.0030099999999999997); anything else as it is."""
    if isinstance(value, list | tuple):
        return [_shown(v) for v in value]
    if isinstance(value, float) and np.isfinite(value):
        return float(f"{value:.12g}")
    return value


#: Preview name -> (its tab, its drawing, the sections whose changes redraw it, its image widget, the
#: scale it is shown at: the Pixel tab's beside the fields at 1280 px). The correlation follows the
#: phase count (pixel) and marks the nominal distance (scene).
_PREVIEWS = {
    "waveforms": ("Pixel", plots.waveforms, {"illumination", "illumination_waveform", "reference_waveform"},
                  "waveform_image", 0.8),
    "correlation": ("Pixel", plots.correlation_function, {"pixel", "scene", "illumination_waveform", "reference_waveform"},
                    "correlation_image", 0.8),
    "fov": ("Scene & Camera", plots.fov_footprint, {"illumination", "scene"}, "fov_image", 0.62),
}


def _range(key: Key) -> str:
    """The allowed range beside a field, short where the input shows the form (the dropdown its
    choices, the diagonal / h x v switch the angle's shape): the rows stay narrow enough for the
    previews beside them."""
    text = key.range_text()
    if key.kind == "choice":
        return "choose from the list"
    if key.kind in ("angle", "float_list"):
        return "each " + text.rsplit("each ", 1)[-1] + (", comma-separated" if key.kind == "float_list" else "")
    return text


class _Cancelled(Exception):
    """Raised in the Monte Carlo's progress callback when Cancel was pressed: ends the run."""


class _RunProgress:
    """The reporter of a run (:func:`tofjax.progress.reporting`): moves the bar per chunk of frames
    and ends the run (:class:`_Cancelled`) between chunks once ``cancel`` is set."""

    def __init__(self, bar, cancel: threading.Event):
        self.bar, self.cancel = bar, cancel
        self.total, self.done = 1.0, 0.0

    def update(self, n: float = 1) -> None:
        self.done += n
        self.bar.max = max(self.total, 1.0)
        self.bar.value = min(self.done, self.total)
        self.bar.description = f"{100 * self.done / max(self.total, 1.0):.0f} %"
        if self.cancel.is_set():
            raise _Cancelled

    def close(self) -> None:
        pass


class _QuietCallbackErrors(logging.Filter):
    """JAX logs the traceback of a failed host callback; a cancel is not a failure."""

    def filter(self, record: logging.LogRecord) -> bool:
        return "callback failed" not in record.getMessage()


class _Field:
    """The input(s) of one configuration key, with its unit and allowed range beside them."""

    def __init__(self, key: Key, value: Any, on_change):
        self.key = key
        value = _shown(value)
        common = dict(description=key.name, style=_DESCRIPTION, tooltip=key.doc)
        self.mode = None
        if key.kind == "float":
            self.inputs = [w.FloatText(value=value, layout=_wide(), **common)]
        elif key.kind == "int":
            self.inputs = [w.IntText(value=value, layout=_wide(), **common)]
        elif key.kind == "bool":
            self.inputs = [w.Checkbox(value=value, indent=True, **common)]
        elif key.kind == "choice":
            self.inputs = [w.Dropdown(options=key.choices, value=value, layout=_wide(), **common)]
        elif key.kind == "float_list":
            self.inputs = [w.Text(value=", ".join(repr(v) for v in value), placeholder="empty, or e.g. 60.24e6",
                                  layout=_wide(), **common)]
        elif key.kind == "choice_list":
            self.inputs = [w.Text(value=", ".join(value), placeholder="empty, or e.g. led", layout=_wide(), **common)]
        elif key.kind == "pair":
            self.inputs = [w.FloatText(value=value[0], layout=_wide(), **{**common, "description": key.name + " x"}),
                           w.FloatText(value=value[1], layout=_narrow(), description="y", style={"description_width": "15px"})]
        else:  # angle: diagonal (one number) or [horizontal, vertical], the thesis' switch (§4.3)
            first, second = (value, value) if np.ndim(value) == 0 else value
            self.mode = w.ToggleButtons(options=[("diagonal", "diagonal"), ("h x v", "hv")],
                                        value="diagonal" if np.ndim(value) == 0 else "hv",
                                        description=key.name, style={**_DESCRIPTION, "button_width": "80px"},
                                        tooltip=key.doc)
            self.inputs = [self.mode, w.FloatText(value=first, layout=_narrow()),
                           w.FloatText(value=second, layout=_narrow())]
            self.mode.observe(lambda _change: self._show_second(), names="value")
            self._show_second()
        self._range_note = f"<small style='white-space:nowrap'>[{html.escape(key.unit)}] {html.escape(_range(key))}</small>"
        self.note = w.HTML(self._range_note, layout=w.Layout(flex="0 0 auto"))
        self.box = w.HBox([*self.inputs, self.note])
        self.box.add_class(f"tofjax-key-{key.section}-{key.name}")  # for a browser test's selectors
        for widget in self.inputs:
            widget.observe(lambda _change: on_change(self), names="value")

    def _show_second(self) -> None:
        # Hidden, not removed: switching diagonal / h x v does not move the layout.
        self.inputs[2].layout.visibility = None if self.mode.value == "hv" else "hidden"

    def show_error(self, text: str | None) -> None:
        """The message at the field (highlighted), or its unit and range again (``None``)."""
        # The outline is the row's layout (ipywidgets' own styling: a <style> rule in an HTML widget
        # does not reach the inputs in Voila); the class is for selectors.
        if text is None:
            self.note.value = self._range_note
            self.box.remove_class("tofjax-invalid")
            self.box.layout.border = None
        else:
            self.note.value = (f"<small style='color:#c00;white-space:normal'>&#9888; {html.escape(text)}</small>"
                               f"<br>{self._range_note}")
            self.box.add_class("tofjax-invalid")
            self.box.layout.border = _INVALID_BORDER

    def value(self) -> Any:
        """The value the inputs hold, in configuration form; :class:`ConfigError` if text does not parse."""
        if self.key.kind == "choice_list":  # names, checked by the schema
            return [part.strip().strip("'\"") for part in self.inputs[0].value.strip("[] ").split(",") if part.strip()]
        if self.key.kind == "float_list":
            text = self.inputs[0].value.strip().strip("[]")
            try:
                return [float(part) for part in text.replace(";", ",").split(",") if part.strip()]
            except ValueError:
                raise ConfigError(f"{self.key.dotted} = {self.inputs[0].value!r} is not a list of numbers: expected "
                                  f"{self.key.range_text()} [{self.key.unit}], separated by commas") from None
        if self.key.kind == "pair":
            return [self.inputs[0].value, self.inputs[1].value]
        if self.key.kind == "angle":
            a, b = self.inputs[1].value, self.inputs[2].value
            return a if self.mode.value == "diagonal" else [a, b]
        return self.inputs[0].value

    def set_value(self, value: Any) -> None:
        if self.key.kind == "choice_list":
            self.inputs[0].value = ", ".join(value)
        elif self.key.kind == "float_list":
            self.inputs[0].value = ", ".join(repr(v) for v in _shown(value))
        elif self.key.kind == "pair":
            self.inputs[0].value, self.inputs[1].value = _shown(value)
        elif self.key.kind == "angle":
            diagonal = np.ndim(value) == 0
            self.mode.value = "diagonal" if diagonal else "hv"
            self.inputs[1].value, self.inputs[2].value = _shown([value, value] if diagonal else value)
            self._show_second()
        else:
            self.inputs[0].value = _shown(value)


class Explorer:
    """The interactive explorer (module docstring). Display it in Jupyter as the last expression
    of a cell; :attr:`widget` is the top-level ipywidgets container.

    **Arguments:**
    - ``config``: a :class:`tofjax.Config`, a path to a TOML configuration, or ``None`` (defaults).
    - ``folder``: the only folder the explorer reads and writes files in (default: the working
      directory when it starts, the notebook's folder). The path box names a file in it (relative,
      or absolute inside it); nothing outside it is read or written, so an explorer served with
      Voila writes only there. Every file is written atomically, and one that exists is replaced
      only after the Overwrite button (TOML, PNG, CSV and the report folder alike).

    **Attributes** (for scripting and tests):
    - ``state``: the :class:`tofjax._explorer_state.ExplorerState` this view shows; ``config``,
      ``error``, ``run``, ``figures``, ``headlines`` and ``folder`` are its.
    - ``config``: the last valid configuration; ``error``: the current validation message or ``None``.
    - ``fields``: dotted key -> its input (every key of the schema).
    - ``sweep``, ``method``, ``seed``, ``plot_checkboxes``, ``calculate_button``, ``cancel_button``,
      ``progress``, ``load_button``, ``save_button``, ``reset_button``, ``path``: the Main tab's
      controls; ``lamp`` and ``time_label`` show ready/busy and the simulation time; ``message``
      (beside Calculate) says what the last action did or why it could not.
    - ``preview``: the live preview figures (``"waveforms"``, ``"correlation"``, ``"fov"``) and
      derived numbers; a preview is drawn when its tab is shown or ``preview`` is read.
    - ``run``: the last :class:`tofjax._run.Run`; ``figures``: plot name -> Figure of the last run;
      ``headlines``: its headline numbers (:func:`tofjax.report.headlines`); ``busy``: a run is going;
      ``stale``: the settings differ from the last run's.
    """

    def __init__(self, config: Config | str | os.PathLike | None = None, *, folder: str | os.PathLike | None = None):
        self.state = ExplorerState(config, folder=folder)
        self._quiet = False
        self._preview: dict = {}
        self._dirty: set[str] = set()  # previews to redraw once their tab is shown (or read)
        self.busy = False
        self.stale = False
        self._cancel = threading.Event()
        self._thread: threading.Thread | None = None
        self.fields = {k.dotted: _Field(k, self.state.raw[k.section][k.name], self._changed) for k in KEYS}

        self.sweep = w.Dropdown(options=SWEEP_CHOICES, value="distance", description="sweep", style=_DESCRIPTION,
                                layout=_wide())
        self.method = w.ToggleButtons(options=[("Monte Carlo", "mc"), ("analytic", "analytic")], value="mc",
                                      description="method", style=_DESCRIPTION,
                                      tooltip="analytic: propagated variances, ~40x faster; Monte Carlo: frames")
        self.seed = w.IntText(value=0, description="seed", style=_DESCRIPTION, layout=_wide())
        self.plot_checkboxes = {
            name: w.Checkbox(value=name in DEFAULT_PLOTS, description=f"{name.replace('_', ' ')} ({ref})",
                             indent=False, layout=w.Layout(width="auto"))
            for name, (_, _, ref) in plots.PLOTS.items()
        }
        self.calculate_button = w.Button(description="Calculate", button_style="primary", icon="play")
        self.cancel_button = w.Button(description="Cancel", icon="stop", disabled=True,
                                      tooltip="stop the run after its current chunk of frames")
        self.progress = w.FloatProgress(value=0.0, min=0.0, max=1.0, description="", bar_style="info",
                                        layout=w.Layout(width="220px", visibility="hidden"))
        self.lamp = w.HTML(_READY)
        self.time_label = w.HTML("")
        self.message = w.HTML("", layout=w.Layout(min_height="1.6em"))
        self.path = w.Text(value="camera.toml", description="TOML file", style={"description_width": "70px"},
                           layout=w.Layout(width="520px"))
        self.load_button = w.Button(description="Load", icon="folder-open")
        self.save_button = w.Button(description="Save", icon="save")
        self.overwrite_button = w.Button(description="Overwrite", button_style="warning",
                                         layout=w.Layout(display="none"))
        self.reset_button = w.Button(description="Reset to defaults", icon="undo")
        self.figures_button = w.Button(description="Save figures", icon="image", disabled=True,
                                       tooltip="the plots of the last run as PNG files, into the folder of the TOML file")
        self.report_button = w.Button(description="Write report", icon="file", disabled=True,
                                      tooltip="the run's tofjax-sweep CSV, the report's plots and report.html, "
                                              "into a report_<sweep> folder beside the TOML file")
        self.overlay = w.Checkbox(value=True, description="overlay the previous run (grey)", indent=False,
                                  tooltip="draw the previous run's curves of the same sweep grey behind the new ones")
        self.stale_note = w.HTML("")
        self.summary = w.HTML("")
        self.plots_box = w.GridBox([], layout=w.Layout(grid_template_columns="repeat(auto-fill, minmax(620px, 1fr))",
                                                        grid_gap="8px"))
        self.waveform_image = w.Image(format="png")
        self.correlation_image = w.Image(format="png")
        self.fov_image = w.Image(format="png")
        self.derived = w.HTML("")
        self._tab_notes: list = []
        # The Frame tab: a scene's frame, as tofjax render makes it.
        self.frame_scene = w.Text(value="step_edge:near_m=1,far_m=1.6,edge_x_m=0.013", description="scene",
                                  style=_DESCRIPTION,
                                  layout=w.Layout(width="520px"))
        self.frame_frames = w.IntText(value=20, description="Monte Carlo frames", style=_DESCRIPTION, layout=_wide())
        self.frame_noise_button = w.Button(description="Noise image", icon="image", button_style="primary",
                                           tooltip="the analytic frame: distance, error, expected noise, amplitude, "
                                                   "flags (immediate)")
        self.frame_mc_button = w.Button(description="Monte Carlo frames", icon="play",
                                        tooltip="that many noisy frames and their statistics (Cancel stops them)")
        self.frame_cancel_button = w.Button(description="Cancel frames", icon="stop", disabled=True)
        self.frame_progress = w.FloatProgress(value=0.0, min=0.0, max=1.0, bar_style="info",
                                              layout=w.Layout(width="220px", visibility="hidden"))
        self.frame_message = w.HTML("", layout=w.Layout(min_height="1.6em"))
        self.frame_summary = w.HTML("")
        self.frame_image = w.Image(format="png")
        self.frame_arrays: dict | None = None

        self.sweep.observe(lambda _c: (self._sweep_changed(), self._refresh_stale()), names="value")
        for control in (self.method, self.seed):
            control.observe(lambda _c: self._refresh_stale(), names="value")
        self.calculate_button.on_click(lambda _b: self.calculate(wait=False))
        self.cancel_button.on_click(lambda _b: self.cancel())
        self.load_button.on_click(lambda _b: self.load())
        self.save_button.on_click(lambda _b: self.save())
        self.overwrite_button.on_click(lambda _b: self._confirm())
        self.reset_button.on_click(lambda _b: self.reset())
        self.figures_button.on_click(lambda _b: self.save_figures())
        self.report_button.on_click(lambda _b: self.write_report())
        self.path.observe(lambda _c: self._hide_overwrite(), names="value")
        self.frame_noise_button.on_click(lambda _b: self.render_frame(monte_carlo=False, wait=False))
        self.frame_mc_button.on_click(lambda _b: self.render_frame(monte_carlo=True, wait=False))
        self.frame_cancel_button.on_click(lambda _b: self.cancel())

        for widget, name in ((self.message, "message"), (self.plots_box, "plots"), (self.progress, "progress"),
                             (self.summary, "summary"), (self.stale_note, "stale-note"),
                             (self.waveform_image, "waveform-preview"), (self.fov_image, "fov-preview"),
                             (self.correlation_image, "correlation-preview"), (self.frame_image, "frame-image"),
                             (self.frame_summary, "frame-summary"), (self.frame_message, "frame-message"),
                             (self.frame_progress, "frame-progress")):
            widget.add_class(f"tofjax-{name}")  # for a browser test's selectors
        self.tabs = w.Tab(children=[self._main_tab(), *(self._section_tab(t) for t in _TAB_SECTIONS), self._frame_tab()],
                          titles=["Main", *_TAB_SECTIONS, "Frame"])
        self.widget = w.VBox([w.HTML(_STYLE + "<b>tofjax</b>: ToF camera performance model"), self.tabs])
        self.tabs.observe(lambda _c: self._render_shown(), names="selected_index")
        self._sweep_changed()
        self._update_previews()

    # --- the state, as attributes ---------------------------------------------------------------
    folder = property(lambda self: self.state.folder, doc="The only folder the explorer reads and writes in.")
    config = property(lambda self: self.state.config, doc="The last valid configuration.")
    error = property(lambda self: self.state.error, doc="The current validation message, or ``None``.")
    run = property(lambda self: self.state.run, doc="The last run (:class:`tofjax._run.Run`).")
    figures = property(lambda self: self.state.figures, doc="Plot name -> Figure of the last run.")
    headlines = property(lambda self: self.state.headlines, doc="The last run's headline numbers.")
    message_text = property(lambda self: _plain(self.message.value),
                            doc="The message beside Calculate as plain text (its widget holds HTML).")
    summary_text = property(lambda self: _plain(self.summary.value),
                            doc="The last run's summary as plain text, a line each (its widget holds HTML).")

    def _say(self, message: Message | None) -> None:
        """Show what an action did (or why not); the Overwrite button while one waits for it."""
        if message is not None:
            self.message.value = _error_html(message.text) if message.error else html.escape(message.text)
        self.overwrite_button.layout.display = None if self.state.pending is not None else "none"

    # --- layout -------------------------------------------------------------------------------
    def _rows(self, dotted_keys) -> list:
        return [self.fields[d].box for d in dotted_keys]

    def _main_tab(self):
        settings = w.VBox([
            *self._rows(["scene.background", *_NOMINAL_KEYS]), self.sweep,
            *self._rows(k for pair in _RANGE_KEYS.values() for k in pair),
            *self._rows(["scene.samples", "pixel.iterations"]), self.method, self.seed,
        ])
        choice = w.VBox([w.HTML("<b>Plots to generate</b> (Table 4.9)"), *self.plot_checkboxes.values()],
                        layout=w.Layout(min_width="300px"))
        actions = w.VBox([
            w.HBox([self.calculate_button, self.cancel_button, self.progress, self.lamp, self.time_label],
                   layout=w.Layout(align_items="center")),
            self.message,
            w.HBox([self.path, self.load_button, self.save_button, self.overwrite_button, self.reset_button]),
        ])
        results = w.HBox([self.figures_button, self.report_button, self.overlay], layout=w.Layout(align_items="center"))
        return w.VBox([w.HBox([settings, choice], layout=w.Layout(flex_flow="row wrap")), actions,
                       self.stale_note, self.summary, results, self.plots_box])

    def _section_tab(self, title: str):
        rows = []
        for section in _TAB_SECTIONS[title]:
            keys = [k.dotted for k in keys_of(section) if k.dotted not in _MAIN_KEYS]
            rows += [w.HTML(f"<b>[{section}]</b>"), *self._rows(keys)]
        if title == "Pixel":
            side = [w.HTML("<b>Illumination and reference waveforms</b>"), self.waveform_image,
                    w.HTML("<b>Correlation functions</b> of the phase images (§3.2.2, Eq 3.24)"),
                    self.correlation_image]
        elif title == "Scene & Camera":
            side = [w.HTML("<b>Illumination field of view</b>"), self.fov_image, self.derived]
        elif title == "Processing":
            side = [w.HTML("<b>The camera's own processing</b> after the demodulation, in this order: its "
                           "factory calibration, a spatial filter, a temporal average, its invalidation "
                           "(docs/model.md, \"The camera's processing\"). A sweep's point is the centre of a "
                           "uniform patch; a frame filters its image.")]
        else:
            constants = PhysicalConstants()
            table = "".join(f"<tr><td>{name}</td><td>{float(getattr(constants, name)):.10g} {unit}</td></tr>"
                            for name, unit in _CONSTANT_UNITS.items())
            side = [w.HTML(f"<b>Physical constants</b> (Table 4.1, exact SI values; fixed)<table>{table}</table>")]
        if title not in ("Physical & ADC", "Processing"):  # the previews say when they show the last valid settings
            self._tab_notes.append(w.HTML(""))
            side.insert(0, self._tab_notes[-1])
        return w.HBox([w.VBox(rows), w.VBox(side)], layout=w.Layout(flex_flow="row wrap"))

    def _frame_tab(self):
        """A scene's frame on this configuration's camera (``tofjax render`` in the explorer): the scene
        in words (a built-in scene and its parameters, or an NPZ file in the folder), the analytic
        noise image at once, Monte Carlo frames on request (progress, Cancel)."""
        scenes_help = "; ".join(f"<code>{name}</code>: " + ", ".join(ranges) for name, (_, ranges) in
                                BUILTIN_SCENES.items())
        return w.VBox([
            w.HTML("<b>A frame</b> of the camera above (every pixel; docs/model.md, \"Full frames\"). Scene: "
                   "<code>NAME</code> or <code>NAME:key=value,...</code>, or a depth map / returns NPZ file in the "
                   f"folder. Built-in scenes and their parameters: {scenes_help}."),
            self.frame_scene, self.frame_frames,
            w.HBox([self.frame_noise_button, self.frame_mc_button, self.frame_cancel_button, self.frame_progress],
                   layout=w.Layout(align_items="center")),
            self.frame_message, self.frame_summary, self.frame_image,
        ])

    def _repr_mimebundle_(self, **kwargs):
        return self.widget._repr_mimebundle_(**kwargs)

    # --- reactions ----------------------------------------------------------------------------
    def _changed(self, field: _Field) -> None:
        if self._quiet:
            return
        error = self.state.edit(field.key, field.value)
        self._set_error(error, field)
        if error is None:
            self._update_previews(self.state.take_changed())

    def _set_error(self, text: str | None, changed: _Field | None = None) -> None:
        """Show (or clear) a validation message: beside Calculate, at the fields it names (or the one
        just changed), above the previews; Calculate is disabled while it stands."""
        for field in self.fields.values():
            named = text is not None and (field is changed or names_key(text, field.key.dotted))
            field.show_error(text if named else None)
        self.message.value = "" if text is None else _error_html(text)
        note = "" if text is None else _error_html(f"invalid value: {text}. The previews show the last valid settings.")
        for tab_note in self._tab_notes:
            tab_note.value = note
        self._controls()
        self._refresh_stale()

    def _controls(self) -> None:
        """Buttons and lamp from the state: Calculate only when idle and valid; Cancel only when busy."""
        self.calculate_button.disabled = self.busy or self.error is not None
        self.cancel_button.disabled = not self.busy
        self.frame_noise_button.disabled = self.frame_mc_button.disabled = self.busy or self.error is not None
        self.frame_cancel_button.disabled = not self.busy
        self.lamp.value = _BUSY if self.busy else (_INVALID if self.error is not None else _READY)
        has_run = self.run is not None and not self.busy
        self.figures_button.disabled = not (has_run and self.figures)
        self.report_button.disabled = not has_run

    def _refresh_stale(self) -> None:
        self.stale = self.state.stale(self.sweep.value, self.method.value, self.seed.value)
        self.stale_note.value = _STALE if self.stale else ""
        for box in (self.summary, self.plots_box):
            (box.add_class if self.stale else box.remove_class)("tofjax-stale")

    def _sweep_changed(self) -> None:
        variable = self.sweep.value
        for name, pair in _RANGE_KEYS.items():
            for k in pair:
                self.fields[k].box.layout.display = None if name == variable else "none"
        allowed = plots.applicable(variable)
        for name, box in self.plot_checkboxes.items():
            box.disabled = name not in allowed

    def selected_plots(self) -> list[str]:
        """The ticked plots that apply to the selected sweep."""
        return [name for name, box in self.plot_checkboxes.items() if box.value and not box.disabled]

    @property
    def preview(self) -> dict:
        """The live preview figures (``"waveforms"``, ``"correlation"``, ``"fov"``) of the current
        configuration, drawn now where they are behind, and its derived numbers."""
        self._render(set(_PREVIEWS))
        return self._preview

    def _render(self, names: set[str]) -> None:
        """Draw those of ``names`` that are behind the configuration."""
        params = self.config.params
        for name in sorted(names & self._dirty):
            _, draw, _, image, scale = _PREVIEWS[name]
            fig = draw(params)
            image = getattr(self, image)
            image.value, image.layout = self._png(fig, scale=scale)
            self._preview[name] = fig
            self._dirty.discard(name)

    def _render_shown(self) -> None:
        title = self.tabs.titles[self.tabs.selected_index or 0]
        self._render({name for name, (tab, *_) in _PREVIEWS.items() if tab == title})

    def _update_previews(self, sections: set[str] | None = None) -> None:
        """Mark the previews changes in ``sections`` affect (all when ``None``) and draw those of the
        shown tab (the others when their tab is opened: an edit on Main draws nothing hidden);
        the derived numbers always."""
        params = self.config.params
        distance = float(params.scene.distance_m)
        self._dirty |= {name for name, (_, _, affected, *_) in _PREVIEWS.items() if sections is None or sections & affected}
        self._render_shown()
        focal = lens(params.camera)
        p = self._preview
        p.update(spot_area_m2=float(spot_area_m2(params.illumination, distance)),
                 focal_length_m=float(focal.focal_length_m), aperture_diameter_m=float(focal.diameter_m),
                 unambiguity_range_m=float(params.unambiguity_range_m))
        freqs = self.config.modulation_frequencies_hz
        extended = ""
        if len(freqs) > 1:
            from ._multifrequency import extended_range_m

            p["extended_range_m"] = float(extended_range_m(freqs, params.constants.speed_of_light_m_per_s))
            extended = f"; with {len(freqs)} frequencies the extended range {p['extended_range_m']:.4g} m"
        self.derived.value = (
            f"lens (from the diagonal FoV, f-number and sensor size, §4.2.5): focal length "
            f"{1e3 * p['focal_length_m']:.4g} mm, aperture {1e3 * p['aperture_diameter_m']:.4g} mm<br>"
            f"spot area at {distance:g} m: {p['spot_area_m2']:.4g} m&sup2;; "
            f"unambiguity range {p['unambiguity_range_m']:.4g} m{extended}")

    @staticmethod
    def _png(fig, scale: float = 1.0):
        """PNG bytes of ``fig`` and a layout that shows them at their own size (sharp)."""
        dpi = _PLOT_DPI * scale
        width, height = (round(x * dpi) for x in fig.get_size_inches())
        return plots.to_png(fig, dpi=dpi), w.Layout(width=f"{width}px", height=f"{height}px")

    # --- actions ------------------------------------------------------------------------------
    def calculate(self, wait: bool = True) -> None:
        """Run the selected sweep and draw the ticked plots (the Calculate button: in a background
        thread, ``wait=False``; :meth:`wait` joins it). One run at a time: while one goes, this says
        so and returns."""
        refused = self.state.check_calculate(self.busy, self.seed.value)
        if refused is not None:
            self._say(refused)
            return
        config, method, seed = self.config, self.method.value, self.seed.value
        sweep = config.sweep(self.sweep.value)
        names = self.selected_plots()
        self.busy = True
        self._cancel.clear()
        self._controls()
        self.time_label.value = ""
        self.progress.value, self.progress.description = 0.0, "starting" if method == "mc" else ""
        self.progress.layout.visibility = "visible" if method == "mc" else "hidden"
        self.message.value = (f"running: {sweep.samples} samples x {config.iterations} frames (Monte Carlo)" if method == "mc"
                              else f"running: {sweep.samples} samples (analytic)")
        if wait:
            self._work(config, sweep, method, seed, names)
        else:
            self._thread = threading.Thread(target=self._work, args=(config, sweep, method, seed, names), daemon=True)
            self._thread.start()

    def render_frame(self, monte_carlo: bool = False, wait: bool = True) -> None:
        """The Frame tab's run: the analytic frame of its scene, with ``monte_carlo`` also its number of
        Monte Carlo frames (the buttons: in a background thread, ``wait=False``; :meth:`wait` joins
        it). One run at a time, as :meth:`calculate`."""
        if self.busy:
            self.frame_message.value = _error_html("a run is going: wait for it or press Cancel")
            return
        frames = self.frame_frames.value if monte_carlo else 0
        config, scene, seed = self.config, self.frame_scene.value, self.seed.value
        self.busy = True
        self._cancel.clear()
        self._controls()
        self.frame_progress.value, self.frame_progress.description = 0.0, "starting" if frames else ""
        self.frame_progress.layout.visibility = "visible" if frames else "hidden"
        self.frame_message.value = html.escape(f"rendering {scene}" + (f": {frames} Monte Carlo frames" if frames
                                                                       else ": the analytic frame"))
        if wait:
            self._frame_work(config, scene, frames, seed)
        else:
            self._thread = threading.Thread(target=self._frame_work, args=(config, scene, frames, seed), daemon=True)
            self._thread.start()

    def _frame_work(self, config, scene: str, frames: int, seed: int) -> None:
        """The frame (in the background thread for the buttons): never raises; the outcome is a message."""
        message = ""
        try:
            with _progress.reporting(_RunProgress(self.frame_progress, self._cancel)):
                out = self.state.frame(config, scene, frames, seed)
            if isinstance(out, Message):
                message = _error_html(out.text)
            else:
                arrays, text = out
                fig = frameio.frame_figure(arrays)
                png, layout = self._png(fig)
                self.frame_image.value, self.frame_image.layout = png, layout
                self.frame_arrays = arrays
                method = f"{frames} Monte Carlo frames" if frames else "analytic"
                self.frame_summary.value = html.escape(f"{scene} ({method}): {text}")
        except Exception as err:  # noqa: BLE001 - a background run must report, not vanish
            message = ("cancelled: the frame below is still the previous one" if self._cancel.is_set()
                       else _error_html(f"the frame failed: {str(err).strip().splitlines()[0] if str(err).strip() else type(err).__name__}"))
        self.busy = False
        self.frame_message.value = message
        self.frame_progress.layout.visibility = "hidden"
        self._controls()

    def wait(self, timeout: float | None = None) -> None:
        """Wait for a run started with the Calculate button (``calculate(wait=False)``)."""
        if self._thread is not None:
            self._thread.join(timeout)

    def cancel(self) -> None:
        """Stop the running Monte Carlo after its current chunk of frames (the Cancel button)."""
        if self.busy:
            self._cancel.set()
            self.message.value = "cancelling after the current chunk of frames ..."

    def _work(self, config, sweep, method, seed, names) -> None:
        """The run (in the background thread for the button): never raises; the outcome is a message."""
        quiet = _QuietCallbackErrors()
        logger = logging.getLogger("jax._src.debugging")
        logger.addFilter(quiet)
        try:
            with _progress.reporting(_RunProgress(self.progress, self._cancel)):
                run, figures, numbers = self.state.compute(config, sweep, method, seed, names, self.overlay.value)
            cells = [self._plot_cell(name, fig, sweep.variable) for name, fig in figures.items()]
            text = summary(run, numbers).html_fragment()
        except Exception as err:  # noqa: BLE001 - a background run must report, not vanish
            if self._cancel.is_set():
                self._finish("cancelled: the summary and plots below are still those of the previous run")
            else:
                text = str(err).strip().splitlines()[0] if str(err).strip() else type(err).__name__
                self._finish(_error_html(f"the run failed: {text}"))
            return
        finally:
            logger.removeFilter(quiet)
        self.state.accept(run, figures, numbers)
        self.plots_box.children = cells
        self.time_label.value = f"simulation time {run.elapsed_s:.2f} s"
        self.summary.value = text
        self._finish("")

    def _plot_cell(self, name: str, fig, variable: str):
        """One plot of the grid at its own size, titled (suptitle): zoomable and pannable (an ipympl
        canvas with its toolbar) where ipympl is installed, else a PNG; with its save buttons."""
        try:
            from ipympl.backend_nbagg import Canvas, FigureManager
        except ImportError:
            png, layout = self._png(fig)
            view = w.Image(value=png, format="png", layout=layout)
        else:
            fig.set_dpi(_PLOT_DPI)
            view = Canvas(fig)
            with warnings.catch_warnings():  # ipympl 0.9-0.10's Toolbar calls a deprecated traitlets path
                warnings.simplefilter("ignore", DeprecationWarning)
                FigureManager(view, 0)  # the toolbar (zoom, pan, home, download)
            view.header_visible, view.resizable = False, False
            # The toolbar shows while the pointer is over the plot (it would cover the title or labels).
            view.toolbar_visible, view.toolbar_position = "fade-in-fade-out", "left"
            view.layout.width = f"{round(fig.get_figwidth() * _PLOT_DPI) + 4}px"
        view.add_class("tofjax-plot")
        stem = file_stem(variable, name)
        save = w.Button(description="Save PNG", icon="image", tooltip=f"this plot as {stem}.png in the folder of the TOML file")
        export = w.Button(description="Export CSV", icon="table",
                          tooltip=f"this plot's curves as {stem}.csv in the folder of the TOML file")
        save.on_click(lambda _b: self.save_figure(name))
        export.on_click(lambda _b: self.export_csv(name))
        return w.VBox([view, w.HBox([save, export])])

    def _finish(self, message: str) -> None:
        self.busy = False
        self.message.value = message
        self.progress.layout.visibility = "hidden"
        self._controls()
        self._refresh_stale()

    def _hide_overwrite(self) -> None:
        self.state.pending = None
        self.overwrite_button.layout.display = "none"

    def _confirm(self):
        """The Overwrite button: run the action that waits for it."""
        return self.state.confirm()

    def _show(self, config: Config, message: str) -> None:
        """Put ``config`` into every field and make it the configuration."""
        self._quiet = True
        try:
            for dotted, field in self.fields.items():
                section, name = dotted.split(".")
                field.set_value(config.values[section][name])
        finally:
            self._quiet = False
        self.state.replace(config)
        self._set_error(None)
        self._update_previews()
        self._say(Message(message))

    def _path_text(self, path) -> str:
        """The path box's text, after putting ``path`` into it (when given)."""
        if path is not None:
            self.path.value = str(path)
        return self.path.value

    def load(self, path: str | os.PathLike | None = None) -> None:
        """Load a TOML configuration (the Load button: from the path box, in :attr:`folder`)."""
        config, message = self.state.load(self._path_text(path))
        if config is None:
            self._say(message)
        else:
            self._show(config, message.text)

    def reset(self) -> None:
        """Every field back to the built-in defaults (the Reset button); the sweep and plots too."""
        self.sweep.value, self.method.value, self.seed.value = "distance", "mc", 0
        for name, box in self.plot_checkboxes.items():
            box.value = name in DEFAULT_PLOTS
        self._show(Config(), "reset to the defaults")

    def save(self, path: str | os.PathLike | None = None, overwrite: bool = False) -> None:
        """Write the configuration as commented TOML (the Save button: to the path box). An existing
        file is only replaced with ``overwrite`` (the Overwrite button, which the first Save shows)."""
        self._say(self.state.save(self._path_text(path), overwrite, lambda overwrite: self.save(path, overwrite)))

    def _write(self, names: list[str], suffix: str, write, overwrite: bool, again) -> list[Path] | None:
        written, message = self.state.write_plots(self.path.value, names, suffix, write, overwrite, again)
        self._say(message)
        return written

    def save_figure(self, name: str, overwrite: bool = False) -> Path | None:
        """One plot of the last run as ``<sweep>_<plot>.png`` in the TOML file's folder (its Save PNG
        button); ``None`` if it waits for Overwrite or cannot be written (:attr:`message` says)."""
        written = self._write([name], "png", save_png, overwrite, lambda overwrite: self.save_figure(name, overwrite))
        return written[0] if written else None

    def export_csv(self, name: str, overwrite: bool = False) -> Path | None:
        """The curves of one plot of the last run as ``<sweep>_<plot>.csv`` in the TOML file's folder
        (its Export CSV button; :func:`tofjax.plots.figure_csv`)."""
        written = self._write([name], "csv", lambda path, fig: write_text(path, plots.figure_csv(fig)), overwrite,
                              lambda overwrite: self.export_csv(name, overwrite))
        return written[0] if written else None

    def save_figures(self, overwrite: bool = False) -> list[Path]:
        """The last run's plots as PNGs (``<sweep>_<plot>.png``, as their Save PNG buttons write them) in
        the TOML file's folder; returns the paths written (none while it waits for Overwrite)."""
        if self.run is None or not self.figures:
            self._say(Message("no plots yet: Calculate first", True))
            return []
        return self._write(list(self.figures), "png", save_png, overwrite,
                           lambda overwrite: self.save_figures(overwrite)) or []

    def write_report(self, overwrite: bool = False) -> Path | None:
        """The last run's tofjax-sweep CSV and HTML report (plots, headline numbers) in
        ``report_<sweep>/`` beside the TOML file, as ``tofjax simulate --report`` writes them (the
        folder replaced as a whole, after the Overwrite button if it exists)."""
        path, message = self.state.write_report(self.path.value, overwrite, lambda overwrite: self.write_report(overwrite))
        self._say(message)
        return path
