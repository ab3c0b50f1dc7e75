"""Reports, public: one :class:`Summary` of a run, rendered as text (the terminal), Markdown and a
self-contained HTML page (images embedded) by this one module, for ``tofjax simulate --report``,
``tofjax render``, ``tofjax compare``, ``tofjax calibrate`` and the explorer.

A :class:`Summary` is a title, its headline ``lines`` (what a terminal prints) and :class:`Section`
s of blocks: a paragraph (``str``), bullets (``list[str]``), a :class:`Table`, a :class:`Figure` or
:class:`Code`. Every text is escaped for the format it is rendered to (a file name such as
``<b>|x|[l](u).csv`` shows as written, never as markup).

The simulation report (:func:`write_report`): PNGs of every plot that applies to the sweep, and
``report.html`` with the configuration, headline figures and the run's timing. Each headline figure
says where it comes from (:func:`headline_figure`): depth noise and amplitude at the nominal point
(the analytic path, hard mode); the shortest distance with valid data (below it the pixel or the
ADC saturates) and the distances where the relative depth noise reaches 1 % and 2 %, from the run's
own sweep when it is a distance sweep (its first sample where they hold, "beyond the sweep" where
none does), else from an analytic scan over 0.05-50 m; the background illuminance where SBI engages
and where the pixel saturates, from the run's sweep when it is an illuminance sweep, else from an
analytic scan over 0-200 klx at the nominal distance; and, from the run itself, the dominant noise
source in each region of the photon transfer curve.
"""

from __future__ import annotations

import base64
import dataclasses
import html
import re
from pathlib import Path
from typing import Union

import numpy as np

from ._schema import SWEEP_AXES
from .outputs import write_bytes, write_text

# The document model needs neither JAX nor matplotlib (``tofjax simulate`` prints its summary with
# it); the simulation report's scans and plots import them where they run.


@dataclasses.dataclass(frozen=True)
class Table:
    """A table of text cells: ``header`` and ``rows`` (tuples of strings); ``muted``: per row, shown
    greyed (flagged rows)."""

    header: tuple[str, ...]
    rows: tuple[tuple[str, ...], ...]
    muted: tuple[bool, ...] = ()


@dataclasses.dataclass(frozen=True)
class Figure:
    """A PNG image: ``name`` (its file's name, which Markdown links), ``png`` (the bytes, which HTML
    embeds), ``caption``."""

    name: str
    png: bytes
    caption: str = ""


@dataclasses.dataclass(frozen=True)
class Code:
    """Preformatted text (a configuration, a command)."""

    text: str


Block = Union[str, list, Table, Figure, Code]  # noqa: UP007 - a paragraph, bullets or one of the three


@dataclasses.dataclass
class Section:
    """A titled list of blocks (:data:`Block`)."""

    title: str
    blocks: list = dataclasses.field(default_factory=list)


@dataclasses.dataclass
class Summary:
    """What a run says (module docstring): ``title``, headline ``lines``, ``sections``."""

    title: str
    lines: list[str] = dataclasses.field(default_factory=list)
    sections: list[Section] = dataclasses.field(default_factory=list)

    def text(self) -> str:
        """Plain text: the headline lines, then each section (tables aligned in columns)."""
        out = list(self.lines)
        for section in self.sections:
            if section.title:
                out += ["", section.title, "-" * len(section.title)]
            for block in section.blocks:
                out += _text_block(block)
        return "\n".join(out)

    def markdown(self) -> str:
        """Markdown: figures linked by file name (written beside it), every text escaped."""
        out = [f"# {markdown_text(self.title)}", ""]
        out += [*(markdown_text(line) for line in self.lines), ""] if self.lines else []
        for section in self.sections:
            out += [f"## {markdown_text(section.title)}", ""]
            for block in section.blocks:
                out += [*_markdown_block(block), ""]
        return "\n".join(out)

    def html(self) -> str:
        """A self-contained HTML page (images embedded as base64)."""
        body = [f"<h1>{html.escape(self.title)}</h1>"] + [f"<p>{html.escape(line)}</p>" for line in self.lines]
        for section in self.sections:
            body.append(f"<h2>{html.escape(section.title)}</h2>")
            body += [_html_block(block) for block in section.blocks]
        return (f"<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>{html.escape(self.title)}"
                f"</title>\n<style>{_STYLE}</style></head><body>\n" + "\n".join(body) + "\n</body></html>\n")

    def html_fragment(self) -> str:
        """The headline lines as HTML (``<br>`` between them), for a page of someone else's (the explorer)."""
        return "<br>".join(html.escape(line) for line in self.lines)


_STYLE = ("body{font-family:sans-serif;max-width:1300px;margin:auto;padding:1em}table{border-collapse:collapse;"
          "font-size:13px}th,td{border:1px solid #ccc;padding:3px 7px;text-align:left}tr.muted td{color:#888}"
          "figure{display:inline-block;margin:6px}img{max-width:560px}pre{background:#f6f6f6;padding:8px;"
          "font-size:12px}")


def markdown_text(text) -> str:
    """``text`` as literal Markdown: HTML escaped, and what could make a link, an image, code,
    emphasis or a table cell backslash-escaped (``\\ ` * [ ] |``): shown, never interpreted."""
    return re.sub(r"([\\`*\[\]|])", r"\\\1", html.escape(str(text), quote=False))


def _text_block(block) -> list[str]:
    if isinstance(block, Table):
        rows = [block.header, *block.rows]
        widths = [max(len(str(r[i])) for r in rows) for i in range(len(block.header))]
        line = lambda r: "  ".join(str(c).rjust(w) for c, w in zip(r, widths, strict=True))  # noqa: E731
        return [line(block.header), "-" * len(line(block.header)), *map(line, block.rows)]
    if isinstance(block, Figure):
        return [f"[figure {block.name}: {block.caption}]" if block.caption else f"[figure {block.name}]"]
    if isinstance(block, Code):
        return ["    " + line for line in block.text.splitlines()]
    if isinstance(block, list):
        return [f"- {item}" for item in block]
    return [str(block)]


def _markdown_block(block) -> list[str]:
    if isinstance(block, Table):
        row = lambda cells: "| " + " | ".join(markdown_text(c) for c in cells) + " |"  # noqa: E731
        return [row(block.header), "|---" * len(block.header) + "|", *map(row, block.rows)]
    if isinstance(block, Figure):
        return [f"![{markdown_text(block.caption or block.name)}]({block.name})"]
    if isinstance(block, Code):
        return ["```", block.text, "```"]
    if isinstance(block, list):
        return [f"- {markdown_text(item)}" for item in block]
    return [markdown_text(block)]


def _html_block(block) -> str:
    if isinstance(block, Table):
        head = "<tr>" + "".join(f"<th>{html.escape(str(h))}</th>" for h in block.header) + "</tr>"
        muted = block.muted or (False,) * len(block.rows)
        rows = "".join(("<tr class='muted'>" if m else "<tr>") + "".join(f"<td>{html.escape(str(c))}</td>" for c in r)
                       + "</tr>\n" for r, m in zip(block.rows, muted, strict=True))
        return f"<table>{head}\n{rows}</table>"
    if isinstance(block, Figure):
        data = base64.b64encode(block.png).decode()
        return (f'<figure><img alt="{html.escape(block.name)}" src="data:image/png;base64,{data}">'
                f"<figcaption>{html.escape(block.caption or block.name)}</figcaption></figure>")
    if isinstance(block, Code):
        return f"<pre>{html.escape(block.text)}</pre>"
    if isinstance(block, list):
        return "<ul>" + "".join(f"<li>{html.escape(str(item))}</li>" for item in block) + "</ul>"
    return f"<p>{html.escape(str(block))}</p>"


def _first(x: np.ndarray, mask: np.ndarray):
    return float(x[np.argmax(mask)]) if np.any(mask) else None


def headlines(params, result) -> dict:
    """The headline figures (module docstring) as a dict of plain numbers (None: not reached)."""
    import jax

    from ._analytic import predict
    from ._sweep import Sweep

    scene = params.scene
    d = np.geomspace(0.05, 50.0, 600)
    lux = np.concatenate([[0.0], np.geomspace(1.0, 2e5, 500)])
    # One analytic call for the three scans: the nominal point, distances, background illuminances.
    nominal_d, nominal_lux, nominal_t = float(scene.distance_m), float(scene.illuminance_lx), float(scene.integration_time_s)
    points = Sweep.points("distance", np.concatenate([[nominal_d], d, np.full(lux.shape, nominal_d)]),
                          np.concatenate([[nominal_lux], np.full(d.shape, nominal_lux), lux]),
                          np.full(1 + d.size + lux.size, nominal_t))
    all_scans = jax.device_get(predict(params, points))
    at = lambda field, lo, hi: np.asarray(getattr(all_scans, field))[lo:hi]  # noqa: E731
    out = {
        "nominal_distance_m": nominal_d, "nominal_illuminance_lx": nominal_lux,
        "nominal_integration_time_s": nominal_t, "nominal_temperature_c": float(params.pixel.temperature_c),
        "nominal_depth_std_m": float(at("depth_std_m", 0, 1)[0]),
        "nominal_relative_depth_std": float(at("depth_std_m", 0, 1)[0] / nominal_d),
        "nominal_amplitude_lsb": float(at("amplitude_mean_lsb", 0, 1)[0]),
        "unambiguity_range_m": float(params.unambiguity_range_m),
    }
    scan = slice(1, 1 + d.size)
    valid = at("valid_fraction", scan.start, scan.stop) > 0
    out["valid_from_m"] = _first(d, valid)
    rel = at("depth_std_m", scan.start, scan.stop) / d
    start = np.argmax(valid) if np.any(valid) else len(d)
    beyond = np.arange(len(d)) >= start
    for level in (0.01, 0.02):
        out[f"relative_noise_{int(level * 100)}pct_at_m"] = _first(d, beyond & valid & (rel >= level))
    lo = 1 + d.size
    out["sbi_engages_at_lx"] = _first(lux, at("sbi_active_fraction", lo, None) > 0) if params.pixel.sbi else None
    out["pixel_saturates_at_lx"] = _first(lux, at("pixel_saturated_fraction", lo, None) > 0)
    out["dominant_noise"] = dominant_noise(result)
    out["sbi"] = bool(params.pixel.sbi)
    out["from_sweep"] = sweep_figures(result, sbi=out["sbi"])
    values = np.asarray(result.sweep_values, dtype=float).reshape(-1)
    out["sweep"] = {"variable": result.sweep_variable, "method": result.method, "from": float(values.min()),
                    "to": float(values.max())}
    return out


_DISTANCE_SCAN = "analytic scan over 0.05-50 m at the nominal illuminance and integration time"
_ILLUMINANCE_SCAN = "analytic scan over 0-200 klx at the nominal distance and integration time"
#: Headline figure -> (the sweep axis it lies on, the analytic scan behind it where the run's sweep
#: does not cover it): what :func:`sweep_figures` takes from a sweep of that axis.
FIGURE_AXES = {"valid_from_m": ("distance", _DISTANCE_SCAN), "relative_noise_1pct_at_m": ("distance", _DISTANCE_SCAN),
               "relative_noise_2pct_at_m": ("distance", _DISTANCE_SCAN),
               "sbi_engages_at_lx": ("illuminance", _ILLUMINANCE_SCAN),
               "pixel_saturates_at_lx": ("illuminance", _ILLUMINANCE_SCAN)}


def sweep_figures(result, sbi: bool = True) -> dict[str, tuple[float | None, str]]:
    """The headline figures (:data:`FIGURE_AXES`) that the run's own sweep covers, from its samples,
    each ``(value, how)``: ``"at"`` (the first sample where it holds), ``"start"`` (it holds from the
    sweep's first sample on: at or below it) or ``"beyond"`` (no sample of the sweep: ``None``).
    Empty for a sweep of another axis."""
    def first(mask, x):
        if not np.any(mask):
            return None, "beyond"
        i = int(np.argmax(mask))
        return float(x[i]), "start" if i == 0 else "at"

    x = np.asarray(result.sweep_values, dtype=float).reshape(-1)
    out: dict[str, tuple[float | None, str]] = {}
    if result.sweep_variable == "distance":
        valid = np.asarray(result.valid_fraction).reshape(-1) > 0
        out["valid_from_m"] = first(valid, x)
        with np.errstate(invalid="ignore"):
            rel = np.asarray(result.depth_std_m).reshape(-1) / x
        for level in (1, 2):
            out[f"relative_noise_{level}pct_at_m"] = first(valid & (rel >= level / 100), x)
    elif result.sweep_variable == "illuminance":
        if sbi:
            out["sbi_engages_at_lx"] = first(np.asarray(result.sbi_active_fraction).reshape(-1) > 0, x)
        out["pixel_saturates_at_lx"] = first(np.asarray(result.pixel_saturated_fraction).reshape(-1) > 0, x)
    return out


def headline_figure(h: dict, key: str, unit: str, digits: int = 4) -> tuple[str, str]:
    """One headline figure of :func:`headlines` as ``(value, where it comes from)``: from the run's
    sweep where it covers the figure (its first sample where it holds; "at or below" the sweep's
    start where it holds from there; "beyond the sweep" where no sample reaches it, with the
    analytic scan's value beside), else from the analytic scan (:data:`FIGURE_AXES`)."""
    if key == "sbi_engages_at_lx" and not h.get("sbi", True):
        return "SBI disabled", "the configuration"
    scan = _fmt(h[key], unit, digits=digits)
    axis, source = FIGURE_AXES[key]
    if key not in h.get("from_sweep", {}):
        return scan, source
    value, how = h["from_sweep"][key]
    sweep = h["sweep"]
    method = "Monte Carlo" if sweep["method"] == "mc" else "analytic"
    span = f"{sweep['from']:.4g}-{sweep['to']:.4g} {unit}"
    if how == "at":
        return _fmt(value, unit, digits=digits), f"this {axis} sweep ({method}): its first sample where it holds"
    scan_note = f"; the {source} puts it at {scan}"
    if how == "start":
        return (f"at or below {_fmt(value, unit, digits=digits)}",
                f"this {axis} sweep ({method}): it holds from its first sample{scan_note}")
    return f"beyond the sweep ({span})", f"this {axis} sweep ({method}): no sample reaches it{scan_note}"


def dominant_noise(result) -> list[dict]:
    """Contiguous ranges of the sweep where read, photon shot or quantisation noise dominates."""
    n = result.noise
    names = ("read noise", "photon shot noise", "quantisation noise")
    stack = np.stack([np.asarray(n.read_e), np.asarray(n.photon_shot_e), np.asarray(n.quantization_e)])
    winner = np.argmax(stack, axis=0)
    x = np.asarray(result.sweep_values)
    regions, start = [], 0
    for i in range(1, len(x) + 1):
        if i == len(x) or winner[i] != winner[start]:
            regions.append({"source": names[winner[start]], "from": float(x[start]), "to": float(x[i - 1])})
            start = i
    return regions


def _fmt(value, unit="", scale=1.0, digits=4):
    return "not reached" if value is None else f"{value * scale:.{digits}g} {unit}".strip()


def write_report(directory, config, result, elapsed_s: float, csv_path, multifrequency=None,
                 timing: list[str] = ()) -> Path:
    """Write the PNGs and ``report.html`` into ``directory``; returns the HTML path. ``timing``: the
    frame's timing and eye-safety lines (:func:`tofjax._timing.summary_lines`)."""
    from . import plots
    from ._estimate import cw_depth_noise, pulsed_depth_noise
    from ._sweep import Sweep

    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    params = config.params
    figures: list[Figure] = []
    for name in plots.applicable(result.sweep_variable):
        func, _, ref = plots.PLOTS[name]
        if name == "depth_noise" and result.sweep_variable == "distance":
            sweep = Sweep("distance", result.distance_m)
            fig = plots.depth_noise(result, estimates={"CW estimate": cw_depth_noise(params, sweep),
                                                       "pulsed estimate": pulsed_depth_noise(params, sweep)})
        else:
            fig = func(result)
        figures.append(Figure(f"{name}.png", plots.to_png(fig), f"{name} ({ref})"))
    figures.append(Figure("tap_voltages.png", plots.to_png(plots.tap_voltages(result, params)), "tap_voltages (Figs 5.2/5.15a)"))
    figures.append(Figure("waveforms.png", plots.to_png(plots.waveforms(params)), "waveforms (Fig 4.2)"))
    figures.append(Figure("fov_footprint.png", plots.to_png(plots.fov_footprint(params)), "fov_footprint (Fig 3.3)"))
    if multifrequency is not None:
        figures.append(Figure("multifrequency.png", plots.to_png(plots.multifrequency_distance(multifrequency)),
                              "multifrequency (§2.2, Fig 5.9)"))
    for figure in figures:
        write_bytes(directory / figure.name, figure.png)

    h = headlines(params, result)
    sweep_unit = SWEEP_AXES[result.sweep_variable].unit
    nominal = "the analytic path (hard mode) at the nominal point"
    rows = [
        ("depth noise at the nominal point", f"{_fmt(h['nominal_depth_std_m'], 'mm', 1e3)} "
         f"({_fmt(h['nominal_relative_depth_std'], '%', 100)}) at {h['nominal_distance_m']:g} m, "
         f"{h['nominal_illuminance_lx']:g} lx, {h['nominal_integration_time_s'] * 1e3:g} ms, "
         f"{h['nominal_temperature_c']:g} °C", nominal),
        ("amplitude at the nominal point", _fmt(h["nominal_amplitude_lsb"], "LSB"), nominal),
        ("valid data from (short-range saturation below)", *headline_figure(h, "valid_from_m", "m")),
        ("relative depth noise reaches 1 %", *headline_figure(h, "relative_noise_1pct_at_m", "m")),
        ("relative depth noise reaches 2 %", *headline_figure(h, "relative_noise_2pct_at_m", "m")),
        ("SBI engages at", *headline_figure(h, "sbi_engages_at_lx", "lx")),
        ("pixel saturates at", *headline_figure(h, "pixel_saturates_at_lx", "lx")),
        ("unambiguity range", _fmt(h["unambiguity_range_m"], "m"), "the configuration"),
    ]
    if multifrequency is not None:
        rows.append(("extended range (multi-frequency)", _fmt(float(multifrequency.extended_range_m), "m"),
                     "the configuration"))
    for line in result.caveat_lines():
        rows.append(("analytic path caveat", line, "this sweep (analytic)"))
    rows.append(("run time", f"{elapsed_s:.2f} s ({result.method}, {len(np.asarray(result.sweep_values))} samples"
                             + (f" x {result.n_frames} frames)" if result.n_frames else ")"), "this run"))
    regions = [f"{r['source']}: {r['from']:.4g} - {r['to']:.4g} {sweep_unit}" for r in h["dominant_noise"]]
    summary = Summary(f"tofjax simulation report: {result.sweep_variable} sweep", [f"Data: {csv_path}"], [
        Section("Headline figures", [Table(("figure", "value", "from"), tuple(rows)),
                                     "Dominant noise source along the sweep (photon transfer curve):", regions]),
        Section("Frame timing and eye safety", list(timing)),
        Section("Figures", list(figures)),
        Section("Configuration", [Code(config.to_toml())]),
    ])
    return write_text(directory / "report.html", summary.html())
