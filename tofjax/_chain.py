"""The signal chain of one camera, composed once from its parameters (thesis Fig 3.1).

    exposure (optical path, background light, mixer, dark signal)       -> expected tap charges
    noise before the limit (photon shot, dark shot, reset kTC)           -> per-tap variances
    limit (SBI or saturation, hard or smooth)                            -> held tap charges
    noise after the limit (hold kTC, readout)                            -> differential variance
    readout (conversion gain, ADC with offset, gain, INL, DNL, rails)    -> codes
    demodulation (Z = sum_j D_j exp(i theta_j))                          -> phase, amplitude, depth

:func:`build_chain` makes each stage from :class:`tofjax.Params` (and a :class:`tofjax.Smooth` for the
relaxed limits), including the correlation table the exposure reads: everything that does not depend
on the operating point is computed here, once per call. :func:`tofjax.predict` walks the chain with
means and variances (:mod:`tofjax._analytic`), :func:`tofjax.simulate` with frames
(:mod:`tofjax._montecarlo`); both take any batch shape of operating points.
"""

from __future__ import annotations

import equinox as eqx
import jax.numpy as jnp
from jaxtyping import Array, Float

from ._adc import Readout
from ._correlation import SERIES_POINTS, Correlation, correlation
from ._charges import TapCharges
from ._mixer import expose
from ._noise import NoiseBudget
from ._params import Params
from ._pattern import PixelPattern
from ._saturation import AbstractLimit, full_well_e, limit_stage
from ._smooth import Smooth


def electrons_per_volt(params: Params) -> Array:
    """C_int / e: electrons per volt at the integration node."""
    return params.pixel.integration_capacitance_f / params.constants.elementary_charge_c


class Chain(eqx.Module):
    """The composed chain (module docstring).

    **Fields:** ``params`` (the camera), ``correlation`` (the mixer's table), ``noise`` (the noise
    budget), ``limit`` (:class:`~tofjax._saturation.SBI` or :class:`~tofjax._saturation.Saturation`),
    ``readout`` (:class:`~tofjax._adc.Readout`), ``sample`` (the pixels' own parameters, a
    :class:`tofjax.PixelPattern` of scalars (a swept pixel) or one per operating point (a frame's
    pixels): gain, dark slopes, phase offset, tap asymmetry, full well; ``None``: the mean pixel).
    """

    params: Params
    correlation: Correlation
    noise: NoiseBudget
    limit: AbstractLimit
    readout: Readout
    sample: PixelPattern | None = None

    @property
    def n_phases(self) -> int:
        return self.params.pixel.n_phases

    @property
    def unambiguity_range_m(self) -> Array:
        return self.params.unambiguity_range_m

    def expose(self, distance_m: Float[Array, "*b"], illuminance_lx: Float[Array, "*b"],
               integration_time_s: Float[Array, "*b"], dark_slopes_v_per_s=None) -> TapCharges:
        """Expected tap charges at the operating points (:func:`tofjax._mixer.expose`), of the chain's
        pixel sample if it has one."""
        return expose(self.params, self.correlation, distance_m, illuminance_lx, integration_time_s,
                      dark_slopes_v_per_s, self.sample)

    def tap_volts(self, held_a: Array, held_b: Array) -> tuple[Array, Array]:
        """Tap voltages V = V_reset - n e / C_int of held charges."""
        per_volt = self.readout.electrons_per_volt
        v_reset = self.params.pixel.v_reset_v
        return v_reset - held_a / per_volt, v_reset - held_b / per_volt


def build_chain(params: Params, smooth: Smooth | None = None, points: int | None = None,
                sample: PixelPattern | None = None) -> Chain:
    """The chain of camera ``params``; ``smooth`` relaxes the limits and the ADC (``None``: hard);
    ``points``, the number of operating points of the call, chooses how the mixer's correlation is
    evaluated (a table, or the series for a few points; ``None``: a table); ``sample``: the pixels'
    own parameters (:class:`Chain`; their full-well scale sets each point's full well, on the axis
    before the phases)."""
    per_volt = electrons_per_volt(params)
    pixel = params.pixel
    well = full_well_e(pixel.v_reset_v, pixel.v_saturated_v, per_volt, pixel.full_well_e)
    if sample is not None:
        scale = jnp.asarray(sample.full_well_scale)
        well = well * (scale if scale.ndim == 0 else scale[..., None])  # (*points, 1) against the phases
    temperature_e = None if smooth is None else smooth.saturation_temperature_v * per_volt
    limit = limit_stage(well, pixel.sbi, temperature_e)
    readout = Readout(params.adc, per_volt, None if smooth is None else smooth.adc_temperature_lsb)
    table = correlation(params.illumination_waveform, params.reference_waveform, pixel.n_phases,
                        tabulate=points is None or points > SERIES_POINTS)
    return Chain(params, table, NoiseBudget.from_params(params), limit, readout, sample)
