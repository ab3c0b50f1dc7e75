"""The analytic path: :func:`predict` folds means and variances through the chain's stages in order
(:meth:`tofjax.chain.Chain.moments`), in closed form per operating point (docs/model.md, "Analytic path").

Per phase image: the noise sources before the limit give each tap's variance; the limit passes
them to the held differential with its closed-form slopes; the sources after the limit add theirs;
the readout's gain compression maps the variance exactly and the mean to first order (a cubic of a
Gaussian); the readout's slope carries the variance to the code, and the quantisation variance
joins it. The demodulation's delta method then gives phase and amplitude statistics with the higher orders of a
phasor in Gaussian noise (:func:`tofjax._depth.delta_method`). No stage is differentiated
numerically; the cost per operating point is a few hundred flops and O(phases) memory.
"""

from __future__ import annotations

import dataclasses

import jax.numpy as jnp
from jaxtyping import Array

from . import _depth, _executor, _jit
from ._adc import saturated
from ._chain import Chain, kept_chain
from ._charges import Exposure, TapCharges
from ._params import Params
from ._reduce import max_last, min_last
from ._result import CAVEAT_COARSE_QUANTIZATION, CAVEAT_LOW_SNR, CAVEAT_NEAR_LIMIT, Result
from ._pattern import PixelPattern, one_pixel
from ._smooth import Smooth
from ._stages import Moments
from ._sweep import Sweep, check_inputs, unpad

#: Standard deviations within which a limit makes the analytic statistics a caveat.
_NEAR = 3.0


def full_well_fraction(n_a: Array, n_b: Array, full_well: Array) -> Array:
    """Expected charge of the fullest tap (photo + dark electrons, before SBI and saturation) over
    the full well N_sat, per operating point: SBI engages or the tap saturates above 1 (§3.2.5).
    ``full_well``: a scalar, or one per point with a trailing axis of 1 (a frame's pixels)."""
    if jnp.ndim(full_well) == 0:
        return max_last(jnp.maximum(n_a, n_b)) / full_well
    return max_last(jnp.maximum(n_a, n_b) / full_well)


def headroom(chain: Chain, n_a: Array, n_b: Array, u: Array) -> Array:
    """The nearest hard limit's distance at the expected tap charges ``n_a``, ``n_b`` (before the
    limit) and code positions ``u``, as a fraction of its range, per point: the smallest over the
    phase images of the limit stage's headroom over the full well (saturation; with SBI the taps'
    difference) and the readout's distance to the ADC's nearer rail over its 2^N codes. > 0 where
    the hard model measures the point's expected charges (:attr:`tofjax.Result.headroom`)."""
    limit, readout = chain.limit, chain.readout
    pixel = limit.headroom(n_a, n_b) / limit.full_well_e
    adc = readout.headroom(u) / 2.0**readout.adc.resolution_bits
    return min_last(jnp.minimum(pixel, adc))


def unwrap_if_sweep(phase: Array, keep: Array) -> Array:
    """Unwrap along a 1-D sweep (§5.4); other shapes have no sweep order and stay wrapped."""
    if phase.ndim == 1:
        return _depth.unwrap_along_sweep(phase, keep)
    return jnp.where(keep, phase, jnp.nan)


def _nan_unless(ok: Array, x: Array) -> Array:
    return jnp.where(ok, x, jnp.nan)


def moments(chain: Chain, sweep: Sweep, charges: TapCharges | None = None, image: bool = False) -> Moments:
    """The moments through the chain's stages (:meth:`tofjax.chain.Chain.moments`); ``charges``: the
    exposure's, if computed; ``image``: the operating points are a frame's pixels."""
    if charges is None:
        charges = chain.expose(*sweep.operating_points(chain.params))
    return chain.moments(charges, image)


def analytic(chain: Chain, sweep: Sweep, m: Moments | None = None) -> Result:
    """:func:`predict` on a built chain (module docstring); ``m``: its :func:`moments`, if computed."""
    params = chain.params
    d, ev, t, temp = sweep.operating_points(params)
    m = moments(chain, sweep) if m is None else m
    charges, var_a, var_b, held_a, held_b, var_held = m.charges, m.var_a, m.var_b, m.a, m.b, m.var_diff
    code, u, slope_u = m.code, m.u, m.slope_u
    phase, var_phase, v_first, amp, var_amp = m.phase, m.var_phase, m.v_first, m.amp, m.var_amp
    n_a, n_b = charges.a, charges.b
    limit, readout, noise = chain.limit, chain.readout, chain.noise

    pixel_sat, sbi_on = limit.flags(n_a, n_b)
    pixel_sat = jnp.any(pixel_sat, axis=-1)
    adc_sat = jnp.any(saturated(params.adc, u), axis=-1)
    # A point that receives none of the camera's light reads a phase of noise alone: no distance.
    valid = ~pixel_sat & ~adc_sat & (charges.signal_e > 0.0)
    keep = jnp.ones_like(valid) if readout.temperature_lsb is not None else valid

    # Caveats: a limit within the noise, a staircase the noise does not dither, a wrapping phase.
    sd_u = jnp.sqrt(slope_u**2 * var_held)  # input noise of the ADC, LSB
    near = ~limit.passes(n_a, n_b, _NEAR * jnp.sqrt(var_a), _NEAR * jnp.sqrt(var_b))
    near = near | saturated(params.adc, u - _NEAR * sd_u) | saturated(params.adc, u + _NEAR * sd_u)
    caveats = jnp.where(jnp.any(near, axis=-1) & valid, CAVEAT_NEAR_LIMIT, 0)
    if params.adc.enabled:
        caveats = caveats | jnp.where(jnp.any(sd_u < 0.5, axis=-1), CAVEAT_COARSE_QUANTIZATION, 0)
    caveats = caveats | jnp.where(v_first > 0.25, CAVEAT_LOW_SNR, 0)

    to_m = chain.unambiguity_range_m / (2.0 * jnp.pi)
    breakdown = noise.breakdown(charges, jnp.sqrt(readout.quantization_variance_lsb2) * readout.lsb_e)
    return Result(
        method="analytic", sweep_variable=sweep.variable, n_frames=0,
        sweep_values=sweep.values, distance_m=d, illuminance_lx=ev, integration_time_s=t, temperature_c=temp,
        unambiguity_range_m=chain.unambiguity_range_m,
        tap_a_e=held_a, tap_b_e=held_b, **chain.tap_conversion,
        code_mean=code, codes=None, phase_rad=None, depth_m=None, depth_unwrapped_m=None, amplitude_lsb=None,
        valid=None,
        depth_mean_m=_nan_unless(keep, to_m * phase),
        depth_unwrapped_mean_m=to_m * unwrap_if_sweep(phase, keep),
        depth_std_m=_nan_unless(keep, to_m * _depth.safe_sqrt(var_phase)),
        amplitude_mean_lsb=_nan_unless(keep, amp),
        amplitude_std_lsb=_nan_unless(keep, _depth.safe_sqrt(var_amp)),
        noise=breakdown,
        valid_fraction=valid.astype(float) if m.delivered is None else valid.astype(float) * m.delivered,
        pixel_saturated_fraction=pixel_sat.astype(float),
        adc_saturated_fraction=adc_sat.astype(float),
        sbi_active_fraction=jnp.any(sbi_on, axis=-1).astype(float),
        full_well_fraction=full_well_fraction(n_a, n_b, limit.full_well_e), headroom=headroom(chain, n_a, n_b, u),
        caveats=caveats.astype(jnp.int32),
    )


def predict(params: Params, sweep: Sweep, *, smooth: Smooth | None = None, pattern: PixelPattern | None = None,
            processing: tuple = ()) -> Result:
    """Analytic prediction: expected signals, and standard deviations propagated from the noise
    variances through the chain, in closed form (module docstring).

    Each phase image's expected code and its variance come from the chain's stages at the expected
    tap charges: shot noise of every collected electron (signal, background, dark) and reset kTC
    noise before SBI/saturation, hold kTC noise after it, the quantisation variance (q^2/12 for an
    ideal ADC, more with DNL). Depth and amplitude follow by the delta method with the higher orders
    of a phasor in Gaussian noise: the amplitude's noise bias (Rician) and the phase variance
    v (1 + v + ...), bounded by that of a uniform phase (:mod:`tofjax._rician`). Where the closed form
    is not what frames would show (a limit within the noise, an undithered ADC, a wrapping phase),
    ``Result.caveats`` says so.

    **Arguments:**
    - ``params``: the camera (:class:`tofjax.Params`).
    - ``sweep``: the operating points (:class:`tofjax.Sweep`; any shape).
    - ``smooth``: ``None`` (default) for the hard saturation and ADC, or a :class:`tofjax.Smooth`
      with temperatures for a differentiable relaxation. Hard: a saturated point's statistics are
      NaN and their gradient 0, not NaN (:func:`tofjax.predict`, "Gradients").
    - ``pattern``: the swept pixel's own parameters, a :class:`tofjax.PixelPattern` of one pixel
      (``tj.draw_pattern(params, settings, (1, 1))``: its gain, dark slopes, phase offset, tap
      asymmetry and full well, as a frame's pixel has them); ``None``: the mean pixel.
    - ``processing``: the camera's processing stages (:mod:`tofjax.processing`; a sweep's point is
      the centre of a uniform patch for the spatial ones); ``()``: the sensor's reading.

    **Returns:** a :class:`tofjax.Result` with ``method = "analytic"`` and no per-frame fields.

    Called directly, a 1-D sweep runs padded with copies of its last point
    (:func:`tofjax._sweep.padded_samples`), so sweeps of similar length share the compiled programs;
    the padding is cut from the result, and the camera's chain (its correlation table) is built at
    the first call with these ``params`` and kept (:func:`tofjax._chain.kept_chain`). Under a
    transformation (``jit``, ``vmap``, ``grad``) the sweep runs as it is and the chain is built in
    the caller's program: that program is compiled for its shapes once anyway.
    """
    check_inputs(params, sweep)
    sample = one_pixel(pattern)
    padded = _executor.padded(sweep, (params, sweep, smooth, sample, processing))
    chain = kept_chain(params, smooth, padded.samples, sample, processing)
    exposure = _predict_exposure(chain, padded)
    return unpad(_predict_result(chain, padded, exposure, _predict_moments(chain, padded, exposure)), sweep, padded)


# predict runs as three programs, the exposure, the moments and the result (after the kept chain's
# own, at a camera's first call): XLA on CPU fuses a producer into each of its consumers, and would
# evaluate the exposure (and then the moments) once per output of the next stage: 2x slower at 1e5
# points. Under an outer jit (calibration, user code) they are traced into one program as usual.
@_jit.jit
def _predict_exposure(chain: Chain, sweep: Sweep) -> Exposure:
    return chain.exposure(*sweep.operating_points(chain.params))


def _charges(chain: Chain, sweep: Sweep, exposure: Exposure) -> TapCharges:
    """The taps' charges of the exposure program's ``exposure``, in the program that reads them."""
    return exposure.charges(sweep.operating_points(chain.params)[3])


#: The moments :func:`analytic` does not read: :func:`predict`'s moments program does not write them
#: (4 of its 12 arrays per phase image), nor the charges (the moments and the result programs each
#: split the exposure program's :class:`~tofjax._charges.Exposure` into the taps' charges, in the
#: fusions that read them: one array per phase image between the programs, not two, and the table
#: lookups are not written out for two consumers; docs/model.md, "Performance", measurement 26).
#: The result's copies of its inputs stay: a result holding an earlier program's buffers instead
#: (no copies) made ``predict`` of 1e5 points 1.5x slower here, 12 000 page faults per call against
#: 1 700 (docs/model.md, "Performance", measurement 18).
_UNREAD = ("diff", "post_a", "post_b", "var_code")


@_jit.jit
def _predict_moments(chain: Chain, sweep: Sweep, exposure: Exposure) -> Moments:
    m = moments(chain, sweep, _charges(chain, sweep, exposure))
    return dataclasses.replace(m, charges=None, **dict.fromkeys(_UNREAD))


@_jit.jit
def _predict_result(chain: Chain, sweep: Sweep, exposure: Exposure, m: Moments) -> Result:
    return analytic(chain, sweep, dataclasses.replace(m, charges=_charges(chain, sweep, exposure)))
