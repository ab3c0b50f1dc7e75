"""The analytic path (tofjax/_analytic.py): the whole chain against closed forms and the thesis'
results (ch. 5), its caveats, the smooth mode's values and gradients, any shape of operating
points; JAX transformations of the public API."""

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

import tofjax as tj


def _ideal(n, ill="pulse", ref="pulse", ill_duty=0.5, ref_duty=0.5):
    """Noise-free, ADC-free camera with the given waveforms."""
    return tj.Params(
        pixel=tj.Pixel(n_phases=n, noise=False), adc=tj.ADC(enabled=False),
        illumination_waveform=tj.IlluminationWaveform(shape=ill, duty_cycle=ill_duty),
        reference_waveform=tj.ReferenceWaveform(shape=ref, duty_cycle=ref_duty),
    )


@pytest.mark.parametrize("n", [2, 3, 4, 5])
def test_noise_free_sine_recovers_distance_to_a_micrometre(n):
    p = _ideal(n, "sine", "sine", 1.0, 1.0)
    d = np.linspace(0.3, 5.0, 300)
    r = tj.predict(p, tj.Sweep("distance", d))
    assert np.all(np.asarray(r.valid_fraction) == 1.0)  # SBI keeps 0.3 m unsaturated
    assert np.max(np.abs(np.asarray(r.depth_unwrapped_mean_m) - d)) < 1e-6
    wrapped = np.mod(d, float(p.unambiguity_range_m))
    err = np.abs(np.asarray(r.depth_mean_m) - wrapped)
    err = np.minimum(err, float(p.unambiguity_range_m) - err)
    assert np.max(err) < 1e-6


@pytest.mark.parametrize("n, oscillations, lo_cm, hi_cm", [(4, 4, 1.5, 3.0), (2, 4, 1.5, 3.0), (3, 6, 0.2, 1.0),
                                                           (5, 10, 0.05, 0.3)])
def test_rectangular_waveforms_wiggle(n, oscillations, lo_cm, hi_cm):
    """§5.3: ~2 cm wiggling for rectangular waveforms, its frequency set by the number of phases
    (with the odd harmonics of a 50 % square wave: N per range for even N, 2N for odd N, and
    a smaller error for odd N, §2.4.1.1)."""
    p = _ideal(n)
    du = float(p.unambiguity_range_m)
    d = 1.0 + np.arange(256) / 256 * du
    err = np.asarray(tj.predict(p, tj.Sweep("distance", d)).depth_unwrapped_mean_m) - d
    assert abs(np.mean(err)) < 1e-5  # the error oscillates around zero
    assert lo_cm < 100 * np.max(np.abs(err)) < hi_cm
    assert np.argmax(np.abs(np.fft.rfft(err - err.mean()))) == oscillations


def test_verification_magnitudes_of_section_5_5():
    """§5.5.1/5.5.3: amplitude ~180 LSB at 1 m and 2 ms; relative depth noise ~0.5 % at 1 m,
    rising with distance (with the ripple of a non-sinusoidal correlation, Figs 5.8, 5.10a)."""
    r = tj.predict(tj.Params(), tj.Sweep.linspace("distance", 0.45, 4.5, 82))
    d = np.asarray(r.distance_m)
    i = int(np.argmin(np.abs(d - 1.0)))
    assert 120 < float(r.amplitude_mean_lsb[i]) < 260
    rel = np.asarray(r.depth_std_m) / d
    assert 0.003 < rel[i] < 0.01
    assert np.polyfit(d, rel, 1)[0] > 0
    assert rel[-1] > 2 * rel[i]
    ripple_free = tj.predict(tj.Params(illumination_waveform=tj.IlluminationWaveform(shape="sine", duty_cycle=1.0),
                                       reference_waveform=tj.ReferenceWaveform(shape="sine", duty_cycle=1.0)),
                             tj.Sweep.linspace("distance", 0.45, 4.5, 82))
    assert np.all(np.diff(np.asarray(ripple_free.depth_std_m) / d) > 0)
    # The signal amplitude is linear in the integration time (the ADC's INL bends it by ~1e-6); with
    # noise on, the mean amplitude also carries the noise bias of |Z|, largest at short exposures.
    t = tj.predict(tj.Params(pixel=tj.Pixel(noise=False)), tj.Sweep.linspace("integration_time", 0.5e-3, 4e-3, 8))
    amp = np.asarray(t.amplitude_mean_lsb)
    np.testing.assert_allclose(amp / np.asarray(t.integration_time_s), amp[0] / 0.5e-3, rtol=1e-5)


@pytest.mark.parametrize("background", ["sunlight", "halogen"])
def test_sbi_keeps_the_pixel_unsaturated_far_beyond_saturation_without_it(background):
    lux = np.geomspace(1.0, 1e5, 200)
    sweep = tj.Sweep("illuminance", lux)
    with_sbi = tj.predict(tj.Params(scene=tj.Scene(background=background)), sweep)
    without = tj.predict(tj.Params(scene=tj.Scene(background=background), pixel=tj.Pixel(sbi=False)), sweep)
    sat_without = lux[np.asarray(without.pixel_saturated_fraction) > 0][0]
    engages = lux[np.asarray(with_sbi.sbi_active_fraction) > 0][0]
    assert 30 < sat_without < 3000  # a few hundred lux (thesis §5.5.2: SBI starts at 230 lx)
    assert engages == pytest.approx(sat_without, rel=0.05)  # SBI takes over where saturation would set in
    assert np.all(np.asarray(with_sbi.valid_fraction) == 1.0)  # 400x beyond, still unsaturated
    assert np.all(np.isnan(np.asarray(without.depth_std_m)[lux >= sat_without * 1.05]))
    # Fig 5.15: beyond the engage point the taps' final voltages no longer change.
    beyond = lux > 2 * engages
    for v in (with_sbi.tap_a_v, with_sbi.tap_b_v):
        v = np.asarray(v)[beyond]
        np.testing.assert_allclose(v - v[0], 0.0, atol=1e-9)


def test_tap_voltages_are_the_held_charges_on_the_integration_capacitance():
    """``tap_a_v``, ``tap_b_v`` and ``differential_v`` (computed on access) are V_reset - n e / C_int
    of the held electrons (§3.2.4), each result with its own camera's reset voltage and capacitance,
    also when results are stacked (leading axis: the camera); ``intensity_e`` is their mean."""
    sweep = tj.Sweep("distance", np.linspace(0.5, 3.0, 5))
    cams = [(2.8, 20e-15), (3.3, 35e-15)]  # (V_reset, C_diode), C_sample&hold as configured
    pixels = [tj.Pixel(v_reset_v=v, c_diode_f=c) for v, c in cams]
    results = [tj.predict(tj.Params(pixel=p), sweep) for p in pixels]
    stacked = jax.tree_util.tree_map(lambda *x: jnp.stack(x), *results)
    e = 1.602176634e-19
    for i, ((v_reset, _), p, r) in enumerate(zip(cams, pixels, results, strict=True)):
        c_int = float(p.integration_capacitance_f)
        a, b = np.asarray(r.tap_a_e), np.asarray(r.tap_b_e)
        want_a, want_b = v_reset - a * e / c_int, v_reset - b * e / c_int
        for got in (r, jax.tree_util.tree_map(lambda x, i=i: x[i], stacked)):
            np.testing.assert_allclose(np.asarray(got.tap_a_v), want_a, rtol=1e-12)
            np.testing.assert_allclose(np.asarray(got.tap_b_v), want_b, rtol=1e-12)
            np.testing.assert_allclose(np.asarray(got.differential_v), want_b - want_a, rtol=1e-9, atol=1e-12)
        np.testing.assert_allclose(np.asarray(stacked.tap_b_v)[i], want_b, rtol=1e-12)
        np.testing.assert_allclose(np.asarray(stacked.intensity_e)[i], (a + b).mean(axis=-1) / 2, rtol=1e-14)
        np.testing.assert_allclose(np.asarray(stacked.differential_v)[i], want_b - want_a, rtol=1e-9, atol=1e-12)
    assert np.ptp(np.asarray(results[0].differential_v)) > 0.01  # a real signal, not a constant


def test_full_well_fraction_is_the_headroom_to_sbi_and_saturation():
    """full_well_fraction crosses 1 exactly where SBI engages (with SBI) or the pixel saturates
    (without), grows with the background light, and is the same in both paths."""
    lux = np.geomspace(1.0, 1e5, 200)
    sweep = tj.Sweep("illuminance", lux)
    for sbi in (True, False):
        p = tj.Params(scene=tj.Scene(background="halogen"), pixel=tj.Pixel(sbi=sbi))
        r = tj.predict(p, sweep)
        frac = np.asarray(r.full_well_fraction)
        flag = np.asarray(r.sbi_active_fraction if sbi else r.pixel_saturated_fraction) > 0
        assert np.all(np.diff(frac) > 0) and frac[0] < 1 < frac[-1]
        np.testing.assert_array_equal(frac >= 1, flag)
        mc = tj.simulate(p, tj.Sweep("illuminance", lux[::40]), jax.random.key(0), 5)
        np.testing.assert_allclose(np.asarray(mc.full_well_fraction), frac[::40], rtol=1e-12)
    # Closed form at the default point: both taps' expected charge at most the pair's total.
    r = tj.predict(tj.Params(), tj.Sweep("distance", [1.0]))
    n = r.noise
    full_well = (2.9 - 2.0) * 14e-15 / 1.602176634e-19
    upper = float(n.signal_e[0] + n.background_e[0] + n.dark_e[0]) / full_well
    assert upper / 2 < float(r.full_well_fraction[0]) < upper




PARAMS_TO_DIFF = {
    "contrast": "pixel.demodulation_contrast",
    "responsivity": "pixel.photo_responsivity_a_per_w",
    "dark_slope": "pixel.dark_slope_mean_v_per_s",
    "k_lens": "camera.k_lens",
}
LEAVES = tuple(PARAMS_TO_DIFF.values())


@eqx.filter_jit
def _smooth_values(x, params, sweep):
    """(depth std, mean amplitude) of the first point in the smooth mode, with the leaves LEAVES = x."""
    r = tj.predict(tj.schema.set_leaves(params, dict(zip(LEAVES, x, strict=True))), sweep, smooth=tj.Smooth())
    return jnp.stack([r.depth_std_m[0], r.amplitude_mean_lsb[0]])


#: d(depth std, amplitude) / d(LEAVES): one compilation per camera structure.
_smooth_jacobian = eqx.filter_jit(jax.jacfwd(_smooth_values))


def _check_smooth_gradients(base, sweep, names, rtol=1e-4):
    """The Jacobian against central finite differences (step 1e-6 relative) of both outputs, for
    the leaves ``names``; a derivative below 1e-6 of value/leaf counts as zero at this precision."""
    x0 = np.array([float(tj.schema.get_leaf(base, leaf)) for leaf in LEAVES])
    jac = np.asarray(_smooth_jacobian(jnp.asarray(x0), base, sweep))
    at = np.asarray(_smooth_values(jnp.asarray(x0), base, sweep))
    assert np.all(np.isfinite(jac))
    for name in names:
        i = LEAVES.index(PARAMS_TO_DIFF[name])
        h = np.zeros(len(LEAVES))
        h[i] = 1e-6 * abs(x0[i])
        up, down = (np.asarray(_smooth_values(jnp.asarray(x0 + sign * h), base, sweep)) for sign in (1, -1))
        fd = (up - down) / (2 * h[i])
        for k in range(2):
            g = jac[k, i]
            assert abs(g - fd[k]) <= rtol * max(abs(fd[k]), 1e-6 * abs(at[k]) / abs(x0[i])), (name, k, g, fd[k])


@pytest.mark.parametrize("case", ["nominal", "sbi_engaged", "tap_saturated"])
def test_smooth_gradients_match_finite_differences(case):
    """Depth noise and amplitude with respect to contrast, responsivity, dark slope and lens
    transmission, at the nominal point, where SBI engages, where a tap saturates."""
    if case == "nominal":
        base, d = tj.Params(), 1.0
    elif case == "sbi_engaged":
        base, d = tj.Params(), 0.33  # the high tap sits at the SBI threshold
    else:
        base, d = tj.Params(pixel=tj.Pixel(sbi=False)), 0.35  # a tap saturates (hard mode: invalid)
    sweep = tj.Sweep("distance", np.array([d]))
    hard = tj.predict(base, sweep)
    if case == "tap_saturated":
        assert float(hard.pixel_saturated_fraction[0]) == 1.0
    if case == "sbi_engaged":
        assert float(hard.sbi_active_fraction[0]) == 1.0 and float(hard.valid_fraction[0]) == 1.0
    _check_smooth_gradients(base, sweep, list(PARAMS_TO_DIFF))


def test_public_api_under_jit_vmap_grad():
    p = tj.Params()
    sweep = tj.Sweep.linspace("distance", 0.5, 4.0, 6)
    eager = tj.predict(p, sweep).depth_std_m
    jitted = jax.jit(lambda q: tj.predict(q, sweep).depth_std_m)(p)
    np.testing.assert_allclose(jitted, eager, rtol=1e-12)
    # Every field: called directly, predict runs three programs, the moments' without what the result
    # does not read (tofjax._analytic._UNREAD), and a table; under jit one program and the series.
    direct, traced = tj.predict(p, sweep), jax.jit(lambda q: tj.predict(q, sweep))(p)
    assert jax.tree_util.tree_structure(direct) == jax.tree_util.tree_structure(traced)
    for a, b in zip(jax.tree_util.tree_leaves(direct), jax.tree_util.tree_leaves(traced), strict=True):
        np.testing.assert_allclose(np.asarray(a), np.asarray(b), rtol=1e-12, atol=1e-12)

    contrasts = jnp.array([0.3, 0.42, 0.6])
    f = lambda c: tj.predict(eqx.tree_at(lambda q: q.pixel.demodulation_contrast, p, c), sweep).depth_std_m  # noqa
    batched = jax.vmap(f)(contrasts)
    np.testing.assert_allclose(batched, np.stack([f(c) for c in contrasts]), rtol=1e-12)
    # Depth noise scales as 1/contrast where shot noise of the unchanged electrons dominates.
    assert np.all(np.diff(np.asarray(batched), axis=0) < 0)

    def mc_loss(c):
        q = eqx.tree_at(lambda q: q.pixel.demodulation_contrast, p, c)
        return jnp.sum(tj.simulate(q, sweep, jax.random.key(0), 64, smooth=tj.Smooth()).depth_std_m)

    g = jax.grad(mc_loss)(0.42)
    assert np.isfinite(g) and g < 0

    sine = tj.Params(illumination_waveform=tj.IlluminationWaveform(shape="sine", duty_cycle=1.0),
                     reference_waveform=tj.ReferenceWaveform(shape="sine", duty_cycle=1.0))

    def distance_grad(d):
        return tj.predict(sine, tj.Sweep("distance", d[None])).depth_std_m[0]

    assert float(jax.grad(distance_grad)(jnp.asarray(2.0))) > 0  # noise grows with distance
    # A saturated point in the hard mode: NaN, and a gradient of 0, not NaN; tj.predict says so and
    # points to the smooth mode (an optimiser had no warning).
    assert np.isnan(distance_grad(jnp.asarray(0.05))) and float(jax.grad(distance_grad)(jnp.asarray(0.05))) == 0.0
    assert "their gradient is 0, not NaN" in " ".join(tj.predict.__doc__.split())
    assert "smooth=tj.Smooth()" in tj.predict.__doc__


def test_new_parameter_values_do_not_recompile():
    sweep = tj.Sweep.linspace("distance", 0.5, 4.0, 4)

    @eqx.filter_jit
    @eqx.debug.assert_max_traces(max_traces=1)
    def depth_noise(p):
        return tj.predict(p, sweep).depth_std_m

    depth_noise(tj.Params())
    # Replacement leaves must keep the dtype (a weakly typed jnp.asarray(0.3) would retrace).
    depth_noise(eqx.tree_at(lambda q: q.pixel.demodulation_contrast, tj.Params(), jnp.asarray(0.3, dtype=float)))
    depth_noise(tj.Params(scene=tj.Scene(illuminance_lx=500.0)))


def test_bad_arguments_raise_clear_errors():
    sweep = tj.Sweep.linspace("distance", 0.5, 4.0, 4)
    with pytest.raises(ValueError, match="iterations = 0 is out of range"):
        tj.simulate(tj.Params(), sweep, jax.random.key(0), 0)
    with pytest.raises(TypeError, match=r"camera must be a tofjax.Camera \(or, for the earlier sweep functions, a "
                                        r"tofjax.Params\), got dict"):
        tj.predict({"pixel": 1}, sweep)
    with pytest.raises(ValueError, match=r"scene.distance_m = .* is out of range: allowed 0 < value <= 1000"):
        tj.Sweep("distance", [-1.0, 2.0])
    with pytest.raises(ValueError, match="did you mean"):
        tj.Sweep("distanse", [1.0])
    with pytest.raises(ValueError, match="must be less than"):
        tj.Sweep.linspace("distance", 4.0, 1.0, 5)
    with pytest.raises(ValueError, match="Smooth.adc_temperature_lsb = 0.0"):
        tj.Smooth(adc_temperature_lsb=0.0)


def test_sweep_points_set_every_operating_quantity():
    d = np.array([0.8, 1.2, 2.0])
    lux = np.array([0.0, 100.0, 300.0])
    t = np.array([1e-3, 2e-3, 3e-3])
    r = tj.predict(tj.Params(), tj.Sweep.points("distance", d, lux, t))
    np.testing.assert_array_equal(r.distance_m, d)
    np.testing.assert_array_equal(r.illuminance_lx, lux)
    np.testing.assert_array_equal(r.integration_time_s, t)
    for i in range(3):
        one = tj.predict(tj.Params(scene=tj.Scene(illuminance_lx=lux[i], integration_time_s=t[i])),
                         tj.Sweep("distance", d[i:i + 1]))
        assert float(one.depth_std_m[0]) == pytest.approx(float(r.depth_std_m[i]), rel=1e-12)
    with pytest.raises(ValueError, match="sweep illuminance_lx has shape"):
        tj.Sweep.points("distance", d, lux[:2], t)
    with pytest.raises(ValueError, match="scene.integration_time_s = .* is out of range"):
        tj.Sweep.points("distance", d, lux, -t)


def test_caveats_say_where_the_closed_form_is_not_what_frames_show():
    """None at the nominal point; near a limit where the SBI floor or the full well is within the
    noise; an undithered ADC without noise; a wrapping phase at low SNR."""
    d = np.array([1.0, 0.3775, 6.0])
    r = tj.predict(tj.Params(pixel=tj.Pixel(sbi=False)), tj.Sweep("distance", d))
    codes = np.asarray(r.caveats)
    assert codes[0] == 0 and codes[1] & tj.schema.CAVEAT_NEAR_LIMIT and not codes[2] & tj.schema.CAVEAT_NEAR_LIMIT
    quiet = tj.predict(tj.Params(pixel=tj.Pixel(noise=False)), tj.Sweep("distance", d))
    assert np.all(np.asarray(quiet.caveats) & tj.schema.CAVEAT_COARSE_QUANTIZATION)
    dim = tj.predict(tj.Params(illumination=tj.Illumination(peak_power_w=0.02)), tj.Sweep("distance", d))
    assert np.asarray(dim.caveats)[2] & tj.schema.CAVEAT_LOW_SNR and "of 3 points: low SNR" in dim.caveat_summary()
    mc = tj.simulate(tj.Params(), tj.Sweep("distance", d), jax.random.key(0), 4)
    assert mc.caveats is None and mc.caveat_lines() == []
    # Printed (the README does), nothing to say is a sentence, not "[]".
    nominal = tj.predict(tj.Params(pixel=tj.Pixel(sbi=False)), tj.Sweep("distance", d[:1]))
    assert nominal.caveat_summary() == "no caveats: the closed form holds at every point"
    assert mc.caveat_summary().startswith("no caveats: a Monte Carlo result")


@pytest.mark.parametrize("sbi", [False, True])
def test_smooth_mode_is_bounded_and_differentiable_into_saturation(sbi):
    """Down to where every tap sits at the full well (SBI off) or the differential reaches it (SBI on):
    finite depth noise no larger than a uniform phase's, amplitudes within the ADC range, and
    gradients equal to finite differences."""
    p = tj.Params(pixel=tj.Pixel(sbi=sbi))
    d = np.geomspace(0.12, 0.6, 40)
    r = tj.predict(p, tj.Sweep("distance", d), smooth=tj.Smooth())
    for field in ("depth_std_m", "amplitude_mean_lsb", "amplitude_std_lsb", "depth_mean_m"):
        assert np.all(np.isfinite(np.asarray(getattr(r, field)))), field
    assert np.all(np.asarray(r.depth_std_m) <= float(p.unambiguity_range_m) / np.sqrt(12) * (1 + 1e-9))
    assert np.all(np.asarray(r.amplitude_mean_lsb) < 4096)
    for x in (0.15, 0.3, 0.36):
        _check_smooth_gradients(p, tj.Sweep("distance", [x]), ["contrast", "k_lens"], rtol=1e-3)
