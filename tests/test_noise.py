"""The noise sources and the one noise budget (thesis §2.4.2, §3.2.3, §4.2.12-4.2.14;
tofjax/_noise.py): magnitudes computed by hand from the physics, the Monte Carlo's sampled variance,
and where each source acts."""

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import tofjax
from tofjax._chain import build_chain
from tofjax._noise import AFTER_LIMIT, BEFORE_LIMIT, NOISE_SOURCES, dark_electrons, hold_noise_e, reset_noise_e

CONSTS = tofjax.PhysicalConstants()
K_B, E, C_INT, C_SH, T_K = 1.380649e-23, 1.602176634e-19, 14e-15, 7e-15, 298.15


def test_ktc_noise_of_14_ff_at_25_c():
    pixel = tofjax.Pixel()  # C_diode = C_sample&hold = 7 fF
    assert float(reset_noise_e(pixel, CONSTS)) == pytest.approx(47.4, abs=0.05)
    # hold noise: kTC of 7 fF, referred to the 14 fF node
    assert float(hold_noise_e(pixel, CONSTS)) == pytest.approx(47.38 * np.sqrt(2), abs=0.1)


def test_dark_electrons_from_the_dark_slope():
    pixel = tofjax.Pixel()
    assert float(dark_electrons(pixel, 2e-3, CONSTS)) == pytest.approx(244.7, abs=0.05)
    assert float(dark_electrons(pixel, 4e-3, CONSTS)) == pytest.approx(2 * 244.7, abs=0.1)


def _camera(**pixel):
    """A pulsed camera (emitted energy = duty x peak, by hand) with an ideal-DNL ADC."""
    return tofjax.Params(pixel=tofjax.Pixel(**pixel), scene=tofjax.Scene(illuminance_lx=0.0),
                         illumination_waveform=tofjax.IlluminationWaveform(shape="pulse", duty_cycle=0.25),
                         adc=tofjax.ADC(differential_nonlinearity_lsb=0.0))


def test_breakdown_magnitudes_equal_the_physics_by_hand():
    """Signal electrons from Eq 3.11 and the responsivity, dark charge from the slope, kTC of both
    capacitors, an ideal quantiser's q^2/12: every entry of the breakdown, and the totals, as a
    data sheet would add them up (both taps of one phase image)."""
    d, t, readout = 1.7, 2e-3, 83.0
    r = tofjax.predict(_camera(readout_noise_e=readout), tofjax.Sweep("distance", [d]))
    n = r.noise
    flux = (1.2 * 0.9 * 0.9 / 1.4**2) * 17.5e-6**2 / (4 * math.pi * (math.tan(math.radians(37.5)) * d) ** 2)
    signal = flux * 0.25 * t * 0.23 / E  # W x duty x s x A/W / e
    dark = 1.4 * t * C_INT / E  # per tap
    reset2, hold2 = K_B * T_K * C_INT / E**2, K_B * T_K / C_SH * C_INT**2 / E**2
    lsb_e = 1.6 / 4096 * C_INT / E
    expected = {"signal_e": signal, "background_e": 0.0, "dark_e": 2 * dark,
                "photon_shot_e": math.sqrt(signal), "dark_shot_e": math.sqrt(2 * dark),
                "reset_e": math.sqrt(2 * reset2), "hold_e": math.sqrt(2 * hold2),
                "quantization_e": lsb_e / math.sqrt(12),
                "read_e": math.sqrt(2 * dark + 2 * reset2 + 2 * hold2 + 2 * readout**2),
                "total_e": math.sqrt(signal + 2 * dark + 2 * reset2 + 2 * hold2 + 2 * readout**2 + lsb_e**2 / 12)}
    for name, value in expected.items():
        assert float(getattr(n, name)[0]) == pytest.approx(value, rel=1e-9, abs=1e-12), name
    assert float(n.sources["readout"][0]) == pytest.approx(math.sqrt(2) * readout, rel=1e-12)
    assert float(r.snr_db[0]) == pytest.approx(20 * math.log10(signal / expected["total_e"]), rel=1e-9)
    assert [s.name for s in NOISE_SOURCES] == list(n.source_names)


def _code_variance_e2(params, distance_m, frames=40_000):
    """Variance of each phase image over Monte Carlo frames, electrons^2 (ADC off: codes are u)."""
    r = tofjax.simulate(params, tofjax.Sweep("distance", [distance_m]), jax.random.key(5), frames, keep_frames=frames)
    lsb_e = float(params.adc.lsb_v) * C_INT / E
    return np.var(np.asarray(r.codes)[0], axis=0, ddof=1) * lsb_e**2, r


def test_the_monte_carlo_samples_the_budget():
    """The frames' variance is the budget's total (both sampling paths: one draw per phase image
    where no limit is in reach, three draws where one is)."""
    p = tofjax.Params(adc=tofjax.ADC(enabled=False), pixel=tofjax.Pixel(readout_noise_e=83.0))
    for d in (1.3, 0.377):  # far from any limit; SBI engaging in some frames, not in others
        var, r = _code_variance_e2(p, d)
        np.testing.assert_allclose(var, float(r.noise.total_e[0]) ** 2, rtol=0.03)  # sqrt(2/40000) = 0.7 %
    assert 0.1 < float(r.sbi_active_fraction[0]) < 0.9 and float(r.valid_fraction[0]) == 1.0
    chain = build_chain(p)
    q = chain.expose(jnp.array([1.3, 0.377]), jnp.full(2, 20.0), jnp.full(2, 2e-3))
    sd_a, sd_b = (jnp.sqrt(v) for v in chain.noise.variance_e2(q, BEFORE_LIMIT))
    linear, _ = chain.limit.linear(q.a, q.b, 6.34 * sd_a, 6.34 * sd_b)
    assert bool(jnp.all(linear[0])) and not bool(jnp.all(linear[1]))  # both paths were taken


def test_sources_act_where_they_say():
    """A tap pinned at the full well passes none of its noise from before the limit, all from after."""
    p = tofjax.Params(adc=tofjax.ADC(enabled=False), pixel=tofjax.Pixel(sbi=False, readout_noise_e=60.0),
                      illumination_waveform=tofjax.IlluminationWaveform(shape="pulse", duty_cycle=0.5),
                      reference_waveform=tofjax.ReferenceWaveform(shape="pulse", duty_cycle=0.5))
    chain = build_chain(p)
    d = np.linspace(0.1, 0.4, 61)
    q = chain.expose(jnp.asarray(d), jnp.full(61, 20.0), jnp.full(61, 2e-3))
    var_a, var_b = chain.noise.variance_e2(q, BEFORE_LIMIT)
    after_a, after_b = chain.noise.variance_e2(q, AFTER_LIMIT)
    well = float(chain.limit.full_well_e)
    pinned = (np.asarray(q.a - 8 * jnp.sqrt(var_a)) > well) & (np.asarray(q.b + 8 * jnp.sqrt(var_b)) < well)
    i, j = np.argwhere(pinned)[0]  # a point and phase whose tap A is saturated in every frame, tap B never
    var, _ = _code_variance_e2(p, float(d[i]))
    expected = float(var_b[i, j] + after_a[i, j] + after_b[i, j])
    assert var[j] == pytest.approx(expected, rel=0.03)
    assert expected < 0.5 * float(var_a[i, j] + var_b[i, j] + after_a[i, j] + after_b[i, j])


def test_a_readout_noise_source_adds_its_closed_form():
    """The worked example of docs/model.md: a readout noise of s electrons per tap adds 2 s^2 to the
    differential variance, and the depth variance of a sinusoidal camera grows in proportion."""
    sine = dict(illumination_waveform=tofjax.IlluminationWaveform(shape="sine", duty_cycle=1.0),
                reference_waveform=tofjax.ReferenceWaveform(shape="sine", duty_cycle=1.0), adc=tofjax.ADC(enabled=False))
    sweep = tofjax.Sweep.linspace("distance", 0.5, 1.0, 6)  # high SNR: the depth variance is first order
    base = tofjax.predict(tofjax.Params(**sine), sweep)
    more = tofjax.predict(tofjax.Params(pixel=tofjax.Pixel(readout_noise_e=83.0), **sine), sweep)
    np.testing.assert_allclose(np.asarray(more.noise.total_e) ** 2 - np.asarray(base.noise.total_e) ** 2,
                               2 * 83.0**2, rtol=1e-9)
    ratio2 = (np.asarray(more.depth_std_m) / np.asarray(base.depth_std_m)) ** 2
    np.testing.assert_allclose(ratio2, np.asarray(more.noise.total_e / base.noise.total_e) ** 2, rtol=1e-3)
    assert np.all(ratio2 > 1.05)


def test_dark_current_doubles_every_doubling_temperature():
    """2^((T - T_ref) / T_2): one doubling temperature above the reference the mean dark electrons and
    the dark shot noise's variance double (the kTC noise changes too, but not the dark electrons); at
    the reference temperature nothing changes whatever T_2; d(dark)/dT = ln 2 / T_2 x dark."""
    sweep = tofjax.Sweep("distance", [1.5])

    def dark(**pixel):
        r = tofjax.predict(tofjax.Params(pixel=tofjax.Pixel(**pixel)), sweep)
        return float(r.noise.dark_e[0]), float(r.noise.sources["dark_shot"][0]) ** 2

    base, hot = dark(), dark(temperature_c=32.0)  # defaults: T_ref = 25 degC, T_2 = 7 degC
    np.testing.assert_allclose(hot, (2 * base[0], 2 * base[1]), rtol=1e-12)
    np.testing.assert_allclose(dark(temperature_c=11.0)[0], base[0] / 4, rtol=1e-12)
    assert dark(temperature_c=40.0, dark_reference_temperature_c=40.0, dark_doubling_temperature_c=3.0) == base
    grad = jax.grad(lambda t: tofjax.predict(tofjax.Params(pixel=tofjax.Pixel(temperature_c=t)), sweep).noise.dark_e[0])
    np.testing.assert_allclose(float(grad(25.0)), math.log(2) / 7.0 * base[0], rtol=1e-10)
