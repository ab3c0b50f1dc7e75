"""The signal chain of one camera, composed once from its parameters (thesis Fig 3.1): an ordered
tuple of stages (:mod:`tofjax._stages`) after the exposure.

    exposure (optical path, background light, mixer, dark signal)       -> expected tap charges
    Noise: sources before the limit (photon shot, dark shot, reset kTC) -> per-tap variances
    limit (SBI or saturation, hard or smooth)                           -> held tap charges
    Noise: sources after the limit (hold kTC, readout)                  -> differential variance
    ReadoutNonlinearity (gain compression of the readout chain)         -> compressed differential
    Readout (conversion gain, ADC with offset, gain, INL, DNL, rails)   -> codes
    Demodulation (Z = sum_j D_j exp(i theta_j))                         -> phase, amplitude, depth
    the camera's processing (calibration, filters, invalidation; optional) -> delivered depth

:func:`build_chain` makes each stage from :class:`tofjax.Params` (and a :class:`tofjax.Smooth` for the
relaxed limits), including the correlation table the exposure reads: everything that does not depend
on the operating point is computed here, once per call, or once per camera for the eager calls
that keep it (:func:`kept_chain`). :func:`tofjax.predict` folds the moments
through the stages (:mod:`tofjax._analytic`), :func:`tofjax.simulate` draws the noise and the limit
and folds its frames through the rest (:mod:`tofjax._frames`); both take any batch shape of
operating points.
"""

from __future__ import annotations

import threading
from collections import OrderedDict

import equinox as eqx
import jax.numpy as jnp
from jaxtyping import Array, Float

from . import _jit
from ._adc import Readout
from ._correlation import SERIES_POINTS, Correlation, correlation, drift_correlation
from ._charges import Exposure, TapCharges
from ._mixer import expose
from ._depth import Demodulation
from ._noise import AFTER_LIMIT, BEFORE_LIMIT, NOISE_SOURCES, Noise, NoiseBudget
from ._nonlinearity import ReadoutNonlinearity
from ._processing import bind_all
from ._params import Params
from ._pattern import PixelPattern
from ._saturation import AbstractLimit, full_well_e, limit_stage
from ._smooth import Smooth
from ._stages import AbstractStage, Moments, Samples, fold_moments, fold_samples


def electrons_per_volt(params: Params) -> Array:
    """C_int / e: electrons per volt at the integration node."""
    return params.pixel.integration_capacitance_f / params.constants.elementary_charge_c


class Chain(eqx.Module):
    """The composed chain (module docstring).

    **Fields:** ``params`` (the camera), ``correlation`` (the mixer's table), ``stages`` (the ordered
    tuple after the exposure, module docstring; exactly one limit, one readout and one
    demodulation, then the camera's processing stages, :mod:`tofjax._processing`), ``sample`` (the pixels' own parameters, a :class:`tofjax.PixelPattern` of scalars
    (a swept pixel) or one per operating point (a frame's pixels): gain, dark slopes, phase offset,
    tap asymmetry, full well; ``None``: the mean pixel), ``drift`` (the correlation's antiderivative when
    another camera's light is in the scene, ``interference.enabled``; else ``None``).
    """

    params: Params
    correlation: Correlation
    stages: tuple[AbstractStage, ...]
    sample: PixelPattern | None = None
    drift: Correlation | None = None

    def _one(self, kind: type) -> AbstractStage:
        (stage,) = (s for s in self.stages if isinstance(s, kind))
        return stage

    @property
    def limit(self) -> AbstractLimit:
        """The limit stage (:class:`~tofjax._saturation.SBI` or :class:`~tofjax._saturation.Saturation`)."""
        return self._one(AbstractLimit)

    @property
    def readout(self) -> Readout:
        """The readout stage (:class:`~tofjax._adc.Readout`)."""
        return self._one(Readout)

    @property
    def noise(self) -> NoiseBudget:
        """Every noise source of the chain's :class:`~tofjax._noise.Noise` stages, in the breakdown's
        order (:data:`~tofjax._noise.NOISE_SOURCES`)."""
        stages = [s for s in self.stages if isinstance(s, Noise)]
        sources = tuple(source for stage in stages for source in stage.sources)
        order = {kind.name: i for i, kind in enumerate(NOISE_SOURCES)}
        return NoiseBudget(tuple(sorted(sources, key=lambda source: order[source.name])), stages[0].enabled)

    @property
    def _drawn(self) -> int:
        """How many leading stages the Monte Carlo's draw covers: up to the last noise source."""
        return 1 + max(i for i, s in enumerate(self.stages) if isinstance(s, Noise))

    def with_limit(self, limit: AbstractLimit) -> Chain:
        """The chain with another limit (a frame's pixels' own full wells)."""
        i = next(i for i, s in enumerate(self.stages) if isinstance(s, AbstractLimit))
        return eqx.tree_at(lambda c: c.stages, self, (*self.stages[:i], limit, *self.stages[i + 1:]))

    def moments(self, charges: TapCharges, image: bool = False) -> Moments:
        """The moments through every stage, from the exposure's expected ``charges`` (the analytic
        path, :mod:`tofjax._analytic`; ``image``: the points are a frame's pixels, :class:`Moments`)."""
        return fold_moments(self.stages, Moments.of(charges, image))

    @property
    def _processing_at(self) -> int:
        """The first processing stage's place in :attr:`stages` (after the demodulation)."""
        return 1 + next(i for i, s in enumerate(self.stages) if isinstance(s, Demodulation))

    @property
    def processing(self) -> tuple[AbstractStage, ...]:
        """The camera's processing stages (:mod:`tofjax._processing`), in order; ``()``: none."""
        return self.stages[self._processing_at:]

    def reference_phase(self, phase: Array) -> Array:
        """A noise-free frame's ``phase`` after the processing stages (:meth:`~tofjax._processing.AbstractProcessing.reference`)."""
        for stage in self.processing:
            phase = stage.reference(phase)
        return phase

    @property
    def _readout_at(self) -> int:
        """The readout stage's place in :attr:`stages`."""
        return next(i for i, s in enumerate(self.stages) if isinstance(s, Readout))

    def readout_moments(self, charges: TapCharges) -> Moments:
        """The moments through the stages up to the readout (its code position ``u`` among them), without
        the demodulation's: what a limit's headroom needs (:func:`tofjax._analytic.headroom`)."""
        return fold_moments(self.stages[:self._readout_at + 1], Moments.of(charges))

    def drawn_moments(self, charges: TapCharges) -> Moments:
        """The moments through the stages the Monte Carlo draws (up to the last noise source): the
        taps' variances before the limit, the held charges, the variances added after it."""
        stages = self.stages[:self._drawn]
        if [type(s) for s in stages if not isinstance(s, AbstractLimit)] != [Noise, Noise] \
                or not isinstance(stages[1], AbstractLimit):
            raise NotImplementedError("the Monte Carlo draws noise, limit, noise (tofjax._frames.draw_frames); "
                                      f"this chain has {[type(s).__name__ for s in stages]} there")
        return fold_moments(stages, Moments.of(charges))

    def samples(self, diff: Array) -> Samples:
        """Frames of the drawn differential ``diff`` (phase axis first) through the stages after the
        last noise source: codes, ADC flags, phase and amplitude (the Monte Carlo)."""
        return fold_samples(self.stages[self._drawn:self._processing_at], Samples(diff))

    def codes(self, diff: Array) -> Array:
        """The codes of the drawn differential ``diff`` (phase axis first): :meth:`samples` up to the
        readout, its codes only."""
        return fold_samples(self.stages[self._drawn:self._readout_at + 1], Samples(diff)).codes

    def samples_of_codes(self, codes: Array) -> Samples:
        """:meth:`samples` from the frames' :meth:`codes` of a hard readout
        (:attr:`~tofjax._adc.Readout.codes_show_saturation`): the ADC's flags read from the codes,
        then the stages after the readout (phase and amplitude)."""
        s = Samples(None, codes=codes, adc_saturated=self.readout.saturated_codes(codes))
        return fold_samples(self.stages[self._readout_at + 1:self._processing_at], s)

    @property
    def n_phases(self) -> int:
        return self.params.pixel.n_phases

    @property
    def dtype(self):
        """The chain's floating-point type: its parameters' (float64 by default; float32 for a camera
        cast with :meth:`tofjax.Camera.astype`)."""
        return jnp.result_type(self.params.pixel.v_reset_v)

    @property
    def unambiguity_range_m(self) -> Array:
        return self.params.unambiguity_range_m

    def exposure(self, distance_m: Float[Array, "*b"], illuminance_lx: Float[Array, "*b"],
                 integration_time_s: Float[Array, "*b"], temperature_c: Float[Array, "*b"] | None = None,
                 dark_slopes_v_per_s=None) -> Exposure:
        """What the pixel collects at the operating points (:func:`tofjax._mixer.expose`; the
        arguments are :meth:`tofjax.Sweep.operating_points`), of the chain's pixel sample if it has
        one, before the taps split it (:meth:`expose`)."""
        return expose(self.params, self.correlation, distance_m, illuminance_lx, integration_time_s,
                      dark_slopes_v_per_s, self.sample, self.drift, temperature_c)

    def expose(self, distance_m: Float[Array, "*b"], illuminance_lx: Float[Array, "*b"],
               integration_time_s: Float[Array, "*b"], temperature_c: Float[Array, "*b"] | None = None,
               dark_slopes_v_per_s=None) -> TapCharges:
        """Expected tap charges at the operating points: the :meth:`exposure`, split into the taps
        (:meth:`tofjax._charges.Exposure.charges`)."""
        return self.exposure(distance_m, illuminance_lx, integration_time_s, temperature_c,
                             dark_slopes_v_per_s).charges(temperature_c)

    @property
    def tap_conversion(self) -> dict[str, Array]:
        """The fields of a :class:`tofjax.Result` that turn its held electrons into tap voltages
        (``Result.tap_a_v``: V = V_reset - n e / C_int): the reset voltage and C_int / e."""
        return {"tap_reset_v": self.params.pixel.v_reset_v, "electrons_per_volt": self.readout.electrons_per_volt}


def build_chain(params: Params, smooth: Smooth | None = None, points: int | None = None,
                sample: PixelPattern | None = None, processing: tuple = ()) -> Chain:
    """The chain of camera ``params``; ``smooth`` relaxes the limits and the ADC (``None``: hard);
    ``points``, the number of operating points of the call, chooses how the mixer's correlation is
    evaluated (a table, or the series for a few points; ``None``: a table); ``sample``: the pixels'
    own parameters (:class:`Chain`; their full-well scale sets each point's full well, on the axis
    before the phases); ``processing``: the camera's processing stages (:mod:`tofjax._processing`),
    bound to this chain and placed after the demodulation."""
    per_volt = electrons_per_volt(params)
    pixel = params.pixel
    nominal_well = well = full_well_e(pixel.v_reset_v, pixel.v_saturated_v, per_volt, pixel.full_well_e)
    if sample is not None:
        scale = jnp.asarray(sample.full_well_scale)
        well = well * (scale if scale.ndim == 0 else scale[..., None])  # (*points, 1) against the phases
    temperature_e = None if smooth is None else smooth.saturation_temperature_v * per_volt
    limit = limit_stage(well, pixel.sbi, temperature_e)
    readout = Readout(params.adc, per_volt, None if smooth is None else smooth.adc_temperature_lsb, pixel.noise)
    table = correlation(params.illumination_waveform, params.reference_waveform, pixel.n_phases,
                        tabulate=points is None or points > SERIES_POINTS)
    budget = NoiseBudget.from_params(params)
    stages = (budget.stage(BEFORE_LIMIT), limit, budget.stage(AFTER_LIMIT),
              ReadoutNonlinearity(pixel.readout_nonlinearity, nominal_well), readout,
              Demodulation(pixel.n_phases, readout.mid_code), *bind_all(processing, params, table, sample))
    drift = None
    if params.interference.enabled:  # another camera's light drifts through the correlation
        drift = drift_correlation(params.illumination_waveform, params.reference_waveform, pixel.n_phases,
                                  tabulate=points is None or points > SERIES_POINTS)
    return Chain(params, table, stages, sample, drift)


#: Chains that eager calls built (:func:`kept_chain`), the most recently used last; a run on another
#: thread (the explorer's, a calibration's) takes the lock to look up, add or evict.
_KEPT: OrderedDict[tuple, tuple] = OrderedDict()
_KEPT_LOCK = threading.Lock()
#: At most this many kept chains (about 2 MB each, the correlation table most of it).
KEPT_CHAINS = 4


def kept_chain(params: Params, smooth: Smooth | None = None, points: int | None = None,
               sample: PixelPattern | None = None, processing: tuple = ()) -> Chain:
    """:func:`build_chain`'s chain, built by a compiled program of its own at the first eager call
    with these ``params``, ``smooth``, ``sample`` and ``processing`` and kept for the next ones. Where a leaf is
    traced (a caller's transformation) it is built in the caller's program and nothing is kept.

    Everything in a chain depends on the camera alone: the correlation table (two FFTs of 16 384
    points), the waveforms' means, the lamp spectra interpolated to the filter band. Built in every
    call's own program, it was most of a ``predict`` of a few hundred points and 1 ms of one of
    1e5 (docs/model.md, "Performance", measurement 25). A module is immutable, so its identity is
    the key; an entry holds its modules, so no other object takes their identity while it is kept.
    The :data:`KEPT_CHAINS` most recently used are kept.
    """
    if _jit.traced((params, smooth, sample, processing)):
        return build_chain(params, smooth, points, sample, processing)
    tabulate = points is None or points > SERIES_POINTS
    key = (id(params), id(smooth), id(sample), tuple(map(id, processing)), tabulate)
    with _KEPT_LOCK:
        hit = _KEPT.get(key)
        if hit is not None:
            _KEPT.move_to_end(key)
            return hit[-1]
    chain = _built(params, smooth, None if tabulate else 1, sample, processing)  # one program per camera structure
    with _KEPT_LOCK:
        _KEPT[key] = (params, smooth, sample, processing, chain)
        while len(_KEPT) > KEPT_CHAINS:
            _KEPT.popitem(last=False)
    return chain


_built = _jit.jit(build_chain)
