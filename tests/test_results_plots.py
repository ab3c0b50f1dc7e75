"""Issue 3: the data behind the plots, the closed-form estimates, multi-frequency range extension and
the report. Plots are checked through their data, not pixels."""

import jax
import numpy as np
import pytest
from matplotlib.figure import Figure

import tofjax as tj
from tofjax import plots
from tofjax import sweepfile as sf
from tofjax.cli import main


def _ideal(shape="pulse", duty=0.5, n=4, noise=False):
    return tj.Params(pixel=tj.Pixel(n_phases=n, noise=noise), adc=tj.ADC(enabled=False),
                     illumination_waveform=tj.IlluminationWaveform(shape=shape, duty_cycle=duty),
                     reference_waveform=tj.ReferenceWaveform(shape=shape, duty_cycle=duty))


@pytest.fixture(scope="module")
def runs():
    p = tj.Params()
    return {
        "distance": tj.simulate(p, tj.Sweep.linspace("distance", 0.3, 4.5, 60), jax.random.key(0), 100),
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


def test_ptc_total_is_the_quadrature_sum_and_snr_is_eq_5_1(runs):
    for r in runs.values():
        n = r.noise
        np.testing.assert_allclose(n.read_e**2, n.reset_e**2 + n.hold_e**2 + n.dark_shot_e**2, rtol=1e-12)
        np.testing.assert_allclose(n.total_e**2, n.read_e**2 + n.photon_shot_e**2 + n.quantization_e**2, rtol=1e-12)
        np.testing.assert_allclose(n.photon_shot_e**2, n.signal_e + n.background_e, rtol=1e-12)
        np.testing.assert_allclose(r.snr_db, 20 * np.log10(np.asarray(n.signal_e) / np.asarray(n.total_e)), rtol=1e-12)
    # Eq 5.1's example: 1e6 signal electrons over 1e3 noise electrons is 60 dB (the thesis prints 138 dB)
    assert 20 * np.log10(1e6 / 1e3) == pytest.approx(60.0)


def test_unwrapped_distance_is_monotonic_where_the_noise_is_small(runs):
    r = runs["distance"]
    mean = np.asarray(r.depth_unwrapped_mean_m)
    ok = np.isfinite(mean)
    assert np.all(np.diff(mean[ok]) > 0)
    frames = np.asarray(r.depth_unwrapped_m)
    near = np.asarray(r.distance_m) < 1.5  # frame noise (< 1 cm) far below the 7 cm sample step
    good = np.all(np.isfinite(frames[near & ok]), axis=1)
    assert np.all(np.diff(frames[near & ok][good], axis=0) > 0)


def test_cw_estimate_equals_the_analytic_path_for_sine_waveforms():
    p = _ideal("sine", 1.0, noise=True)
    sweep = tj.Sweep.linspace("distance", 0.5, 4.0, 15)
    analytic = np.asarray(tj.predict(p, sweep).depth_std_m)
    estimate = np.asarray(tj.cw_depth_noise(p, sweep))
    # The closed form is first order; the analytic path adds sigma_phi^2 / 2 relative, negligible below
    # sigma_phi = 0.1 rad.
    sigma_phi = analytic * 2 * np.pi / float(p.unambiguity_range_m)
    small = sigma_phi < 0.1
    assert small.sum() >= 6
    np.testing.assert_allclose(estimate[small], analytic[small], rtol=0.01)


@pytest.mark.parametrize("duty, lo, hi", [(0.25, 0.6, 1.2), (0.125, 0.3, 0.7)])
def test_pulsed_estimate_is_of_the_model_magnitude(duty, lo, hi):
    """Fig 5.18: estimate and model agree in magnitude at 25 % duty. At 12.5 % the pulse sits in the
    flat top of the correlation with the 50 % gate (Fig 5.4b) and the model's noise is ~2x the
    estimate, which ignores the mixing (docs/model.md)."""
    p = tj.Params(illumination_waveform=tj.IlluminationWaveform(duty_cycle=duty))
    sweep = tj.Sweep.linspace("distance", 0.6, 4.5, 10)
    ratio = np.asarray(tj.pulsed_depth_noise(p, sweep)) / np.asarray(tj.predict(p, sweep).depth_std_m)
    assert np.all((ratio > lo) & (ratio < hi)), ratio


def test_dual_frequency_extends_the_range():
    assert tj.extended_range_m([80.32e6, 60.24e6]) == pytest.approx(7.465, abs=1e-3)
    d = np.linspace(0.01, 7.4, 300)
    dim = tj.Params(**{**_ideal("sine", 1.0).__dict__, "illumination": tj.Illumination(peak_power_w=1e-3)})
    noise_free = tj.simulate_multifrequency(dim, tj.Sweep("distance", d), jax.random.key(0), 2, [80.32e6, 60.24e6])
    assert np.all(noise_free.valid)
    np.testing.assert_allclose(np.asarray(noise_free.depth_m)[:, 0], d, atol=1e-9)
    assert not np.any(noise_free.wrong_unwrap)
    noisy = tj.simulate_multifrequency(tj.Params(scene=tj.Scene(illuminance_lx=0.0)),
                                       tj.Sweep.linspace("distance", 0.5, 7.4, 12), jax.random.key(1), 1500,
                                       [80.32e6, 60.24e6])
    wrong = np.asarray(noisy.wrong_unwrap_fraction)
    assert np.all(wrong[:5] == 0.0)  # high SNR: never wrong
    assert wrong[-1] > 0.1 and wrong[-1] > wrong[len(wrong) // 2]  # rises with distance
    # combining frequencies beats each one alone where unwrapping is reliable
    per = np.asarray(noisy.per_frequency.depth_std_m)
    assert np.all(np.asarray(noisy.depth_std_m)[:5] < per[:, :5].min(axis=0))
    fig = plots.multifrequency_distance(noisy)
    assert isinstance(fig, Figure)
    with pytest.raises(ValueError, match="two or more distinct frequencies"):
        tj.simulate_multifrequency(tj.Params(), tj.Sweep("distance", [1.0]), jax.random.key(0), 2, [80e6])


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


@pytest.mark.parametrize("sweep", ["distance", "illuminance", "integration_time"])
def test_report_writes_csv_pngs_and_html(tmp_path, capsys, sweep):
    out = tmp_path / sweep
    assert main(["simulate", "--sweep", sweep, "--samples", "30", "--iterations", "100", "--report", str(out)]) == 0
    assert "report:" in capsys.readouterr().out
    assert sf.read_sweep(out / "sweep.csv").n_rows == 30
    html = (out / "report.html").read_text()
    assert html.count("data:image/png;base64,") == len(plots.applicable(sweep)) + 3  # + taps, waveforms, FoV
    for name in plots.applicable(sweep):
        assert (out / f"{name}.png").stat().st_size > 1000
    for text in ("Headline figures", "SBI engages at", "relative depth noise reaches 1 %", "Dominant noise source",
                 "[pixel]", "run time"):
        assert text in html


def test_headlines_are_physical():
    from tofjax.report import headlines

    r = tj.predict(tj.Params(), tj.Sweep.linspace("distance", 0.5, 4.5, 30))
    h = headlines(tj.Params(), r)
    assert 0.2 < h["valid_from_m"] < 0.5
    assert h["valid_from_m"] < h["relative_noise_1pct_at_m"] < h["relative_noise_2pct_at_m"]
    assert 100 < h["sbi_engages_at_lx"] < 1000 and h["pixel_saturates_at_lx"] is None
    no_sbi = headlines(tj.Params(pixel=tj.Pixel(sbi=False)), r)
    assert no_sbi["pixel_saturates_at_lx"] == pytest.approx(h["sbi_engages_at_lx"], rel=0.05)
    sources = [region["source"] for region in h["dominant_noise"]]
    assert sources == ["photon shot noise", "read noise"]  # shot noise near, read noise far


def test_multifrequency_from_the_configuration(tmp_path, capsys):
    cfg = tmp_path / "dual.toml"
    cfg.write_text("[illumination_waveform]\nextra_modulation_frequencies_hz = [60.24e6]\n")
    out = tmp_path / "dual.csv"
    assert main(["simulate", "--config", str(cfg), "--sweep", "distance", "--from", "0.5", "--to", "7", "--samples",
                 "8", "--iterations", "200", "--out", str(out)]) == 0
    assert "extended range 7.4650 m" in capsys.readouterr().out
    data = sf.read_sweep(out)
    assert data.metadata["modulation_frequencies_hz"] == "80320000.0,60240000.0"
    assert {"wrong_unwrap_fraction", "depth_std_m_f1", "depth_std_m_f2"} <= set(data.columns)
    assert np.all(np.abs(data.columns["depth_mean_m"] - data.columns["distance_m"]) < 0.1)
    bad = tmp_path / "bad.toml"
    bad.write_text("[illumination_waveform]\nextra_modulation_frequencies_hz = [80.32e6]\n")
    assert main(["simulate", "--config", str(bad), "--sweep", "distance", "--out", str(out)]) == 2
    assert "repeats a frequency" in capsys.readouterr().err
