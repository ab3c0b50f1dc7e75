"""Range extension with several modulation frequencies (thesis §2.2, Fig 5.9; tofjax/_multifrequency.py)."""

import equinox as eqx
import jax
import numpy as np
import pytest
from matplotlib.figure import Figure

import tofjax as tj
from tofjax import plots
from tofjax import sweepfile as sf
from tofjax.cli import main

from helpers import traces


def _ideal(shape="pulse", duty=0.5, n=4, noise=False):
    return tj.Params(pixel=tj.Pixel(n_phases=n, noise=noise), adc=tj.ADC(enabled=False),
                     illumination_waveform=tj.IlluminationWaveform(shape=shape, duty_cycle=duty),
                     reference_waveform=tj.ReferenceWaveform(shape=shape, duty_cycle=duty))


def test_dual_frequency_extends_the_range():
    assert tj.stats.extended_range_m([80.32e6, 60.24e6]) == pytest.approx(7.465, abs=1e-3)
    d = np.linspace(0.01, 7.4, 300)
    dim = tj.Params(**{**_ideal("sine", 1.0).__dict__, "illumination": tj.Illumination(peak_power_w=1e-3)})
    noise_free = tj.simulate(tj.Camera(dim, frequencies_hz=[80.32e6, 60.24e6]), tj.Sweep("distance", d), jax.random.key(0), 2, keep_frames=2)
    assert np.all(noise_free.valid)
    np.testing.assert_allclose(np.asarray(noise_free.depth_m)[:, 0], d, atol=1e-9)
    assert not np.any(noise_free.wrong_unwrap)
    noisy = tj.simulate(tj.Camera(tj.Params(scene=tj.Scene(illuminance_lx=0.0)), frequencies_hz=[80.32e6, 60.24e6]), tj.Sweep.linspace("distance", 0.5, 7.4, 12), jax.random.key(1), 1500, keep_frames=20)
    wrong = np.asarray(noisy.wrong_unwrap_fraction)
    assert np.all(wrong[:5] == 0.0)  # high SNR: never wrong
    assert wrong[-1] > 0.1 and wrong[-1] > wrong[len(wrong) // 2]  # rises with distance
    # The closed form of the rate (the union bound over the candidates) against the frames: within 3
    # binomial standard errors (1500 frames) plus 0.02 up to a rate of 0.2; above, an upper bound (the
    # union bound counts a frame two candidates beat twice, and the noise wraps: 0.57 against 0.42).
    closed = np.asarray(tj.predict(tj.Camera(tj.Params(scene=tj.Scene(illuminance_lx=0.0)),
                                             frequencies_hz=[80.32e6, 60.24e6]),
                                   tj.Sweep.linspace("distance", 0.5, 7.4, 12)).wrong_unwrap_fraction)
    assert np.all(closed[:5] < 1e-6) and closed[-1] > 0.1
    tolerance = 3.0 * np.sqrt(wrong * (1 - wrong) / 1500) + 0.02
    small = wrong < 0.2
    assert np.all(np.abs(closed - wrong)[small] < tolerance[small]) and np.all(closed > wrong - tolerance)
    # combining frequencies beats each one alone where unwrapping is reliable
    per = np.asarray(noisy.per_frequency.depth_std_m)
    assert np.all(np.asarray(noisy.depth_std_m)[:5] < per[:, :5].min(axis=0))
    # Called directly, the 12 points run padded to 16 (tofjax._executor.padded): a 16-point sweep of
    # those 12 and 4 more runs the same programs, and its first 12 points are those frames, to the bit
    # (the per-frequency leaves' points after the frequencies' axis).
    more = np.concatenate([np.linspace(0.5, 7.4, 12), [1.0, 2.0, 3.0, 4.0]])
    traced, longer = traces(lambda: tj.simulate(tj.Camera(tj.Params(scene=tj.Scene(illuminance_lx=0.0)),
                                                          frequencies_hz=[80.32e6, 60.24e6]),
                                                tj.Sweep("distance", more), jax.random.key(1), 1500, keep_frames=20))
    assert traced == [], f"a 16-point sweep should run the padded 12-point sweep's programs: {traced}"
    for (path, a), b in zip(jax.tree_util.tree_leaves_with_path(noisy), jax.tree_util.tree_leaves(longer), strict=True):
        name = jax.tree_util.keystr(path)
        per_frequency = "per_frequency" in name  # (frequencies, points, ...)
        if name.endswith(("frequencies_hz", "extended_range_m")) or np.ndim(b) <= int(per_frequency):
            expected = b  # per call
        else:
            expected = b[:, :12] if per_frequency else b[:12]
        assert np.shape(a) == np.shape(expected), name
        np.testing.assert_array_equal(a, expected, err_msg=name)
    # With progress, the chunks run from the host (tofjax._executor.drive_blocks): the same result, to
    # rounding (the tap voltages' difference is computed in another program).
    loud = tj.simulate(tj.Camera(tj.Params(scene=tj.Scene(illuminance_lx=0.0)), frequencies_hz=[80.32e6, 60.24e6]), tj.Sweep.linspace("distance", 0.5, 7.4, 12), jax.random.key(1), 1500, keep_frames=20, progress=True)
    for a, b in zip(jax.tree_util.tree_leaves(noisy), jax.tree_util.tree_leaves(loud), strict=True):
        np.testing.assert_allclose(np.asarray(b), np.asarray(a), rtol=1e-13, atol=1e-15)
    fig = plots.multifrequency_distance(noisy)
    assert fig.axes[0].lines[0].get_xdata().size == 12 * 20  # the kept frames
    assert isinstance(fig, Figure)
    with pytest.raises(ValueError, match="two or more distinct frequencies"):
        tj.simulate(tj.Camera(tj.Params(), frequencies_hz=[80e6]), tj.Sweep("distance", [1.0]), jax.random.key(0), 2)


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


def test_every_frequency_keeps_its_raw_phase_images():
    """A multi-frequency camera's kept frames carry each frequency's raw phase images: both taps as
    read, whose difference digitises to that frequency's codes, and the frames are the same with and
    without them."""
    from tofjax._chain import build_chain

    freqs = (80.32e6, 60.24e6)
    camera = tj.Camera(tj.Params(), frequencies_hz=freqs)
    sweep = tj.Sweep("distance", [0.6, 1.7, 3.1])
    # The frame counts of test_dual_frequency_extends_the_range: ``plain`` runs its compiled program.
    raw = tj.simulate(camera, sweep, jax.random.key(3), 1500, keep_frames=20, raw=True)
    plain = tj.simulate(camera, sweep, jax.random.key(3), 1500, keep_frames=20)
    per = raw.per_frequency
    assert per.frames_tap_a_e.shape == per.frames_tap_b_e.shape == per.codes.shape == (2, 3, 20, 4)
    np.testing.assert_array_equal(per.codes, plain.per_frequency.codes)
    np.testing.assert_allclose(raw.depth_m, plain.depth_m, rtol=1e-15)  # another program: rounding
    for i, f in enumerate(freqs):
        chain = build_chain(eqx.tree_at(lambda p: p.illumination_waveform.modulation_frequency_hz, camera.params, f))
        difference = np.asarray(per.frames_tap_a_e[i]) - np.asarray(per.frames_tap_b_e[i])
        np.testing.assert_array_equal(chain.readout.quantize(chain.readout.position(difference)), per.codes[i])


def test_a_frame_of_several_frequencies_is_fused_pixel_by_pixel():
    """A wall at 3 m, beyond either frequency's range (1.87, 2.49 m): the fused frame reads it where
    each frequency alone wraps; its Monte Carlo noise is the closed form's; the noisy frames of a
    prepared camera and of an exposed scene are the same; the wrapped flag counts the extended range."""
    from helpers import small

    params = small(tj.Params(scene=tj.Scene(illuminance_lx=0.0)))
    camera = tj.Camera(params, frequencies_hz=(80.32e6, 60.24e6))
    scene = tj.scenes.wall(3.0)
    analytic = tj.predict(camera, scene)
    assert float(analytic.result.unambiguity_range_m) == pytest.approx(7.465, abs=1e-3)
    error = np.asarray(analytic.radial_m - analytic.radial_true_m)
    assert np.all(np.abs(error) < 0.05)  # the wiggling of the two frequencies, not a wrap
    with pytest.warns(tj.schema.NoGoodPixelsWarning, match="beyond the unambiguity range"):  # one frequency wraps
        assert np.nanmedian(np.asarray(tj.predict(tj.Camera(params), scene).radial_m)) < 1.87
    assert not np.any(np.asarray(analytic.flags) & 8)
    assert np.all(np.asarray(analytic.result.wrong_unwrap_fraction) < 0.2)
    mc = tj.simulate(camera, scene, jax.random.key(0), 200, keep_frames=2)
    ratio = np.asarray(mc.depth_std_m) / np.asarray(analytic.depth_std_m)
    assert np.nanmedian(ratio) == pytest.approx(1.0, abs=0.05)
    assert mc.frames_radial_m.shape == (2,) + analytic.radial_m.shape
    a = camera.expose(scene).sample(jax.random.key(1), 2)
    b = camera.prepare().sample(camera.returns(scene), jax.random.key(1), 2)
    np.testing.assert_allclose(np.asarray(a.radial_m), np.asarray(b.radial_m), rtol=1e-12)  # other programs
    near = np.abs(np.asarray(a.radial_m) - np.asarray(analytic.radial_true_m)[None])[np.asarray(a.valid)] < 0.5
    wrong = float(np.mean(np.asarray(analytic.result.wrong_unwrap_fraction)))
    assert 1.0 - near.mean() < wrong + 0.03  # the frames a wrong unwrap takes, at the closed form's rate
    _the_host_driven_render_is_few_cacheable_programs(camera, scene, mc)


def _the_host_driven_render_is_few_cacheable_programs(camera, scene, mc):
    """With ``progress`` (chunk by chunk from the host, as the command line runs it) the same frames
    as in one program, to rounding; the run's setup and finish are programs (their operations, run
    one by one, compiled ~190 programs in every process: the README's corner render 2.4 s of its 19),
    and the prepared camera's program holds no host callback (a check of returns already checked
    made it one, which JAX's persistent cache never keeps: 1.4 s of every render's start)."""
    import jax._src.dispatch as dispatch

    from helpers import Ticks

    from tofjax import progress
    from tofjax._multiframe import _camera_prepare

    prepared, returns = camera.prepare(), camera.returns(scene)
    assert "callback" not in str(jax.make_jaxpr(lambda r: _camera_prepare(prepared, r))(returns))
    frame = prepared.prepare(returns)
    eager, real = [], dispatch.xla_primitive_callable  # every operation run on its own (jax < 0.11)
    dispatch.xla_primitive_callable = lambda prim, **kw: eager.append(prim.name) or real(prim, **kw)
    try:
        with progress.reporting(Ticks()) as ticks:
            loud = frame.render(jax.random.key(0), 200, keep_frames=2, progress=True)
    finally:
        dispatch.xla_primitive_callable = real
    assert ticks.n == ticks.total >= 1
    assert len(eager) <= 10, eager
    for a, b in zip(jax.tree_util.tree_leaves(loud), jax.tree_util.tree_leaves(mc), strict=True):
        np.testing.assert_allclose(np.asarray(a), np.asarray(b), rtol=1e-12, atol=1e-15)


def test_phase_average_weights_each_distance_by_its_frequency():
    from tofjax._multifrequency import fusion_weights

    ranges = np.array([1.0, 2.0, 4.0])
    w = np.asarray(fusion_weights(np.ones((3, 2)), ranges, "phase_average"))
    np.testing.assert_allclose(w[:, 0] / w[0, 0], [1.0, 0.5, 0.25])
