"""The thesis' plots (Table 4.9, §3.3.4, §4.2.17, Figs 3.3, 4.2, 5.2-5.18) from simulation results.

Each function takes a result (and optionally an existing matplotlib ``Axes``) and returns the
``Figure``; axes carry units. Figures are built with ``matplotlib.figure.Figure`` directly, so
nothing here needs a display or pyplot. :data:`PLOTS` lists which plots apply to which sweep
(distance-only ones as Table 4.9 says).
"""

from __future__ import annotations

import csv
import io

import numpy as np
from matplotlib.figure import Figure
from matplotlib.ticker import LogFormatterSciNotation, LogLocator, NullFormatter

from ._schema import SWEEP_AXES, SWEEPS


def to_png(fig: Figure, dpi: float = 110) -> bytes:
    """The figure rendered as PNG bytes (Agg; no display needed)."""
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=dpi)
    return buf.getvalue()


def _axes(ax, ncols: int = 1, size=(6.4, 4.2)):
    if ax is not None:
        return ax.figure, ax
    fig = Figure(figsize=size, layout="constrained")
    return fig, fig.add_subplot(1, ncols, 1)


def _x(result):
    axis = SWEEP_AXES[result.sweep_variable]
    return np.asarray(result.sweep_values) * axis.display_scale, axis.axis_label


def waveforms(params, ax=None) -> Figure:
    """Illumination and reference waveforms over one period (Fig 4.2), in optical power units, on a
    time axis in nanoseconds at the configured modulation frequency."""
    from ._waveforms import waveform

    fig, ax = _axes(ax)
    t = np.linspace(-0.5, 0.5, 2001)
    period_ns = 1e9 / float(params.illumination_waveform.modulation_frequency_hz)
    peak = float(params.illumination.peak_power_w)
    ax.plot(t * period_ns, peak * np.asarray(waveform(params.illumination_waveform, t)),
            label=f"illumination ({params.illumination_waveform.shape}, "
                  f"{100 * float(params.illumination_waveform.duty_cycle):g} %)")
    ax.plot(t * period_ns, peak * np.asarray(waveform(params.reference_waveform, t)), "--",
            label=f"reference ({params.reference_waveform.shape}, {100 * float(params.reference_waveform.duty_cycle):g} %)"
                  " [x peak power]")
    ax.set_xlabel(f"time [ns] (one period: {period_ns:.4g} ns at "
                  f"{float(params.illumination_waveform.modulation_frequency_hz) / 1e6:.4g} MHz)")
    ax.set_ylabel("optical power [W]")
    ax.legend(fontsize=9)
    ax.grid(alpha=0.3)
    return fig


def correlation_function(params, ax=None) -> Figure:
    """The correlation functions a_j of the configured waveforms: the fraction of the modulated light
    tap A collects in phase image j over the reflection delay (one period; thesis §3.2.2, Eq 3.24),
    with the distance scale on top and the nominal distance marked."""
    from ._correlation import correlation
    from ._waveforms import phase_steps

    fig, ax = _axes(ax)
    frequency_hz = float(params.illumination_waveform.modulation_frequency_hz)
    period_ns = 1e9 / frequency_hz
    n = params.pixel.n_phases
    # The model's series at 4096 + 1 delays over the period, by one inverse FFT (its table's values).
    table = correlation(params.illumination_waveform, params.reference_waveform, n, points=4096).table
    a = np.asarray(table[:, :, 0])  # each cell's constant term: the value at its grid point
    a = np.concatenate([a, a[:1]])  # and the period's end
    delay = np.linspace(0.0, 1.0, a.shape[0])  # reflection delay in periods
    for j, theta in enumerate(np.degrees(phase_steps(n))):
        ax.plot(delay * period_ns, a[:, j], label=f"a_{j} ({theta:g} deg)")
    c = float(params.constants.speed_of_light_m_per_s)
    nominal = (2.0 * float(params.scene.distance_m) * frequency_hz / c) % 1.0
    ax.axvline(nominal * period_ns, color="k", ls=":", lw=0.8,
               label=f"nominal distance {float(params.scene.distance_m):g} m")
    ax.set_xlim(0.0, period_ns)
    ax.set_xlabel(f"reflection delay [ns] (one period at {frequency_hz / 1e6:.4g} MHz)")
    ax.set_ylabel("tap-A fraction of the modulated light")
    metres = 0.5 * c * 1e-9  # distance per ns of round-trip delay
    top = ax.secondary_xaxis("top", functions=(lambda t: t * metres, lambda m: m / metres))
    top.set_xlabel("distance [m] (within the unambiguity range)")
    ax.legend(fontsize=8, loc="lower left")
    ax.grid(alpha=0.3)
    return fig


def fov_footprint(params, distance_m: float | None = None, ax=None) -> Figure:
    """The illumination cone from the point source and the lit spot at ``distance_m`` (Fig 3.3)."""
    from ._optics import spot_area_m2

    d = float(params.scene.distance_m) if distance_m is None else float(distance_m)
    fov = np.atleast_1d(np.asarray(params.illumination.fov_deg, dtype=float))
    if ax is None:
        fig = Figure(figsize=(10, 4.2), layout="constrained")
        side, top = fig.add_subplot(1, 2, 1), fig.add_subplot(1, 2, 2)
    else:
        fig, side, top = ax.figure, ax, None
    half = d * np.tan(np.deg2rad(fov) / 2.0)
    r = half[0]
    side.fill([0, d, d], [0, r, -r], alpha=0.25, color="C1")
    side.plot([0, d, d, 0], [0, r, -r, 0], color="C1")
    side.plot([0], [0], "ko")
    side.set_xlabel("distance [m]")
    side.set_ylabel("height [m]")
    side.set_title(f"FoV {'x'.join(f'{f:g}' for f in fov)} deg, spot area "
                   f"{float(spot_area_m2(params.illumination, d)):.3g} m^2 at {d:g} m", fontsize=9)
    side.set_aspect("equal")
    if top is not None:
        if fov.size == 1:
            a = np.linspace(0, 2 * np.pi, 200)
            top.fill(r * np.cos(a), r * np.sin(a), alpha=0.25, color="C1")
        else:
            top.fill([-half[0], half[0], half[0], -half[0]], [-half[1], -half[1], half[1], half[1]], alpha=0.25,
                     color="C1")
        top.plot([0], [0], "k+")
        top.set_aspect("equal")
        top.set_xlabel("x [m]")
        top.set_ylabel("y [m]")
        top.set_title("lit spot on the target (circular: diagonal FoV; rectangular: [h, v])", fontsize=9)
    return fig


def cross_correlation(result, ax=None) -> Figure:
    """Differential voltage V_B - V_A of every phase image over the sweep (CC, Figs 5.3/5.4)."""
    from ._waveforms import phase_steps

    fig, ax = _axes(ax)
    x, label = _x(result)
    theta = np.degrees(phase_steps(result.differential_v.shape[-1]))
    for j, th in enumerate(theta):
        ax.plot(x, np.asarray(result.differential_v)[:, j], label=f"{th:g} deg")
    ax.set_xlabel(label)
    ax.set_ylabel("integrated differential voltage [V]")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    return fig


def tap_voltages(result, params, phase: int = 0, ax=None) -> Figure:
    """Tap voltages A and B of one phase image with the SBI threshold and V_reset (Figs 5.2, 5.15a)."""
    fig, ax = _axes(ax)
    x, label = _x(result)
    ax.plot(x, np.asarray(result.tap_a_v)[:, phase], label="V_A")
    ax.plot(x, np.asarray(result.tap_b_v)[:, phase], label="V_B")
    ax.axhline(float(params.pixel.v_reset_v), color="k", ls="--", lw=0.8, label="V_reset")
    ax.axhline(float(params.pixel.v_saturated_v), color="r", ls="--", lw=0.8, label="V_saturated (SBI threshold)")
    ax.set_xlabel(label)
    ax.set_ylabel("tap voltage at the end of the exposure [V]")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    return fig


def photon_transfer_curve(result, ax=None) -> Figure:
    """Noise electrons of each source over the light-generated electrons, log-log (Figs 5.12a, 5.14a,
    5.17a); the x axis counts signal and background photo-electrons of one phase image."""
    fig, ax = _axes(ax)
    n = result.noise
    x = np.asarray(n.signal_e) + np.asarray(n.background_e)
    order = np.argsort(x)
    curves = [(n.signal_e, "signal", "k-"), (n.total_e, "total noise", "C2-"), (n.read_e, "read noise", "C1-")]
    # Every source of the noise budget, dotted (the shot noise of the light solid).
    styles = {"photon_shot": "C4-", "reset": "C0:", "hold": "C5:", "dark_shot": "C7:"}
    curves += [(value, name.replace("_", " ") + " noise", styles.get(name, f"C{6 + i % 4}:"))
               for i, (name, value) in enumerate(n.source_items())]
    for values, name, style in curves + [(n.quantization_e, "quantisation", "C8:")]:
        y = np.asarray(values)[order]
        if np.all(y > 0):
            ax.loglog(x[order], y, style, label=name)
    ax.set_xlabel("photo-electrons per phase image (signal + background)")
    ax.set_ylabel("electrons")
    # Beside the axes, not over the curves; no labels on minor ticks (over less than a decade,
    # matplotlib labels them and they overlap).
    ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.02, 1.0), borderaxespad=0.0)
    for axis in (ax.xaxis, ax.yaxis):
        _log_ticks(axis)
    ax.grid(alpha=0.3, which="both")
    return fig


def _log_ticks(axis) -> None:
    """Numbers on a log axis whatever its span: over less than two decades ticks at 1, 2 and 5 of
    each decade, labelled (matplotlib labels only powers of ten there, so an axis within one decade
    had no number at all); minor ticks never labelled (they overlapped)."""
    lo, hi = sorted(axis.get_view_interval())
    if lo > 0 and hi / lo < 100:
        axis.set_major_locator(LogLocator(base=10.0, subs=(1.0, 2.0, 5.0)))
        axis.set_major_formatter(LogFormatterSciNotation(labelOnlyBase=False, minor_thresholds=(np.inf, np.inf)))
    axis.set_minor_formatter(NullFormatter())


def _over_sweep(result, values, ylabel: str, ax) -> Figure:
    fig, ax = _axes(ax)
    x, label = _x(result)
    ax.plot(x, np.asarray(values))
    ax.set_xlabel(label)
    ax.set_ylabel(ylabel)
    ax.grid(alpha=0.3)
    return fig


def snr(result, ax=None) -> Figure:
    """SNR = 20 log10(signal / total noise) in dB (Eq 5.1; Figs 5.12b, 5.14b, 5.17b)."""
    return _over_sweep(result, result.snr_db, "SNR [dB]", ax)


def amplitude(result, ax=None) -> Figure:
    """Amplitude in LSB (Figs 5.11a, 5.16a)."""
    return _over_sweep(result, result.amplitude_mean_lsb, "amplitude [LSB]", ax)


def depth_noise(result, relative: bool = False, estimates: dict | None = None, ax=None) -> Figure:
    """Depth standard deviation, absolute (mm) or relative to the distance (%) (Figs 5.7, 5.11b,
    5.13, 5.15b, 5.16b), with optional closed-form ``estimates`` {label: array in m} (Fig 5.18)."""
    fig, ax = _axes(ax)
    x, label = _x(result)
    scale = 100.0 / np.asarray(result.distance_m) if relative else 1e3
    ax.plot(x, np.asarray(result.depth_std_m) * scale, ".", ms=3 if result.n_frames else 0,
            ls="-" if not result.n_frames else "none", label=f"model ({result.method})")
    for name, values in (estimates or {}).items():
        ax.plot(x, np.asarray(values) * scale, "--", label=name)
    ax.set_xlabel(label)
    ax.set_ylabel("relative depth noise [%]" if relative else "depth noise [mm]")
    if estimates:
        ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    return fig


def _frames(result, values, limit=200):
    if values is None:
        return None
    v = np.asarray(values)
    return v[:, : min(limit, v.shape[1])]


def calculated_vs_real(result, ax=None) -> Figure:
    """Calculated (wrapped) distance over the real one, unambiguity intervals shaded (Fig 5.6a)."""
    fig, ax = _axes(ax)
    d = np.asarray(result.distance_m)
    du = float(result.unambiguity_range_m)
    for k in range(int(np.ceil(d.max() / du)) + 1):
        if k % 2 == 0:
            ax.axvspan(k * du, (k + 1) * du, color="0.9", label="every other unambiguity interval" if k == 0 else None)
    frames = _frames(result, result.depth_m)
    if frames is not None:
        ax.plot(np.repeat(d, frames.shape[1]), frames.ravel(), ",", color="C0", alpha=0.3)
        ax.plot([], [], ".", color="C0", label=f"frames (up to {frames.shape[1]} per point)")  # the legend's marker
    ax.plot(d, np.asarray(result.depth_mean_m), "C1-", lw=1, label="mean (circular)")
    ax.set_xlim(d.min(), d.max())
    ax.set_xlabel("real distance [m]")
    ax.set_ylabel("calculated distance [m]")
    ax.set_title(f"unambiguity range {du:.4f} m", fontsize=9)
    ax.legend(fontsize=8, loc="upper left")
    ax.grid(alpha=0.3)
    return fig


def unwrapped_vs_real(result, ax=None) -> Figure:
    """Unwrapped calculated distance over the real one (Figs 5.6b, 5.9)."""
    fig, ax = _axes(ax)
    d = np.asarray(result.distance_m)
    frames = _frames(result, result.depth_unwrapped_m, limit=20)
    if frames is not None:
        ax.plot(d, frames, lw=0.5, alpha=0.5)
    ax.plot(d, np.asarray(result.depth_unwrapped_mean_m), "k-", lw=1.2, label="mean")
    ax.plot(d, d, "k:", lw=0.8, label="ideal")
    ax.set_xlabel("real distance [m]")
    ax.set_ylabel("unwrapped calculated distance [m]")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    return fig


def wiggling(result, ax=None) -> Figure:
    """Mean calculated minus real distance (Figs 5.5, 5.10b)."""
    fig, ax = _axes(ax)
    d = np.asarray(result.distance_m)
    ax.plot(d, 100 * (np.asarray(result.depth_unwrapped_mean_m) - d))
    ax.set_xlabel("real distance [m]")
    ax.set_ylabel("mean distance error [cm]")
    ax.grid(alpha=0.3)
    return fig


def multifrequency_distance(result, ax=None) -> Figure:
    """Unwrapped distance of a multi-frequency sweep over the real one across the extended range,
    with the wrong-unwrap fraction (§2.2, Fig 5.9)."""
    fig, ax = _axes(ax)
    d = np.asarray(result.distance_m)
    frames = _frames(result, result.depth_m)
    if frames is not None:
        ax.plot(np.repeat(d, frames.shape[1]), frames.ravel(), ",", color="C0", alpha=0.3)
    ax.plot(d, np.asarray(result.depth_mean_m), "C1-", lw=1, label="mean")
    ax.plot(d, np.mod(d, float(result.extended_range_m)), "k:", lw=0.8, label="ideal")
    ax.set_xlabel("real distance [m]")
    ax.set_ylabel("unwrapped distance [m]")
    freqs = ", ".join(f"{f / 1e6:g}" for f in np.asarray(result.frequencies_hz))
    ax.set_title(f"{freqs} MHz: extended range {float(result.extended_range_m):.3f} m", fontsize=9)
    twin = ax.twinx()
    twin.plot(d, 100 * np.asarray(result.wrong_unwrap_fraction), "C3-", label="wrong unwraps")
    twin.set_ylabel("wrong unwraps [% of valid frames]", color="C3")
    ax.grid(alpha=0.3)
    return fig


#: The gid of the lines :func:`overlay` adds (so that an overlay is never overlaid again).
OVERLAY_GID = "tofjax-previous-run"


def _data_lines(ax):
    """The lines of ``ax`` drawn in data coordinates (not axhline/axvline references), not overlays."""
    return [line for line in ax.get_lines()
            if line.get_transform() == ax.transData and line.get_gid() != OVERLAY_GID]


def overlay(fig: Figure, previous: Figure, label: str = "previous run") -> int:
    """Draw the data lines of ``previous`` (the same plot of an earlier run) into ``fig``, thin and
    grey behind the new curves, axes by axes; notes it in the suptitle. Returns the lines drawn (0
    when the figures' axes do not pair up)."""
    if len(fig.axes) != len(previous.axes):
        return 0
    drawn = 0
    for ax, old in zip(fig.axes, previous.axes, strict=True):
        for line in _data_lines(old):
            x, y = line.get_data()
            ax.plot(x, y, color="0.6", ls=line.get_linestyle(), marker=line.get_marker(),
                    ms=line.get_markersize(), lw=max(0.8, 0.8 * line.get_linewidth()), alpha=0.8,
                    zorder=0.5, gid=OVERLAY_GID, label="_nolegend_")
            drawn += 1
    if drawn:
        title = fig.get_suptitle()
        fig.suptitle(f"{title}{'; ' if title else ''}grey: {label}", fontsize=10)
    return drawn


def figure_csv(fig: Figure) -> str:
    """The data of a figure's plotted curves as CSV in long form: one row per point with the panel
    (axes number and y label), the curve's label, and x and y with their axis labels. Reference
    lines (axhline/axvline) and overlays are not data and are left out."""
    out = io.StringIO()
    writer = csv.writer(out, lineterminator="\n")
    writer.writerow(["panel", "curve", "x_label", "x", "y_label", "y"])
    for i, ax in enumerate(fig.axes):
        panel = f"{i}: {ax.get_ylabel()}" if ax.get_ylabel() else str(i)
        lines = _data_lines(ax)
        for k, line in enumerate(lines):
            name = line.get_label()
            if name.startswith("_"):  # unlabelled: the panel's only curve is its y quantity
                name = ax.get_ylabel() if len(lines) == 1 else f"curve {k}"
            x, y = (np.asarray(v, dtype=float) for v in line.get_data())
            writer.writerows([panel, name, ax.get_xlabel(), repr(float(a)), ax.get_ylabel(), repr(float(b))]
                             for a, b in zip(x, y, strict=True))
    return out.getvalue()


#: Plot name -> (function, sweeps it applies to, thesis reference); Table 4.9.
PLOTS = {
    "cross_correlation": (cross_correlation, SWEEPS, "CC, Figs 5.3/5.4"),
    "photon_transfer_curve": (photon_transfer_curve, SWEEPS,
                              "PTC, Figs 5.12a/5.14a/5.17a"),
    "snr": (snr, SWEEPS, "SNR, Figs 5.12b/5.14b/5.17b"),
    "amplitude": (amplitude, SWEEPS, "Amplitudes, Figs 5.11a/5.16a"),
    "depth_noise": (depth_noise, SWEEPS, "DistNoise, Figs 5.7/5.13/5.16b"),
    "relative_depth_noise": (lambda r, ax=None: depth_noise(r, relative=True, ax=ax),
                             SWEEPS, "Figs 5.11b/5.13/5.16b"),
    "calculated_vs_real": (calculated_vs_real, ("distance",), "DistUnambiguity, Fig 5.6a"),
    "unwrapped_vs_real": (unwrapped_vs_real, ("distance",), "DistRealDist, Fig 5.6b"),
    "wiggling": (wiggling, ("distance",), "Wiggling, Fig 5.5"),
}


def applicable(sweep_variable: str) -> list[str]:
    """Names of the plots of :data:`PLOTS` that apply to a sweep (Table 4.9)."""
    return [name for name, (_, sweeps, _) in PLOTS.items() if sweep_variable in sweeps]
