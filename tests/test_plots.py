"""The plots of Table 4.9 (tofjax/plots.py), checked through their data, not pixels."""

import jax
import numpy as np
import pytest
from matplotlib.figure import Figure

import tofjax as tj
from tofjax import plots


def _ideal(shape="pulse", duty=0.5, n=4, noise=False):
    return tj.Params(pixel=tj.Pixel(n_phases=n, noise=noise), adc=tj.ADC(enabled=False),
                     illumination_waveform=tj.IlluminationWaveform(shape=shape, duty_cycle=duty),
                     reference_waveform=tj.ReferenceWaveform(shape=shape, duty_cycle=duty))


@pytest.fixture(scope="module")
def runs():
    p = tj.Params()
    return {
        "distance": tj.simulate(p, tj.Sweep.linspace("distance", 0.3, 4.5, 60), jax.random.key(0), 100, keep_frames=100),
        "illuminance": tj.predict(p, tj.Sweep.linspace("illuminance", 0.0, 5000.0, 40)),
        "integration_time": tj.predict(p, tj.Sweep.linspace("integration_time", 0.2e-3, 5e-3, 40)),
    }


def test_rectangular_cross_correlation_is_a_triangle():
    """Fig 2.6b/5.3a: a 50 % pulse pair correlates to triangles; with constant electrons (one
    unambiguity range at ~3.7 m, 1/d^2 nearly flat) the extrema are +-K N_s e / C."""
    p = _ideal()
    du = float(p.unambiguity_range_m)
    d = 3.0 + np.arange(400) / 400 * du
    r = tj.predict(p, tj.Sweep("distance", d))
    v = np.asarray(r.differential_v)[:, 0]
    scale = np.asarray(r.noise.signal_e) * float(p.pixel.demodulation_contrast) * 1.602176634e-19 / 14e-15
    shape = v / scale  # the correlation normalised by its electrons: 2 a - 1
    assert shape.max() == pytest.approx(1.0, abs=3e-3) and shape.min() == pytest.approx(-1.0, abs=3e-3)
    # piecewise linear: slopes of +-4 per period (from +1 to -1 in half a period), corners at the extrema
    slopes = np.diff(shape) / np.diff(d / du)
    straight = np.abs(np.abs(slopes) - 4.0) < 0.05
    assert straight.mean() > 0.95
    fig = plots.cross_correlation(r)
    np.testing.assert_array_equal(fig.axes[0].lines[0].get_ydata(), np.asarray(r.differential_v)[:, 0])


def test_unwrapped_distance_is_monotonic_where_the_noise_is_small(runs):
    r = runs["distance"]
    mean = np.asarray(r.depth_unwrapped_mean_m)
    ok = np.isfinite(mean)
    assert np.all(np.diff(mean[ok]) > 0)
    frames = np.asarray(r.depth_unwrapped_m)
    near = np.asarray(r.distance_m) < 1.5  # frame noise (< 1 cm) far below the 7 cm sample step
    good = np.all(np.isfinite(frames[near & ok]), axis=1)
    assert np.all(np.diff(frames[near & ok][good], axis=0) > 0)


@pytest.mark.parametrize("sweep", ["distance", "illuminance", "integration_time"])
def test_every_applicable_plot_draws_with_units(runs, sweep):
    r = runs[sweep]
    names = plots.applicable(sweep)
    assert ("wiggling" in names) == (sweep == "distance")  # Table 4.9: distance-only plots
    for name in names:
        fig = plots.PLOTS[name][0](r)
        assert isinstance(fig, Figure)
        for ax in fig.axes:
            assert "[" in ax.get_xlabel() or "electrons" in ax.get_xlabel()
            assert "[" in ax.get_ylabel() or ax.get_ylabel() == "electrons"
    for fig in (plots.tap_voltages(r, tj.Params()), plots.waveforms(tj.Params()),
                plots.fov_footprint(tj.Params()), plots.fov_footprint(tj.Params(illumination=tj.Illumination(
                    fov_deg=[60.0, 45.0])))):
        assert isinstance(fig, Figure)


def test_plots_draw_into_a_given_axes():
    fig = Figure()
    ax = fig.add_subplot()
    r = tj.predict(tj.Params(), tj.Sweep.linspace("distance", 0.5, 2.0, 5))
    assert plots.amplitude(r, ax=ax) is fig
    np.testing.assert_array_equal(ax.lines[0].get_ydata(), np.asarray(r.amplitude_mean_lsb))


def test_photon_transfer_curve_draws_every_source_of_the_budget(runs):
    """One line per noise source of the budget (and signal, totals, quantisation), with its data."""
    r = runs["illuminance"]
    fig = plots.photon_transfer_curve(r)
    lines = {line.get_label(): line.get_ydata() for line in fig.axes[0].lines}
    for name, value in r.noise.source_items():
        label = name.replace("_", " ") + " noise"
        if np.all(np.asarray(value) > 0):
            np.testing.assert_array_equal(np.sort(lines[label]), np.sort(np.asarray(value)))
    for label in ("signal", "total noise", "read noise", "quantisation"):
        assert label in lines


@pytest.mark.parametrize("n", [2, 4])
def test_the_correlation_preview_is_the_triangle_of_a_rectangular_pair(n):
    """§3.2.2, Eq 3.24: a 50 % pulse pair gives a_j(d) = 1 - 2 |d - theta_j / 2 pi| (periods, wrapped);
    the series' truncation at 1024 harmonics rounds the corners by ~2e-4. The delay axis is in ns at
    the configured frequency, the nominal distance sits at its round-trip delay."""
    from tofjax._waveforms import phase_steps

    p = _ideal(n=n)
    fig = plots.correlation_function(p)
    ax = fig.axes[0]
    period_ns = 1e9 / float(p.illumination_waveform.modulation_frequency_hz)
    curves = [line for line in ax.get_lines() if line.get_label().startswith("a_")]
    assert len(curves) == n
    for line, theta in zip(curves, phase_steps(n), strict=True):
        t, a = line.get_data()
        wrapped = np.mod(t / period_ns - theta / (2 * np.pi) + 0.5, 1.0) - 0.5
        np.testing.assert_allclose(a, 1.0 - 2.0 * np.abs(wrapped), atol=3e-4)
    marker = next(line for line in ax.get_lines() if line.get_label().startswith("nominal"))
    delay_ns = 2.0 * float(p.scene.distance_m) / 299792458.0 * 1e9
    assert marker.get_xdata()[0] == pytest.approx(delay_ns % period_ns, rel=1e-12)


def test_figure_csv_holds_the_plotted_curves_and_overlay_draws_the_previous_run():
    import csv
    import io

    near = tj.predict(tj.Params(), tj.Sweep.linspace("distance", 0.5, 2.0, 5))
    far = tj.predict(tj.Params(), tj.Sweep.linspace("distance", 1.0, 4.0, 7))
    fig = plots.tap_voltages(far, tj.Params())
    rows = list(csv.DictReader(io.StringIO(plots.figure_csv(fig))))
    assert {r["curve"] for r in rows} == {"V_A", "V_B"}  # the axhline references are not data
    got = np.array([float(r["y"]) for r in rows if r["curve"] == "V_B"])
    np.testing.assert_array_equal(got, np.asarray(far.tap_b_v)[:, 0])
    assert rows[0]["x_label"] == "distance [m]" and float(rows[1]["x"]) == pytest.approx(1.5, rel=1e-15)

    previous = plots.amplitude(near)
    fig = plots.amplitude(far)
    assert plots.overlay(fig, previous) == 1 and fig.get_suptitle() == "grey: previous run"
    grey = [line for line in fig.axes[0].get_lines() if line.get_gid() == plots.OVERLAY_GID]
    np.testing.assert_array_equal(grey[0].get_ydata(), np.asarray(near.amplitude_mean_lsb))
    # An overlay is neither overlaid again nor exported; figures whose axes do not pair are left alone.
    assert plots.overlay(plots.amplitude(near), fig) == 1
    assert len(list(csv.DictReader(io.StringIO(plots.figure_csv(fig))))) == 7
    assert plots.overlay(plots.fov_footprint(tj.Params()), previous) == 0


def _labels(axis, fig) -> list[str]:
    fig.canvas.draw()
    return [t.get_text() for t in axis.get_majorticklabels() if t.get_text() and t.get_visible()]


def test_every_axis_has_numbers_every_plot_with_several_curves_a_legend(runs):
    """The photon transfer curve of a sweep spanning less than a decade still has numbers on its x
    axis (it had none); calculated vs real says what its dots, line and bands are."""
    fig = plots.photon_transfer_curve(tj.predict(tj.Params(), tj.Sweep.linspace("distance", 0.45, 4.5, 50)))
    ax = fig.axes[0]
    lo, hi = ax.get_xlim()
    assert hi / lo < 10  # the default distance sweep's photo-electrons: less than a decade
    assert len(_labels(ax.xaxis, fig)) >= 2 and len(_labels(ax.yaxis, fig)) >= 2
    ax = plots.calculated_vs_real(runs["distance"]).axes[0]
    legend = [t.get_text() for t in ax.get_legend().get_texts()]
    assert legend == ["every other unambiguity interval", "frames (up to 100 per point)", "mean (circular)"]


def test_a_frame_maps_titles_fit_their_figure():
    """Every map's title line fits the 6.4-inch figure at matplotlib's default 12 pt (about 60
    characters); the error map's was 61 characters on one line and cut off."""
    from tofjax import frameio

    for title, _, _ in frameio.MAPS.values():
        assert max(map(len, title.splitlines())) <= 48, title
