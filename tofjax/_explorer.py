"""The interactive explorer: the thesis' GUI (§4.3, Figs 4.8-4.11) as an ipywidgets app.

Four tabs as in the thesis: **Main** (background light, sweep with from/to/samples/iterations,
method, plot choice, Calculate with a ready/busy lamp and the simulation time, TOML load/save),
**Pixel** (pixel, illumination and reference waveforms, with a live waveform preview),
**Scene & Camera** (illumination unit, scene, camera, with a live FoV preview and the derived lens)
and **Physical & ADC** (physical constants, read-only, and the ADC).

Every configuration key of the schema has one input with its unit and allowed range next to it.
Each change re-validates the whole configuration (:func:`tofjax.config_from_dict`): an invalid
value shows the validation message and disables Calculate instead of raising, and the explorer
keeps the last valid configuration. The logic lives here, not in a notebook, so that the tests can
drive it headlessly: set widget values, press buttons with ``.click()``, read :attr:`config`,
:attr:`preview`, :attr:`figures` and :attr:`message`.
"""

from __future__ import annotations

import copy
import html
import os
from pathlib import Path
from typing import Any

import numpy as np

try:
    import ipywidgets as w
except ImportError as err:  # pragma: no cover - exercised only without the extra
    raise ImportError('the explorer needs ipywidgets: pip install "tofjax[notebooks]"') from err

from . import plots
from ._config import SWEEP_RANGE_KEYS, Config, config_from_dict, load_config
from ._optics import lens, spot_area_m2
from ._params import PhysicalConstants
from ._run import run_sweep
from ._schema import KEYS, ConfigError, Key, keys_of

#: Sweep choices as the thesis' GUI names them (§4.3).
SWEEP_CHOICES = (("Distance", "distance"), ("Background light", "illuminance"),
                 ("Integration time", "integration_time"))
#: Plots ticked when the explorer opens.
DEFAULT_PLOTS = ("depth_noise", "amplitude", "photon_transfer_curve")

_MAIN_KEYS = ("scene.background", "scene.samples", "pixel.iterations",
              *(f"scene.{k}" for pair in SWEEP_RANGE_KEYS.values() for k in pair))
_TAB_SECTIONS = {
    "Pixel": ("pixel", "illumination_waveform", "reference_waveform"),
    "Scene & Camera": ("illumination", "scene", "camera", "frame"),
    "Physical & ADC": ("adc",),
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


def _error_html(text: str) -> str:
    return f'<span style="color:#c00">{html.escape(text)}</span>'


class _Field:
    """The input(s) of one configuration key, with its unit and allowed range beside them."""

    def __init__(self, key: Key, value: Any, on_change):
        self.key = key
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
        self.note = w.HTML(f"<small>[{html.escape(key.unit)}] {html.escape(key.range_text())}</small>")
        self.box = w.HBox([*self.inputs, self.note])
        for widget in self.inputs:
            widget.observe(lambda _change: on_change(self), names="value")

    def _show_second(self) -> None:
        self.inputs[2].layout.display = None if self.mode.value == "hv" else "none"

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
            self.inputs[0].value = ", ".join(repr(v) for v in value)
        elif self.key.kind == "pair":
            self.inputs[0].value, self.inputs[1].value = value
        elif self.key.kind == "angle":
            diagonal = np.ndim(value) == 0
            self.mode.value = "diagonal" if diagonal else "hv"
            self.inputs[1].value, self.inputs[2].value = (value, value) if diagonal else value
            self._show_second()
        else:
            self.inputs[0].value = value


class Explorer:
    """The interactive explorer (module docstring). Display it in Jupyter as the last expression
    of a cell; :attr:`widget` is the top-level ipywidgets container.

    **Arguments:**
    - ``config``: a :class:`tofjax.Config`, a path to a TOML configuration, or ``None`` (defaults).

    **Attributes** (for scripting and tests):
    - ``config``: the last valid configuration; ``error``: the current validation message or ``None``.
    - ``fields``: dotted key -> its input (every key of the schema).
    - ``sweep``, ``method``, ``seed``, ``plot_checkboxes``, ``calculate_button``, ``load_button``,
      ``save_button``, ``path``: the Main tab's controls; ``lamp`` and ``time_label`` show
      ready/busy and the simulation time.
    - ``preview``: the live preview figures (``"waveforms"``, ``"fov"``) and derived numbers.
    - ``run``: the last :class:`tofjax._run.Run`; ``figures``: plot name -> Figure of the last run.
    """

    def __init__(self, config: Config | str | os.PathLike | None = None):
        if config is None:
            config = Config()
        elif not isinstance(config, Config):
            config = load_config(config)
        self.config = config
        self._raw = copy.deepcopy({s: dict(t) for s, t in config.values.items()})
        self.error: str | None = None
        self._unparsed: dict[str, str] = {}
        self._stale: set[str] = set()
        self._quiet = False
        self.run = None
        self.figures: dict = {}
        self.preview: dict = {}
        self.fields = {k.dotted: _Field(k, self._raw[k.section][k.name], self._changed) for k in KEYS}

        self.sweep = w.Dropdown(options=SWEEP_CHOICES, value="distance", description="sweep", style=_DESCRIPTION,
                                layout=_wide())
        self.method = w.ToggleButtons(options=[("Monte Carlo", "mc"), ("analytic", "analytic")], value="mc",
                                      description="method", style=_DESCRIPTION,
                                      tooltip="analytic: propagated variances, ~40x faster; Monte Carlo: frames")
        self.seed = w.IntText(value=0, description="seed", style=_DESCRIPTION, layout=_wide())
        self.plot_checkboxes = {
            name: w.Checkbox(value=name in DEFAULT_PLOTS, description=f"{name.replace('_', ' ')} ({ref})",
                             indent=False, layout=w.Layout(width="340px"))
            for name, (_, _, ref) in plots.PLOTS.items()
        }
        self.calculate_button = w.Button(description="Calculate", button_style="primary", icon="play")
        self.lamp = w.HTML(_READY)
        self.time_label = w.HTML("")
        self.path = w.Text(value="camera.toml", description="TOML file", style=_DESCRIPTION, layout=_wide())
        self.load_button = w.Button(description="Load", icon="folder-open")
        self.save_button = w.Button(description="Save", icon="save")
        self.message = w.HTML("")
        self.summary = w.HTML("")
        self.plots_box = w.VBox([])
        self.waveform_image = w.Image(format="png")
        self.fov_image = w.Image(format="png")
        self.derived = w.HTML("")

        self.sweep.observe(lambda _c: self._sweep_changed(), names="value")
        self.calculate_button.on_click(lambda _b: self.calculate())
        self.load_button.on_click(lambda _b: self.load())
        self.save_button.on_click(lambda _b: self.save())

        self.tabs = w.Tab(children=[self._main_tab(), *(self._section_tab(t) for t in _TAB_SECTIONS)],
                          titles=["Main", *_TAB_SECTIONS])
        self.widget = w.VBox([w.HTML("<b>tofjax</b>: ToF camera performance model"), self.tabs, self.message])
        self._sweep_changed()
        self._update_previews()

    # --- layout -------------------------------------------------------------------------------
    def _rows(self, dotted_keys) -> list:
        return [self.fields[d].box for d in dotted_keys]

    def _main_tab(self):
        settings = w.VBox([
            *self._rows(["scene.background"]), self.sweep,
            *self._rows(f"scene.{k}" for pair in SWEEP_RANGE_KEYS.values() for k in pair),
            *self._rows(["scene.samples", "pixel.iterations"]), self.method, self.seed,
            w.HBox([self.calculate_button, self.lamp, self.time_label]),
            w.HBox([self.path, self.load_button, self.save_button]),
        ])
        choice = w.VBox([w.HTML("<b>Plots to generate</b> (Table 4.9)"), *self.plot_checkboxes.values()])
        return w.VBox([w.HBox([settings, choice]), self.summary, self.plots_box])

    def _section_tab(self, title: str):
        rows = []
        for section in _TAB_SECTIONS[title]:
            keys = [k.dotted for k in keys_of(section) if k.dotted not in _MAIN_KEYS]
            rows += [w.HTML(f"<b>[{section}]</b>"), *self._rows(keys)]
        if title == "Pixel":
            side = [w.HTML("<b>Illumination and reference waveforms</b>"), self.waveform_image]
        elif title == "Scene & Camera":
            side = [w.HTML("<b>Illumination field of view</b>"), self.fov_image, self.derived]
        else:
            constants = PhysicalConstants()
            table = "".join(f"<tr><td>{name}</td><td>{float(getattr(constants, name)):.10g} {unit}</td></tr>"
                            for name, unit in _CONSTANT_UNITS.items())
            side = [w.HTML(f"<b>Physical constants</b> (Table 4.1, exact SI values; fixed)<table>{table}</table>")]
        return w.HBox([w.VBox(rows), w.VBox(side)])

    def _repr_mimebundle_(self, **kwargs):
        return self.widget._repr_mimebundle_(**kwargs)

    # --- reactions ----------------------------------------------------------------------------
    def _changed(self, field: _Field) -> None:
        if self._quiet:
            return
        self._stale.add(field.key.section)  # sections changed since the last valid configuration
        try:
            self._raw[field.key.section][field.key.name] = field.value()
            self._unparsed.pop(field.key.dotted, None)
        except ConfigError as err:  # text that is not a value at all: remembered until fixed
            self._unparsed[field.key.dotted] = str(err)
        try:
            if self._unparsed:
                raise ConfigError(next(iter(self._unparsed.values())))
            config = config_from_dict(self._raw)
        except ConfigError as err:
            self._set_error(str(err))
            return
        self.config = config
        self._set_error(None)
        self._update_previews(self._stale)
        self._stale = set()

    def _set_error(self, text: str | None) -> None:
        self.error = text
        self.message.value = "" if text is None else _error_html(text)
        self.calculate_button.disabled = text is not None

    def _sweep_changed(self) -> None:
        variable = self.sweep.value
        for name, pair in SWEEP_RANGE_KEYS.items():
            for k in pair:
                self.fields[f"scene.{k}"].box.layout.display = None if name == variable else "none"
        allowed = plots.applicable(variable)
        for name, box in self.plot_checkboxes.items():
            box.disabled = name not in allowed

    def selected_plots(self) -> list[str]:
        """The ticked plots that apply to the selected sweep."""
        return [name for name, box in self.plot_checkboxes.items() if box.value and not box.disabled]

    def _update_previews(self, sections: set[str] | None = None) -> None:
        """Redraw the previews changes in ``sections`` affect (all when ``None``); derived numbers always."""
        params = self.config.params
        distance = float(params.scene.distance_m)
        if sections is None or sections & {"illumination", "illumination_waveform", "reference_waveform"}:
            self.preview["waveforms"] = plots.waveforms(params)
            self.waveform_image.value = plots.to_png(self.preview["waveforms"], dpi=72)
        if sections is None or sections & {"illumination", "scene"}:
            self.preview["fov"] = plots.fov_footprint(params)
            self.fov_image.value = plots.to_png(self.preview["fov"], dpi=60)
        focal = lens(params.camera)
        p = self.preview
        p.update(spot_area_m2=float(spot_area_m2(params.illumination, distance)),
                 focal_length_m=float(focal.focal_length_m), aperture_diameter_m=float(focal.diameter_m),
                 unambiguity_range_m=float(params.unambiguity_range_m))
        self.derived.value = (
            f"lens (from the diagonal FoV, f-number and sensor size, §4.2.5): focal length "
            f"{1e3 * p['focal_length_m']:.3f} mm, aperture {1e3 * p['aperture_diameter_m']:.3f} mm<br>"
            f"spot area at {distance:g} m: {p['spot_area_m2']:.4g} m&sup2;; "
            f"unambiguity range {p['unambiguity_range_m']:.4f} m")

    # --- actions ------------------------------------------------------------------------------
    def calculate(self) -> None:
        """Run the selected sweep (the Calculate button) and draw the ticked plots."""
        if self.error is not None:
            return
        if self.seed.value < 0:
            self.message.value = _error_html(f"seed = {self.seed.value} is out of range: allowed integer >= 0")
            return
        self.lamp.value, self.calculate_button.disabled = _BUSY, True
        self.time_label.value = ""
        try:
            run = run_sweep(self.config, self.config.sweep(self.sweep.value), self.method.value, seed=self.seed.value,
                            keep_frames=200)
        except ValueError as err:
            self.message.value = _error_html(str(err))
            return
        finally:
            self.lamp.value, self.calculate_button.disabled = _READY, self.error is not None
        self.message.value = ""
        self.run = run
        figures = {name: plots.PLOTS[name][0](run.result) for name in self.selected_plots()}
        if run.multifrequency is not None and run.sweep.variable == "distance":
            figures["multifrequency_distance"] = plots.multifrequency_distance(run.multifrequency)
        self.figures = figures
        self.plots_box.children = [w.Image(value=plots.to_png(fig, dpi=80), format="png") for fig in figures.values()]
        self.time_label.value = f"simulation time {run.elapsed_s:.2f} s"
        self.summary.value = self._summary(run)

    @staticmethod
    def _summary(run) -> str:
        r = run.result
        valid = np.asarray(r.valid_fraction)
        std = np.asarray(r.depth_std_m)
        kind = f"Monte Carlo, {r.n_frames} frames per sample" if r.method == "mc" else "analytic"
        noise = (f"depth noise {1e3 * np.nanmin(std):.3g}-{1e3 * np.nanmax(std):.3g} mm"
                 if np.any(np.isfinite(std)) else "no valid sample")
        return (f"{len(valid)} samples ({kind}); {noise}; {np.mean(valid == 1):.0%} of the samples fully valid; "
                f"unambiguity range {float(r.unambiguity_range_m):.4f} m")

    def _path(self, path) -> Path:
        if path is not None:
            self.path.value = str(path)
        return Path(self.path.value).expanduser()

    def load(self, path: str | os.PathLike | None = None) -> None:
        """Load a TOML configuration (the Load button: from the path box)."""
        path = self._path(path)
        try:
            config = load_config(path)
        except ConfigError as err:
            self.message.value = _error_html(str(err))
            return
        self._quiet = True
        try:
            for dotted, field in self.fields.items():
                section, name = dotted.split(".")
                field.set_value(config.values[section][name])
        finally:
            self._quiet = False
        self.config = config
        self._raw = copy.deepcopy({s: dict(t) for s, t in config.values.items()})
        self._unparsed.clear()
        self._stale = set()
        self._set_error(None)
        self._update_previews()
        self.message.value = f"loaded {html.escape(str(path))}"

    def save(self, path: str | os.PathLike | None = None) -> None:
        """Write the configuration as commented TOML (the Save button: to the path box)."""
        path = self._path(path)
        if self.error is not None:
            self.message.value = _error_html(f"not saved: fix the invalid value first ({self.error})")
            return
        try:
            path.write_text(self.config.to_toml(), encoding="utf-8")
        except OSError as err:
            self.message.value = _error_html(f"cannot write {path}: {err.strerror or err}")
            return
        self.message.value = f"saved {html.escape(str(path))}"
