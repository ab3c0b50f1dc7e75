"""The centre-pixel signal chain end to end: :func:`predict` (analytic) and :func:`simulate`
(Monte Carlo) over a :class:`tofjax.Sweep`.

Order of the chain (thesis Fig 3.1): optical path -> mixer -> per-tap electrons -> shot and
reset noise -> SBI and saturation -> hold noise -> differential voltage -> ADC -> phase,
amplitude and depth. Saturation acts on the noisy charge, as it does in the pixel; the thesis
applies it before noise (§3.2.5), which lets a saturated tap carry noise beyond its limit.
"""

from __future__ import annotations

from typing import NamedTuple

import equinox as eqx
import jax
import jax.numpy as jnp
import jax.random as jr
from jaxtyping import Array, Float, PRNGKeyArray

from . import _adc, _depth, _saturation
from ._background import background_photon_irradiance
from ._mixer import tap_photo_electrons
from ._noise import dark_electrons, hold_noise_e, reset_noise_e
from ._optics import active_electrons, background_electrons
from ._params import Params
from ._result import NoiseBreakdown, Result
from ._sweep import Sweep
from ._waveforms import waveform_mean


def _f64(x) -> Array:
    return jnp.asarray(x, dtype=float)


class Smooth(eqx.Module):
    """Temperatures of the smooth relaxation (differentiable everywhere; hard mode as they -> 0).

    **Fields:**
    - ``saturation_temperature_v``: half-width of the soft saturation and SBI switching, V at the
      tap (1 mV = 87 electrons at 14 fF); exact where every tap is further than that from a limit.
    - ``adc_temperature_lsb``: width of each smoothed quantiser step and of the soft ADC rails,
      LSB; physically the rms input noise that would blur the staircase that much.
    """

    saturation_temperature_v: Float[Array, ""] = eqx.field(converter=_f64, default=1e-3)
    adc_temperature_lsb: Float[Array, ""] = eqx.field(converter=_f64, default=0.3)

    def __check_init__(self):
        for name in ("saturation_temperature_v", "adc_temperature_lsb"):
            value = getattr(self, name)
            if not isinstance(value, jax.core.Tracer) and not float(value) > 0.0:
                raise ValueError(f"Smooth.{name} = {float(value)!r} is out of range: allowed value > 0")


class _Expected(NamedTuple):
    """Expected electrons of each sweep sample before any noise or limit."""

    distance_m: Array
    illuminance_lx: Array
    integration_time_s: Array
    photo_a: Array  # (samples, phases)
    photo_b: Array
    active_e: Array  # (samples,)
    background_e: Array
    dark_a: Array
    dark_b: Array


def _check_inputs(params, sweep) -> None:
    if not isinstance(params, Params):
        raise TypeError(f"params must be a tofjax.Params, got {type(params).__name__}")
    if not isinstance(sweep, Sweep):
        raise TypeError(f"sweep must be a tofjax.Sweep, got {type(sweep).__name__}")


def _expected(params: Params, sweep: Sweep, dark_slopes_v_per_s=None) -> _Expected:
    d, ev, t = sweep.operating_points(params.scene)
    scene, ill, consts = params.scene, params.illumination, params.constants
    active = active_electrons(params, d, t, waveform_mean(params.illumination_waveform))
    photon_irr = background_photon_irradiance(scene.background, ev, ill.wavelength_m, scene.filter_half_width_m, consts)
    background = background_electrons(params, d, photon_irr, t)
    photo_a, photo_b = jax.vmap(tap_photo_electrons, in_axes=(None, 0, 0, 0))(params, d, active, background)
    if dark_slopes_v_per_s is None:
        dark_a = dark_b = dark_electrons(params.pixel, t, consts)
    else:
        dark_a = dark_electrons(params.pixel, t, consts, dark_slopes_v_per_s[0])
        dark_b = dark_electrons(params.pixel, t, consts, dark_slopes_v_per_s[1])
    return _Expected(d, ev, t, photo_a, photo_b, active, background, dark_a, dark_b)


def _electrons_per_volt(params: Params) -> Array:
    return params.pixel.integration_capacitance_f / params.constants.elementary_charge_c


def _full_well_e(params: Params) -> Array:
    """N_sat = (V_reset - V_saturated) C_int / e."""
    return (params.pixel.v_reset_v - params.pixel.v_saturated_v) * _electrons_per_volt(params)


def _temperatures(params: Params, smooth: Smooth | None):
    if smooth is None:
        return None, None
    return smooth.saturation_temperature_v * _electrons_per_volt(params), smooth.adc_temperature_lsb


def _noise_breakdown(params: Params, ex: _Expected) -> NoiseBreakdown:
    reset = reset_noise_e(params.pixel, params.constants) * jnp.ones_like(ex.active_e)
    hold = hold_noise_e(params.pixel, params.constants) * jnp.ones_like(ex.active_e)
    dark = ex.dark_a + ex.dark_b
    reset_e, hold_e = jnp.sqrt(2.0) * reset, jnp.sqrt(2.0) * hold
    shot = jnp.sqrt(ex.active_e + ex.background_e)
    dark_shot = jnp.sqrt(dark)
    read = jnp.sqrt(reset_e**2 + hold_e**2 + dark_shot**2)
    quant_lsb = jnp.sqrt(_adc.quantization_variance_lsb2(params.adc))
    quant = quant_lsb * params.adc.lsb_v * _electrons_per_volt(params) * jnp.ones_like(ex.active_e)
    total = jnp.sqrt(read**2 + shot**2 + quant**2)
    return NoiseBreakdown(ex.active_e, ex.background_e, dark, reset_e, hold_e, shot, dark_shot, read, quant, total)


def _snr_db(noise: NoiseBreakdown) -> Array:
    """SNR = 20 log10(n_signal / n_total_noise), Eq 5.1."""
    return 20.0 * jnp.log10(noise.signal_e / noise.total_e)


def _taps_volts(params: Params, a: Array, b: Array):
    per_volt = _electrons_per_volt(params)
    return params.pixel.v_reset_v - a / per_volt, params.pixel.v_reset_v - b / per_volt


def _full_well_fraction(n_a: Array, n_b: Array, full_well: Array) -> Array:
    """Expected charge of the fullest tap (photo + dark electrons, before SBI and saturation) over
    the full well N_sat, per sample: SBI engages or the tap saturates above 1 (§3.2.5)."""
    return jnp.max(jnp.maximum(n_a, n_b), axis=-1) / full_well


def _nan_unless(ok: Array, x: Array) -> Array:
    return jnp.where(ok, x, jnp.nan)


@eqx.filter_jit
def predict(params: Params, sweep: Sweep, *, smooth: Smooth | None = None) -> Result:
    """Analytic prediction: expected signals, and standard deviations propagated from the noise
    variances through the chain (delta method).

    Each phase image's expected code and its variance come from linearising the chain at the
    expected tap charges: shot noise of every collected electron (signal, background, dark) and
    reset kTC noise before SBI/saturation, hold kTC noise after it, and the quantisation variance
    (q^2/12 for an ideal ADC, more with DNL).
    The depth and amplitude standard deviations follow from the gradients of the phase and
    amplitude estimators with respect to the phase images, with second-order terms: the amplitude
    mean includes the curvature term (the noise bias of |Z|), and the phase variance v becomes
    v (1 + v), the next order for circular complex Gaussian noise.

    **Arguments:**
    - ``params``: the camera (:class:`tofjax.Params`).
    - ``sweep``: the swept quantity and its values (:class:`tofjax.Sweep`).
    - ``smooth``: ``None`` (default) for the hard saturation and ADC, or a :class:`tofjax.Smooth`
      with temperatures for a differentiable relaxation.

    **Returns:** a :class:`tofjax.Result` with ``method = "analytic"`` and no per-frame fields.
    """
    _check_inputs(params, sweep)
    ex = _expected(params, sweep)
    adc, pixel = params.adc, params.pixel
    per_volt = _electrons_per_volt(params)
    full_well = _full_well_e(params)
    temp_e, temp_lsb = _temperatures(params, smooth)
    n_a = ex.photo_a + ex.dark_a[:, None]
    n_b = ex.photo_b + ex.dark_b[:, None]

    def after_limit(x):  # charge difference A - B -> expected code
        return _adc.expected_code(adc, _adc.code_position(adc, x / per_volt), temp_lsb)

    def chain(a, b):
        sa, sb = _saturation.saturate(a, b, full_well, pixel.sbi, temp_e)
        return after_limit(sa - sb)

    held_a, held_b = _saturation.saturate(n_a, n_b, full_well, pixel.sbi, temp_e)
    code = chain(n_a, n_b)
    ones = jnp.ones_like(n_a)
    _, slope_a = jax.jvp(lambda a: chain(a, n_b), (n_a,), (ones,))
    _, slope_b = jax.jvp(lambda b: chain(n_a, b), (n_b,), (ones,))
    _, slope_x = jax.jvp(after_limit, (held_a - held_b,), (ones,))
    if pixel.noise:
        reset2 = reset_noise_e(pixel, params.constants) ** 2
        hold2 = hold_noise_e(pixel, params.constants) ** 2
        var = slope_a**2 * (n_a + reset2) + slope_b**2 * (n_b + reset2) + slope_x**2 * 2.0 * hold2
        var = var + _adc.quantization_variance_lsb2(adc)
    else:
        var = jnp.zeros_like(code)

    values = code - _adc.mid_code(adc)
    n_phases = pixel.n_phases
    phase = _depth.phase_rad(_depth.demodulate(values))

    def amp_fn(v):
        return _depth.amplitude(_depth.demodulate(v), n_phases)

    grad_phase = jax.vmap(jax.grad(lambda v: jnp.angle(_depth.demodulate(v) + 0j)))(values)
    grad_amp = jax.vmap(jax.grad(amp_fn))(values)
    curvature = jnp.diagonal(jax.vmap(jax.hessian(amp_fn))(values), axis1=-2, axis2=-1)
    # Second-order mean of the amplitude: the noise raises E|Z| (the Rician bias, ~ s^2 / 2A).
    amp = jax.vmap(amp_fn)(values) + 0.5 * jnp.sum(curvature * var, axis=-1)
    var_phase = jnp.sum(grad_phase**2 * var, axis=-1)
    # Next order of the phase variance for circular complex Gaussian noise: s^2/A^2 (1 + s^2/A^2).
    var_phase = var_phase * (1.0 + var_phase)
    var_amp = jnp.sum(grad_amp**2 * var, axis=-1)
    std_phase, std_amp = _depth.safe_sqrt(var_phase), _depth.safe_sqrt(var_amp)

    pixel_sat, sbi_on = _saturation.flags(n_a, n_b, full_well, pixel.sbi)
    pixel_sat = jnp.any(pixel_sat, axis=-1)
    adc_sat = jnp.any(_adc.saturated(adc, _adc.code_position(adc, (held_a - held_b) / per_volt)), axis=-1)
    valid = ~pixel_sat & ~adc_sat
    keep = jnp.ones_like(valid) if smooth is not None else valid
    to_m = params.unambiguity_range_m / (2.0 * jnp.pi)
    unwrapped = _depth.unwrap_along_sweep(phase, keep)
    tap_a_v, tap_b_v = _taps_volts(params, held_a, held_b)
    noise = _noise_breakdown(params, ex)
    return Result(
        method="analytic", sweep_variable=sweep.variable, n_frames=0,
        sweep_values=sweep.values, distance_m=ex.distance_m, illuminance_lx=ex.illuminance_lx,
        integration_time_s=ex.integration_time_s, unambiguity_range_m=params.unambiguity_range_m,
        tap_a_e=held_a, tap_b_e=held_b, tap_a_v=tap_a_v, tap_b_v=tap_b_v, differential_v=tap_b_v - tap_a_v,
        code_mean=code, codes=None, phase_rad=None, depth_m=None, depth_unwrapped_m=None, amplitude_lsb=None,
        valid=None,
        depth_mean_m=_nan_unless(keep, to_m * phase),
        depth_unwrapped_mean_m=to_m * unwrapped,
        depth_std_m=_nan_unless(keep, to_m * std_phase),
        amplitude_mean_lsb=_nan_unless(keep, amp),
        amplitude_std_lsb=_nan_unless(keep, std_amp),
        intensity_e=jnp.mean(0.5 * (held_a + held_b), axis=-1),
        snr_db=_snr_db(noise), noise=noise,
        valid_fraction=valid.astype(float), pixel_saturated_fraction=pixel_sat.astype(float),
        adc_saturated_fraction=adc_sat.astype(float),
        sbi_active_fraction=jnp.any(sbi_on, axis=-1).astype(float),
        full_well_fraction=_full_well_fraction(n_a, n_b, full_well),
    )


def _pixel_dark_slopes(params: Params, key: PRNGKeyArray) -> Array:
    """Dark slopes (V/s) of taps A and B of one pixel drawn from the population: a gamma
    distribution (positive) with the configured mean and pixel-to-pixel sigma."""
    mean, sigma = params.pixel.dark_slope_mean_v_per_s, params.pixel.dark_slope_sigma_v_per_s
    ok = (mean > 0) & (sigma > 0)
    shape = jnp.where(ok, mean**2 / jnp.where(ok, sigma, 1.0) ** 2, 1.0)
    draw = jr.gamma(key, shape, (2,)) * jnp.where(ok, sigma**2 / jnp.where(ok, mean, 1.0), 0.0)
    return jnp.where(ok, draw, mean)


@eqx.filter_jit
def simulate(
    params: Params,
    sweep: Sweep,
    key: PRNGKeyArray,
    iterations: int = 2000,
    *,
    smooth: Smooth | None = None,
    fixed_pattern: bool = False,
) -> Result:
    """Monte Carlo simulation: ``iterations`` noisy frames at every sweep sample.

    Per frame, phase image and tap: Gaussian shot noise of every collected electron plus reset
    kTC noise, then SBI and saturation of the noisy charge, then hold kTC noise, the ADC, and the
    phase/amplitude/depth estimators. A frame is valid when no tap of any phase image saturated
    and no code hit an end of the ADC range; statistics use valid frames only.

    **Arguments:**
    - ``params``, ``sweep``: as :func:`tofjax.predict`.
    - ``key``: a ``jax.random`` key; the same key gives the same frames.
    - ``iterations``: frames per sample (static; each value compiles once).
    - ``smooth``: ``None`` for the hard mode, or :class:`tofjax.Smooth` temperatures.
    - ``fixed_pattern``: if true, the taps' dark slopes are drawn once (per key) from the
      pixel population (mean, sigma of ``pixel.dark_slope_*``) instead of taking the mean pixel.

    **Returns:** a :class:`tofjax.Result` with ``method = "mc"`` and the per-frame fields.
    """
    _check_inputs(params, sweep)
    if isinstance(iterations, bool) or not isinstance(iterations, int) or iterations < 1:
        raise ValueError(f"iterations = {iterations!r} is out of range: allowed integer >= 1")
    pattern_key, key = jr.split(key)
    ex = _expected(params, sweep, _pixel_dark_slopes(params, pattern_key) if fixed_pattern else None)
    adc, pixel = params.adc, params.pixel
    per_volt = _electrons_per_volt(params)
    full_well = _full_well_e(params)
    temp_e, temp_lsb = _temperatures(params, smooth)
    reset = reset_noise_e(pixel, params.constants)
    hold = hold_noise_e(pixel, params.constants)
    n_a = ex.photo_a + ex.dark_a[:, None]
    n_b = ex.photo_b + ex.dark_b[:, None]
    n_phases = pixel.n_phases

    def frames(k, a, b):  # one sweep sample: a, b of shape (phases,)
        a, b = a[None, :], b[None, :]
        if pixel.noise:
            z = jr.normal(k, (iterations, n_phases, 4))
            a_noisy = a + jnp.sqrt(a + reset**2) * z[..., 0]
            b_noisy = b + jnp.sqrt(b + reset**2) * z[..., 1]
            hold_a, hold_b = hold * z[..., 2], hold * z[..., 3]
        else:
            a_noisy = jnp.broadcast_to(a, (iterations, n_phases))
            b_noisy = jnp.broadcast_to(b, (iterations, n_phases))
            hold_a = hold_b = 0.0
        sat, sbi_on = _saturation.flags(a_noisy, b_noisy, full_well, pixel.sbi)
        held_a, held_b = _saturation.saturate(a_noisy, b_noisy, full_well, pixel.sbi, temp_e)
        u = _adc.code_position(adc, (held_a + hold_a - held_b - hold_b) / per_volt)
        code = _adc.quantize(adc, u, temp_lsb)
        adc_sat = _adc.saturated(adc, u)
        z_iq = _depth.demodulate(code - _adc.mid_code(adc))
        return (code, _depth.phase_rad(z_iq), _depth.amplitude(z_iq, n_phases),
                jnp.any(sat, axis=-1), jnp.any(adc_sat, axis=-1), jnp.any(sbi_on, axis=-1))

    keys = jr.split(key, sweep.samples)
    code, phase, amp, pixel_sat, adc_sat, sbi_on = jax.vmap(frames)(keys, n_a, n_b)
    valid = ~pixel_sat & ~adc_sat
    mean_phase, std_phase, _ = _depth.circular_stats(phase, valid)
    amp_mean, amp_std = _depth.masked_mean_std(amp, valid)
    to_m = params.unambiguity_range_m / (2.0 * jnp.pi)
    unwrapped_frames = _depth.unwrap_along_sweep(phase, valid)
    has_mean = ~jnp.isnan(mean_phase)
    unwrapped_mean = _depth.unwrap_along_sweep(jnp.where(has_mean, mean_phase, 0.0), has_mean)
    held_a, held_b = _saturation.saturate(n_a, n_b, full_well, pixel.sbi, temp_e)
    tap_a_v, tap_b_v = _taps_volts(params, held_a, held_b)
    noise = _noise_breakdown(params, ex)
    return Result(
        method="mc", sweep_variable=sweep.variable, n_frames=iterations,
        sweep_values=sweep.values, distance_m=ex.distance_m, illuminance_lx=ex.illuminance_lx,
        integration_time_s=ex.integration_time_s, unambiguity_range_m=params.unambiguity_range_m,
        tap_a_e=held_a, tap_b_e=held_b, tap_a_v=tap_a_v, tap_b_v=tap_b_v, differential_v=tap_b_v - tap_a_v,
        code_mean=jnp.mean(code, axis=1), codes=code, phase_rad=phase, depth_m=to_m * phase,
        depth_unwrapped_m=to_m * unwrapped_frames, amplitude_lsb=amp, valid=valid,
        depth_mean_m=to_m * mean_phase, depth_unwrapped_mean_m=to_m * unwrapped_mean,
        depth_std_m=to_m * std_phase, amplitude_mean_lsb=amp_mean, amplitude_std_lsb=amp_std,
        intensity_e=jnp.mean(0.5 * (held_a + held_b), axis=-1),
        snr_db=_snr_db(noise), noise=noise,
        valid_fraction=jnp.mean(valid, axis=1), pixel_saturated_fraction=jnp.mean(pixel_sat, axis=1),
        adc_saturated_fraction=jnp.mean(adc_sat, axis=1), sbi_active_fraction=jnp.mean(sbi_on, axis=1),
        full_well_fraction=_full_well_fraction(n_a, n_b, full_well),
    )
