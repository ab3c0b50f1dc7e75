"""The simulation report (``tofjax simulate --report DIR``): PNGs of every plot that applies to the
sweep, and one self-contained ``report.html`` (images embedded) with the configuration, headline
figures and the run's timing.

Headline figures come from the analytic path (hard mode) on dedicated scans, so they do not depend
on the chosen sweep's range: depth noise at the nominal point; the shortest distance with valid
data (below it the pixel or the ADC saturates); the distances where the relative depth noise crosses
1 % and 2 % (0.05-50 m); the background illuminance where SBI engages and where the pixel saturates
(0-200 klx at the nominal distance); and, from the run itself, the dominant noise source in each
region of the photon transfer curve.
"""

from __future__ import annotations

import base64
import html
from pathlib import Path

import jax
import numpy as np

from . import plots
from ._estimate import cw_depth_noise, pulsed_depth_noise
from ._analytic import predict
from ._schema import SWEEP_AXES
from ._sweep import Sweep
from .outputs import write_bytes, write_text


def _first(x: np.ndarray, mask: np.ndarray):
    return float(x[np.argmax(mask)]) if np.any(mask) else None


def headlines(params, result) -> dict:
    """The headline figures (module docstring) as a dict of plain numbers (None: not reached)."""
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
        "nominal_integration_time_s": nominal_t,
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
    return out


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


def write_report(directory, config, result, elapsed_s: float, csv_path, multifrequency=None) -> Path:
    """Write the PNGs and ``report.html`` into ``directory``; returns the HTML path."""
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    params = config.params
    figures: list[tuple[str, str, bytes]] = []
    for name in plots.applicable(result.sweep_variable):
        func, _, ref = plots.PLOTS[name]
        if name == "depth_noise" and result.sweep_variable == "distance":
            sweep = Sweep("distance", result.distance_m)
            fig = plots.depth_noise(result, estimates={"CW estimate": cw_depth_noise(params, sweep),
                                                       "pulsed estimate": pulsed_depth_noise(params, sweep)})
        else:
            fig = func(result)
        figures.append((name, ref, plots.to_png(fig)))
    figures.append(("tap_voltages", "Figs 5.2/5.15a", plots.to_png(plots.tap_voltages(result, params))))
    figures.append(("waveforms", "Fig 4.2", plots.to_png(plots.waveforms(params))))
    figures.append(("fov_footprint", "Fig 3.3", plots.to_png(plots.fov_footprint(params))))
    if multifrequency is not None:
        figures.append(("multifrequency", "§2.2, Fig 5.9", plots.to_png(plots.multifrequency_distance(multifrequency))))
    for name, _, data in figures:
        write_bytes(directory / f"{name}.png", data)

    h = headlines(params, result)
    sweep_unit = SWEEP_AXES[result.sweep_variable].unit
    rows = [
        ("depth noise at the nominal point", f"{_fmt(h['nominal_depth_std_m'], 'mm', 1e3)} "
         f"({_fmt(h['nominal_relative_depth_std'], '%', 100)}) at {h['nominal_distance_m']:g} m, "
         f"{h['nominal_illuminance_lx']:g} lx, {h['nominal_integration_time_s'] * 1e3:g} ms"),
        ("amplitude at the nominal point", _fmt(h["nominal_amplitude_lsb"], "LSB")),
        ("valid data from (short-range saturation below)", _fmt(h["valid_from_m"], "m")),
        ("relative depth noise reaches 1 %", _fmt(h["relative_noise_1pct_at_m"], "m")),
        ("relative depth noise reaches 2 %", _fmt(h["relative_noise_2pct_at_m"], "m")),
        ("SBI engages at", _fmt(h["sbi_engages_at_lx"], "lx") if params.pixel.sbi else "SBI disabled"),
        ("pixel saturates at (0-200 klx)", _fmt(h["pixel_saturates_at_lx"], "lx")),
        ("unambiguity range", _fmt(h["unambiguity_range_m"], "m")),
    ]
    if multifrequency is not None:
        rows.append(("extended range (multi-frequency)", _fmt(float(multifrequency.extended_range_m), "m")))
    for line in result.caveat_summary():
        rows.append(("analytic path caveat", line))
    rows.append(("run time", f"{elapsed_s:.2f} s ({result.method}, {len(np.asarray(result.sweep_values))} samples"
                             + (f" x {result.n_frames} frames)" if result.n_frames else ")")))
    regions = "".join(f"<li>{html.escape(r['source'])}: {r['from']:.4g} - {r['to']:.4g} {sweep_unit}</li>"
                      for r in h["dominant_noise"])
    table = "".join(f"<tr><th>{html.escape(k)}</th><td>{html.escape(v)}</td></tr>" for k, v in rows)
    images = "".join(
        f'<figure><img alt="{name}" src="data:image/png;base64,{base64.b64encode(data).decode()}">'
        f"<figcaption>{html.escape(name)} ({html.escape(ref)})</figcaption></figure>" for name, ref, data in figures)
    config_html = html.escape(config.to_toml())
    text = f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>tofjax report: {result.sweep_variable} sweep</title>
<style>body{{font-family:sans-serif;max-width:1100px;margin:auto;padding:1em}}table{{border-collapse:collapse}}
th,td{{border:1px solid #ccc;padding:4px 8px;text-align:left}}figure{{display:inline-block;margin:6px}}
img{{max-width:520px}}pre{{background:#f6f6f6;padding:8px;font-size:12px}}</style></head><body>
<h1>tofjax simulation report: {result.sweep_variable} sweep</h1>
<p>Data: <code>{html.escape(str(csv_path))}</code></p>
<h2>Headline figures</h2><table>{table}</table>
<h3>Dominant noise source along the sweep (photon transfer curve)</h3><ul>{regions}</ul>
<h2>Figures</h2>{images}
<h2>Configuration</h2><pre>{config_html}</pre>
</body></html>
"""
    return write_text(directory / "report.html", text)
