"""The Monte Carlo path (tofjax/_montecarlo.py, tofjax/_frames.py): agreement with the analytic path
down to low SNR, saturation flags, determinism, the random-number economy (one draw per phase image
where no limit is in reach), chunking in bounded memory, any shape of operating points."""

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

import tofjax as tj
from tofjax import _rician
from tofjax._chain import build_chain
from tofjax._frames import draw_frames
from tofjax._montecarlo import monte_carlo, prepare
from tofjax._pattern import pixel_dark_slopes
from tofjax._noise import AFTER_LIMIT, BEFORE_LIMIT
from tofjax._random import key_words


def test_monte_carlo_depth_noise_agrees_with_the_analytic_path():
    p = tj.Params()
    sweep = tj.Sweep.linspace("distance", 0.45, 4.5, 24)
    analytic = tj.predict(p, sweep)
    # 20 000 frames: the mean depth's standard error (<= 0.5 mm) sits well inside the 3 mm below.
    mc = tj.simulate(p, sweep, jax.random.key(11), 20_000)
    # Noise of one phase image in LSB, from the electron budget.
    per_volt = float(p.pixel.integration_capacitance_f / p.constants.elementary_charge_c)
    noise_lsb = np.asarray(analytic.noise.total_e) / per_volt / float(p.adc.lsb_v) * 1.05
    strong = np.asarray(analytic.amplitude_mean_lsb) > 20 * noise_lsb
    assert strong.sum() >= 4
    ratio = np.asarray(mc.depth_std_m)[strong] / np.asarray(analytic.depth_std_m)[strong]
    np.testing.assert_allclose(ratio, 1.0, atol=0.05)
    amp_ratio = np.asarray(mc.amplitude_mean_lsb)[strong] / np.asarray(analytic.amplitude_mean_lsb)[strong]
    np.testing.assert_allclose(amp_ratio, 1.0, atol=0.01)
    np.testing.assert_allclose(mc.depth_unwrapped_mean_m, analytic.depth_unwrapped_mean_m, atol=3e-3)


def test_progress_runs_the_same_chunks_from_the_host_in_cacheable_programs():
    """With ``progress``, the chunks run from the host: the same numbers as without, to rounding (the
    first test's run: its 24 points run padded as 32, in 5 chunks of 4000 frames), a tick per chunk,
    and programs without host callbacks, which JAX's persistent compilation cache keeps (with a
    callback in the program every process compiled the Monte Carlo anew: ``tofjax simulate`` on the
    defaults, 5 of its 7.4 s every run)."""
    import logging

    from helpers import Ticks

    from tofjax import progress

    class Log(logging.Handler):
        def __init__(self, level):
            super().__init__(level)
            self.lines = []

        def emit(self, record):
            self.lines.append(record.getMessage())

    p, sweep, key = tj.Params(), tj.Sweep.linspace("distance", 0.45, 4.5, 24), jax.random.key(11)
    quiet = tj.simulate(p, sweep, key, 20_000)
    log, logger = Log(level=logging.DEBUG), logging.getLogger("jax._src.compiler")
    level = logger.level
    logger.addHandler(log)
    logger.setLevel(logging.DEBUG)
    try:
        with progress.reporting(Ticks()) as ticks:
            loud = tj.simulate(p, sweep, key, 20_000, progress=True)
    finally:
        logger.removeHandler(log)
        logger.setLevel(level)
    assert (ticks.n, ticks.total) == (5, 5.0)
    for a, b in zip(jax.tree_util.tree_leaves(quiet), jax.tree_util.tree_leaves(loud), strict=True):
        # The same sums in the same order; XLA may round a chunk's reduction apart in another program.
        np.testing.assert_allclose(np.asarray(a), np.asarray(b), rtol=1e-13, atol=0)
    chunk = [line for line in log.lines if "frames_chunk" in line]
    assert chunk, "the chunk program was neither compiled nor read from the cache here"
    assert not [line for line in log.lines if "host callbacks" in line], log.lines


def _first_order_phase_std(phase_variance):
    """The delta method's first-order phase std behind a phase variance G(v) (inverting the table)."""
    v = np.geomspace(1e-7, 1e6, 20_001)
    return np.sqrt(np.interp(phase_variance, np.asarray(_rician.phase_variance(jnp.asarray(v))), v))


def test_low_snr_analytic_statistics_match_the_frames():
    """From the delta method's home down to a phase noise of 1.7 rad (the depth nearly uniform over the
    unambiguity range): depth noise within 2 % and mean amplitude within 1 % of 20 000 frames wherever
    the analytic path states no limit in reach (the shortest exposures hold so few electrons that the
    reset noise reaches the SBI floor at V_reset: flagged). The first-order phase variance alone, or the amplitude
    without its noise bias, would miss by up to 30 %: this test fails without the higher orders."""
    p = tj.Params()
    sweep = tj.Sweep.points("integration_time", np.full(8, 2.5), np.full(8, 20.0), np.geomspace(2e-5, 4e-4, 8))
    an = tj.predict(p, sweep)
    mc = tj.simulate(p, sweep, jax.random.key(3), 20_000)
    caveats = np.asarray(an.caveats)
    clean = (caveats & tj.schema.CAVEAT_NEAR_LIMIT) == 0
    assert clean.sum() >= 5 and np.sum((caveats[clean] & tj.schema.CAVEAT_LOW_SNR) != 0) >= 4
    depth = np.asarray(mc.depth_std_m) / np.asarray(an.depth_std_m)
    np.testing.assert_allclose(depth[clean], 1.0, atol=0.02)  # MC standard error 0.5 %
    amp = np.asarray(mc.amplitude_mean_lsb) / np.asarray(an.amplitude_mean_lsb)
    np.testing.assert_allclose(amp[clean], 1.0, atol=0.01)
    to_phase = 2 * np.pi / float(p.unambiguity_range_m)
    first = _first_order_phase_std((np.asarray(an.depth_std_m) * to_phase) ** 2) / to_phase
    assert np.max(np.abs(first[clean] / np.asarray(mc.depth_std_m)[clean] - 1)) > 0.3
    # Bounded by a uniform phase: never more than d_u / sqrt(12).
    assert np.all(np.asarray(an.depth_std_m) <= float(p.unambiguity_range_m) / np.sqrt(12))


def test_sunlight_at_a_short_exposure_is_bounded_flagged_and_right():
    """The issue's case (100 klx, 50 us, 1-6 m): the analytic depth noise is the wrapped phase's,
    bounded by d_u / sqrt(12) and within a few % of the frames, and flagged as low SNR."""
    p = tj.Params(scene=tj.Scene(illuminance_lx=1e5, integration_time_s=5e-5))
    sweep = tj.Sweep.linspace("distance", 1.0, 6.0, 11)
    an, mc = tj.predict(p, sweep), tj.simulate(p, sweep, jax.random.key(1), 8000)
    limit = float(p.unambiguity_range_m) / np.sqrt(12)
    assert np.all(np.asarray(an.depth_std_m) <= limit) and np.all(np.asarray(an.depth_std_m) > 0.9 * limit)
    np.testing.assert_allclose(np.asarray(mc.depth_std_m) / np.asarray(an.depth_std_m), 1.0, atol=0.03)
    assert np.all(np.asarray(an.caveats) & tj.schema.CAVEAT_LOW_SNR)
    assert any("low SNR" in line for line in an.caveat_lines()) and "low SNR" in an.caveat_summary()


def test_saturated_samples_are_flagged_and_never_zero():
    p = tj.Params(pixel=tj.Pixel(sbi=False))
    sweep = tj.Sweep("distance", np.array([0.2, 0.3, 1.0]))
    mc = tj.simulate(p, sweep, jax.random.key(0), 50, keep_frames=50)  # statistics of all 50 frames
    for r in (tj.predict(p, sweep), mc):
        vf = np.asarray(r.valid_fraction)
        assert vf[0] == 0.0 and vf[-1] == 1.0
        assert np.asarray(r.pixel_saturated_fraction)[0] == 1.0
        for field in (r.depth_mean_m, r.depth_std_m, r.amplitude_mean_lsb):
            assert np.isnan(np.asarray(field)[0]) and np.isfinite(np.asarray(field)[-1])
    assert not np.any(np.asarray(mc.valid)[0])


def test_noise_switch_and_determinism():
    sweep = tj.Sweep.linspace("distance", 0.5, 3.0, 5)
    quiet = tj.simulate(tj.Params(pixel=tj.Pixel(noise=False)), sweep, jax.random.key(0), 20)
    assert np.all(np.asarray(quiet.depth_std_m) == 0.0)
    assert np.all(np.asarray(tj.predict(tj.Params(pixel=tj.Pixel(noise=False)), sweep).depth_std_m) == 0.0)
    # 16 frames, all kept: the program of the raw-taps and recording tests' plain runs.
    a = tj.simulate(tj.Params(), sweep, jax.random.key(1), 16, keep_frames=16)
    b = tj.simulate(tj.Params(), sweep, jax.random.key(1), 16, keep_frames=16)
    c = tj.simulate(tj.Params(), sweep, jax.random.key(2), 16, keep_frames=16)
    np.testing.assert_array_equal(a.codes, b.codes)
    assert not np.array_equal(np.asarray(a.codes), np.asarray(c.codes))


def test_fixed_pattern_dark_slopes_follow_the_population():
    p = tj.Params()
    slopes = jax.vmap(lambda k: pixel_dark_slopes(p, k))(jax.random.split(jax.random.key(0), 20000))
    slopes = np.asarray(slopes).ravel()
    assert np.all(slopes > 0)
    assert np.mean(slopes) == pytest.approx(1.4, rel=0.02)
    assert np.std(slopes) == pytest.approx(1.0, rel=0.03)


@eqx.filter_jit
def _chunked(params, sweep, key, chunking):
    return monte_carlo(build_chain(params), sweep, key, 300, 40, chunking=chunking)


def test_results_do_not_depend_on_the_chunking():
    """A frame's noise is a function of (key, frame, point) only: chunks of 2 points x 38 frames, and
    of 7 points x 3 frames (fewer frames than points: drawn and summed frames first), give the
    frames and statistics of one chunk for everything (to summation rounding)."""
    p = tj.Params(pixel=tj.Pixel(sbi=False))
    sweep = tj.Sweep("distance", [0.36, 0.3775, 0.8, 1.4, 2.0, 2.6, 3.0])  # 0.3775 m saturates in half the frames
    whole = _chunked(p, sweep, jax.random.key(4), (1 << 20, 256))
    for chunking in ((320, 2), (84, 256)):
        small = _chunked(p, sweep, jax.random.key(4), chunking)
        np.testing.assert_array_equal(whole.codes, small.codes)
        for field in ("depth_std_m", "depth_mean_m", "amplitude_mean_lsb", "amplitude_std_lsb", "valid_fraction",
                      "pixel_saturated_fraction", "adc_saturated_fraction", "code_mean"):
            np.testing.assert_allclose(getattr(small, field), getattr(whole, field), rtol=1e-10, atol=1e-13,
                                       err_msg=f"{field}, chunking {chunking}")
    assert 0.1 < float(whole.valid_fraction[1]) < 0.9 and float(whole.valid_fraction[0]) == 0


def test_one_draw_per_phase_image_is_the_three_draw_path():
    """Where no limit is in reach, the one-draw path's frames have the statistics of the three-draw
    path's (independent streams): the same variance of every phase image and the same mean."""
    p = tj.Params(adc=tj.ADC(enabled=False))
    chain = build_chain(p)
    consts = prepare(chain, tj.Sweep("distance", [1.2])).consts
    assert bool(consts.linear[0])
    words = key_words(jax.random.key(8))
    fast = draw_frames(chain, consts, words, jnp.uint32(0), 40_000, linear=jnp.asarray([True])).codes[:, 0]
    full = draw_frames(chain, consts, words, jnp.uint32(0), 40_000, linear=jnp.asarray([False])).codes[:, 0]
    np.testing.assert_allclose(np.var(np.asarray(fast), axis=1), np.var(np.asarray(full), axis=1), rtol=0.04)
    sd = np.std(np.asarray(full), axis=1)
    np.testing.assert_allclose(np.mean(np.asarray(fast), axis=1), np.mean(np.asarray(full), axis=1),
                               atol=float(5 * np.max(sd) / np.sqrt(20_000)))
    assert abs(np.corrcoef(np.asarray(fast)[0], np.asarray(full)[0])[0, 1]) < 0.03  # not the same draws


def test_raw_taps_are_the_held_charges_plus_their_noise_and_digitise_to_the_codes():
    """The raw phase images' taps (draw_frames(taps=True)), on both paths, against closed forms: at
    1.2 m (no limit in reach) each tap reads its expected charge with the variance of every source
    on it (before and after the limit); at 0.3 m SBI always holds the fuller tap of each phase image
    at the full well, so it reads N_sat with only the noise after the limit, and the other
    N_sat - |n_A - n_B| with the difference's noise before the limit and its own after it. Their difference digitises to the
    frames' codes exactly, its code positions give the frames' ADC flags, and the frames themselves do
    not change when the taps are asked for."""
    p = tj.Params()
    chain = build_chain(p)
    sweep = tj.Sweep("distance", [0.3, 1.2])
    charges = prepare(chain, sweep).charges
    consts = prepare(chain, sweep).consts
    assert np.all(np.asarray(consts.linear)) and np.asarray(consts.sbi_fixed).tolist() == [True, False]
    var_a, var_b = (np.asarray(v) for v in chain.noise.variance_e2(charges, BEFORE_LIMIT))
    post_a, post_b = (np.broadcast_to(np.asarray(v), var_a.shape) for v in chain.noise.variance_e2(charges, AFTER_LIMIT))
    n_a, n_b, well = np.asarray(charges.a), np.asarray(charges.b), float(chain.limit.full_well_e)
    assert np.all(np.abs(n_a[0] - n_b[0]) > 10 * np.sqrt(var_a[0] + var_b[0]))  # which tap is fuller: fixed
    a_full = n_a[0] > n_b[0]
    low, before = well - np.abs(n_a[0] - n_b[0]), var_a[0] + var_b[0]
    expected_mean_a = np.stack([np.where(a_full, well, low), n_a[1]])
    expected_mean_b = np.stack([np.where(a_full, low, well), n_b[1]])
    expected_var_a = np.stack([post_a[0] + np.where(a_full, 0.0, before), var_a[1] + post_a[1]])
    expected_var_b = np.stack([post_b[0] + np.where(a_full, before, 0.0), var_b[1] + post_b[1]])
    words = key_words(jax.random.key(5))
    frames = 40_000
    for linear in (True, False):  # the one-draw and the three-draw paths
        path = jnp.asarray([linear, linear])
        f = draw_frames(chain, consts, words, jnp.uint32(0), frames, linear=path, taps=True)
        plain = draw_frames(chain, consts, words, jnp.uint32(0), frames, linear=path)
        np.testing.assert_array_equal(np.asarray(f.codes), np.asarray(plain.codes))
        readout = chain.readout
        np.testing.assert_array_equal(np.asarray(readout.quantize(readout.position(f.tap_a_e - f.tap_b_e))),
                                      np.asarray(f.codes))
        for taps, mean, var in ((f.tap_a_e, expected_mean_a, expected_var_a), (f.tap_b_e, expected_mean_b, expected_var_b)):
            taps = np.moveaxis(np.asarray(taps), 0, 1)  # (points, phases, frames)
            np.testing.assert_allclose(np.var(taps, axis=-1), var, rtol=0.04)  # 5.7 sigma of a variance of 40 000
            np.testing.assert_allclose(np.mean(taps, axis=-1), mean, atol=float(5 * np.sqrt(np.max(var) / frames)))
    # Through simulate(raw=True): the kept frames' taps beside their codes, the frames unchanged.
    kept = tj.simulate(p, sweep, jax.random.key(5), 16, keep_frames=16, raw=True)
    plain = tj.simulate(p, sweep, jax.random.key(5), 16, keep_frames=16)
    assert plain.frames_tap_a_e is None and kept.frames_tap_a_e.shape == kept.codes.shape == (2, 16, 4)
    np.testing.assert_array_equal(kept.codes, plain.codes)
    difference = kept.frames_tap_a_e - kept.frames_tap_b_e
    np.testing.assert_array_equal(chain.readout.quantize(chain.readout.position(difference)), kept.codes)
    # The frames' ADC flags (the draw reads them from the hard codes) against the code positions of the
    # taps' difference, not the codes: where the largest phase image reaches the top rail, some frames
    # of each point saturate and some do not (the same program as above).
    rail = tj.simulate(p, tj.Sweep("distance", [0.3065, 0.3075]), jax.random.key(5), 16, keep_frames=16, raw=True)
    u = chain.readout.position(rail.frames_tap_a_e - rail.frames_tap_b_e)
    flags = np.any(np.asarray(chain.readout.saturated(u)), axis=-1)  # (points, frames)
    assert 0 < flags.sum() < flags.size
    np.testing.assert_allclose(rail.adc_saturated_fraction, flags.mean(axis=-1), rtol=1e-12)


def test_memory_is_bounded_for_long_runs():
    """1000 points x 20 000 frames compile to a program whose buffers stay below 100 MB (the chunks),
    and a point's statistics over many frames are what the analytic path says."""
    p = tj.Params()
    sweep = tj.Sweep.linspace("distance", 0.45, 4.5, 1000)
    compiled = jax.jit(lambda q, k: tj.simulate(q, sweep, k, 20_000)).lower(p, jax.random.key(0)).compile()
    memory = compiled.memory_analysis()
    total = memory.temp_size_in_bytes + memory.output_size_in_bytes + memory.argument_size_in_bytes
    assert total < 100e6, total


def test_kept_frames_beyond_a_quarter_of_the_device_memory_are_refused_before_any_work(monkeypatch):
    """Statistics run in bounded memory for any size; returned frames are refused past a quarter of
    the device's memory with the largest allowed count, and the sweep runner keeps only that many.
    Here a device of 4 GiB (1 GiB of frames)."""
    from tofjax import _limits
    from tofjax._montecarlo import max_keep_frames

    monkeypatch.setattr(_limits, "device_memory_bytes", lambda: 4 << 30)
    most = max_keep_frames(1_000_000, 4)
    assert most == (1 << 30) // (1_000_000 * (8 * 4 + 33)) == 16
    sweep = tj.Sweep.linspace("distance", 0.5, 4.0, 1_000_000)
    with pytest.raises(ValueError, match=rf"^keep_frames = 17 is out of range for 1000000 operating points \(1.1 GB of "
                                         rf"frames\): allowed 0 <= value <= {most} \(frames returned take at most a "
                                         r"quarter of this device's 4.3 GB\); the statistics use every frame regardless$"):
        tj.simulate(tj.Params(), sweep, jax.random.key(0), 100, keep_frames=17)
    # With their raw phase images (both taps beside the codes) a kept frame takes 64 bytes more per phase.
    assert max_keep_frames(1_000_000, 4, raw=True) == (1 << 30) // (1_000_000 * (3 * 8 * 4 + 33)) == 8
    with pytest.raises(ValueError, match=r"keep_frames = 9 is out of range .* allowed 0 <= value <= 8 "):
        tj.simulate(tj.Params(), sweep, jax.random.key(0), 100, keep_frames=9, raw=True)
    # A device of 64 GiB keeps 16x as many.
    monkeypatch.setattr(_limits, "device_memory_bytes", lambda: 64 << 30)
    assert max_keep_frames(1_000_000, 4) == (16 << 30) // (1_000_000 * (8 * 4 + 33)) == 264


def test_device_memory_and_frame_chunks():
    """The device's memory is what JAX or the machine says (this suite runs on a CPU: its physical
    memory, within ulimit -v); frames are drawn in chunks of one 640 x 480 frame on a CPU and of an
    eighth of an accelerator's memory at 256 bytes a phase image, a power of two within bounds."""
    import os
    import resource

    from tofjax import _executor, _limits

    physical = os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    soft, _ = resource.getrlimit(resource.RLIMIT_AS)
    assert _limits.device_memory_bytes() == (physical if soft == resource.RLIM_INFINITY else min(physical, soft))
    assert _limits.kept_bytes_limit() == _limits.device_memory_bytes() // 4
    assert _executor.frame_chunk_elements() == _executor.FRAME_CHUNK_ELEMENTS == 1 << 21
    assert _executor.chunk_elements("cpu", 1 << 40) == 1 << 21
    # An H100 as JAX reports it (75 % of 80 GB): 60e9 / 256 = 234e6 -> 2^27; an 8 GB card's 6e9 -> 2^24.
    assert _executor.chunk_elements("gpu", 60_000_000_000) == 1 << 27
    assert _executor.chunk_elements("gpu", 6_000_000_000) == 1 << 24
    assert _executor.chunk_elements("gpu", 1 << 20) == 1 << 21  # never below a CPU's chunk
    assert _executor.chunk_elements("gpu", 1 << 50) == _executor.MAX_CHUNK_ELEMENTS == 1 << 28


def test_a_gpu_is_sized_by_what_jax_reports_and_a_silent_one_by_the_machine(monkeypatch):
    """The device's memory from ``memory_stats()["bytes_limit"]`` (an H200 as JAX reported it), and the
    frames' chunks from it; a device that cannot report its memory is bounded by the machine's."""
    import os
    import resource

    from tofjax import _executor, _limits

    class Device:
        platform = "gpu"

        def __init__(self, stats):
            self.stats = stats

        def memory_stats(self):
            if self.stats is None:
                raise NotImplementedError("memory_stats")
            return self.stats

    try:
        monkeypatch.setattr(jax, "devices", lambda: [Device({"bytes_limit": 112_583_507_968})])
        _limits.device_memory_bytes.cache_clear()
        assert _limits.device_memory_bytes() == 112_583_507_968
        assert _executor.frame_chunk_elements() == 1 << 28  # 112.6e9 / 256 = 440e6: the largest chunk
        monkeypatch.setattr(jax, "devices", lambda: [Device(None)])
        _limits.device_memory_bytes.cache_clear()
        physical = os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
        soft, _ = resource.getrlimit(resource.RLIMIT_AS)
        assert _limits.device_memory_bytes() == (physical if soft == resource.RLIM_INFINITY else min(physical, soft))
    finally:
        monkeypatch.undo()
        _limits.device_memory_bytes.cache_clear()
    assert _executor.frame_chunk_elements() == 1 << 21


def test_any_shape_of_operating_points():
    """A 2-D image of distances gives 2-D results, point for point those of the flattened sweep."""
    d = np.linspace(0.6, 3.0, 12)
    image = tj.simulate(tj.Params(), tj.Sweep("distance", d.reshape(3, 4)), jax.random.key(2), 64, keep_frames=3)
    flat = tj.simulate(tj.Params(), tj.Sweep("distance", d), jax.random.key(2), 64, keep_frames=3)
    assert image.depth_std_m.shape == (3, 4) and image.codes.shape == (3, 4, 3, 4)
    for field in ("depth_std_m", "amplitude_mean_lsb", "code_mean", "codes", "valid_fraction"):
        # Equal up to the last bit's rounding (XLA may fuse the two shapes differently).
        np.testing.assert_allclose(np.asarray(getattr(image, field)).reshape(np.shape(getattr(flat, field))),
                                   getattr(flat, field), rtol=1e-12, atol=0.0, err_msg=field)
    an = tj.predict(tj.Params(), tj.Sweep("distance", d.reshape(3, 4)))
    assert an.depth_std_m.shape == (3, 4) and an.noise.total_e.shape == (3, 4)
    np.testing.assert_allclose(np.asarray(an.depth_std_m).ravel(), tj.predict(tj.Params(), tj.Sweep("distance", d)).depth_std_m,
                               rtol=1e-12)
