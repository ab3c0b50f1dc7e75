"""The Monte Carlo path: :func:`simulate` draws noisy frames through the chain and reduces them to
statistics chunk by chunk (:mod:`tofjax._frames`; docs/model.md, "Monte Carlo")."""

from __future__ import annotations

import equinox as eqx
import jax
import jax.numpy as jnp
import jax.random as jr
from jaxtyping import Array, PRNGKeyArray

from ._analytic import full_well_fraction, headroom, unwrap_if_sweep
from ._chain import Chain, kept_chain
from ._depth import unwrap_along_sweep
from . import _executor, _jit
from ._executor import BLOCK_POINTS, CHUNK_ELEMENTS, execute, run_blocks
from ._limits import kept_bytes_limit, kept_limit_text, size_text
from ._frames import PointConstants, Sums, draw_delivered, frame_statistics, point_constants, reduce_frames
from ._charges import TapCharges
from ._params import Params
from ._pattern import PixelPattern, one_pixel, pixel_dark_slopes
from ._processing import draw_factor
from ._random import key_words
from ._result import Result
from ._smooth import Smooth
from ._sweep import Sweep, check_inputs, unpad


def kept_bytes_per_frame(n_phases: int, raw: bool = False) -> int:
    """Bytes one kept frame of one operating point takes: its codes (per phase), with ``raw`` both
    taps too (the raw phase images), phase, depth, unwrapped depth and amplitude (float64 each) and
    the valid flag."""
    return (3 if raw else 1) * 8 * n_phases + 4 * 8 + 1


def max_keep_frames(samples: int, n_phases: int, raw: bool = False) -> int:
    """The most frames per point that fit :func:`tofjax._limits.kept_bytes_limit` (a quarter of the
    device's memory) for ``samples`` operating points; the statistics themselves run in bounded
    memory for any number of frames."""
    return kept_bytes_limit() // (max(samples, 1) * kept_bytes_per_frame(n_phases, raw))


def check_counts(iterations, keep_frames, samples: int = 1, n_phases: int = 4,
                 names: tuple[str, str] = ("iterations", "keep_frames"), raw: bool = False) -> None:
    """Frames per point (>= 1) and frames to keep (0 .. iterations, and within
    :func:`tofjax._limits.kept_bytes_limit` for ``samples`` points, with ``raw`` their raw phase
    images), as Python integers; refused before any work, naming the caller's arguments (``names``:
    the frame functions say ``frames``)."""
    many, kept = names
    if isinstance(iterations, bool) or not isinstance(iterations, int) or iterations < 1:
        raise ValueError(f"{many} = {iterations!r} is out of range: allowed integer >= 1")
    if isinstance(keep_frames, bool) or not isinstance(keep_frames, int) or not 0 <= keep_frames <= iterations:
        raise ValueError(f"{kept} = {keep_frames!r} is out of range: allowed integer 0 <= value <= "
                         f"{many} = {iterations}")
    most = max_keep_frames(samples, n_phases, raw)
    if keep_frames > most:
        size = size_text(keep_frames * samples * kept_bytes_per_frame(n_phases, raw))
        raise ValueError(f"{kept} = {keep_frames} is out of range for {samples} operating points ({size} of frames): "
                         f"allowed 0 <= value <= {most} ({kept_limit_text()}); the statistics use every frame regardless")


class Prepared(eqx.Module):
    """A chain's expected charges at the operating points and its frames' per-point constants."""

    charges: TapCharges  # batch shape (*b)
    consts: PointConstants  # points flattened, last axis


def prepare(chain: Chain, sweep: Sweep, dark_slopes_v_per_s=None) -> Prepared:
    """The charges and the frames' constants at the sweep's points. The exposure's modulated sum is
    written out (:meth:`~tofjax._charges.Exposure.written_out`): the run's one program reads the
    charges in the constants, the result and its breakdown, and XLA on a CPU otherwise wrote out each
    point's gathered table rows, four per phase image, and evaluated the cubic in every reader
    (docs/model.md, "Performance", measurement 29)."""
    d, ev, t, temp = sweep.operating_points(chain.params)
    charges = chain.exposure(d, ev, t, temp, dark_slopes_v_per_s).written_out().charges(temp)
    flat = jax.tree_util.tree_map(lambda x: x.reshape((-1,) + x.shape[d.ndim:]), charges)
    n_points = flat.signal_e.shape[0]
    return Prepared(charges, point_constants(chain, flat, jnp.arange(n_points, dtype=jnp.uint32)))


class FramesStep(eqx.Module):
    """The chunk step of :func:`tofjax._executor.run_blocks` for one chain: sums, and with ``record``
    the frames as (codes ``(points, frames, phases)``, phase in [0, 2 pi), amplitude, valid, and
    with ``raw`` the taps as read, ``(points, frames, phases)`` each: :func:`~tofjax._frames.draw_frames`). A
    pytree, so that the chunk programs of :func:`tofjax._executor.drive_blocks` take it as an argument.

    A chunk of fewer frames than points (a camera frame's pixels) whose frames are not kept is drawn
    frames first, so that the points are the arrays' minor axis: with a minor axis of a few frames
    XLA's CPU loops run slower per element. Kept frames stay points first, the layout they are
    returned in: transposing them from frames first costs more (docs/model.md, "Performance",
    measurement 6)."""

    chain: Chain
    words: tuple[Array, Array]
    stream: int = eqx.field(static=True, default=0)
    raw: bool = eqx.field(static=True, default=False)
    image: tuple[int, int] | None = eqx.field(static=True, default=None)  # a frame's pixels (whole frames)

    def __call__(self, c, first, n, counted, record):
        ff = n < c.index.shape[0] and not record
        taps = record and self.raw
        frames = draw_delivered(self.chain, c, self.words, first, n, self.stream, frames_first=ff, taps=taps,
                                image=self.image)
        sums, valid = reduce_frames(c, frames, counted[:, None] if ff else counted[None, :], frames_first=ff)
        if not record:
            return sums, None
        phase = jnp.mod(frames.phase, 2.0 * jnp.pi)
        last = lambda x: jnp.moveaxis(x, 0, -1)  # noqa: E731 - (phases, points, frames) -> (points, frames, phases)
        kept = (last(frames.codes), phase, frames.amplitude, valid)
        return sums, kept + ((last(frames.tap_a_e), last(frames.tap_b_e)) if taps else ())


def frames_step(chain: Chain, words, stream: int = 0, raw: bool = False, image: tuple[int, int] | None = None
                ) -> FramesStep:
    """The chunk step of one chain (:class:`FramesStep`; ``raw``: its kept frames' taps too; ``image``:
    the points are a frame's pixels, drawn as whole frames)."""
    return FramesStep(chain, words, stream, raw, image)


def assemble(chain: Chain, sweep: Sweep, prepared: Prepared, sums: Sums, kept, iterations: int) -> Result:
    """The :class:`tofjax.Result` of a Monte Carlo run from its per-point sums and kept frames."""
    d, ev, t, temp = sweep.operating_points(chain.params)
    shape = d.shape
    charges, consts = prepared.charges, prepared.consts
    mean_phase, std_phase, amp_mean, amp_std = frame_statistics(consts, sums, iterations)
    points = lambda x: x.reshape(shape + x.shape[1:])  # noqa: E731 - (points, ...) -> (*b, ...)
    fraction = lambda x: points(x / float(iterations))  # noqa: E731
    mean_phase, std_phase = points(mean_phase), points(std_phase)
    has_mean = ~jnp.isnan(mean_phase)
    to_m = chain.unambiguity_range_m / (2.0 * jnp.pi)
    n_a, n_b = charges.a, charges.b
    held_a, held_b = chain.limit(n_a, n_b)
    readout = chain.readout
    breakdown = chain.noise.breakdown(charges, jnp.sqrt(readout.quantization_variance_lsb2) * readout.lsb_e)
    if kept is not None:
        codes, phase, amplitude, valid, *taps = (points(x) for x in kept)
        frames_tap_a, frames_tap_b = taps if taps else (None, None)
        unwrapped = unwrap_along_sweep(phase, valid) if len(shape) == 1 else jnp.where(valid, phase, jnp.nan)
        frames = dict(codes=codes, phase_rad=phase, depth_m=to_m * phase, depth_unwrapped_m=to_m * unwrapped,
                      amplitude_lsb=amplitude, valid=valid, frames_tap_a_e=frames_tap_a, frames_tap_b_e=frames_tap_b)
    else:
        frames = dict(codes=None, phase_rad=None, depth_m=None, depth_unwrapped_m=None, amplitude_lsb=None, valid=None)
    return Result(
        method="mc", sweep_variable=sweep.variable, n_frames=iterations,
        sweep_values=sweep.values, distance_m=d, illuminance_lx=ev, integration_time_s=t, temperature_c=temp,
        unambiguity_range_m=chain.unambiguity_range_m,
        tap_a_e=held_a, tap_b_e=held_b, **chain.tap_conversion,
        code_mean=points(jnp.moveaxis(sums.codes, 0, -1) / float(iterations)), **frames,
        depth_mean_m=to_m * mean_phase,
        depth_unwrapped_mean_m=to_m * unwrap_if_sweep(jnp.where(has_mean, mean_phase, 0.0), has_mean),
        depth_std_m=to_m * std_phase, amplitude_mean_lsb=points(amp_mean), amplitude_std_lsb=points(amp_std),
        noise=breakdown,
        valid_fraction=fraction(sums.valid), pixel_saturated_fraction=fraction(sums.pixel_saturated),
        adc_saturated_fraction=fraction(sums.adc_saturated), sbi_active_fraction=fraction(sums.sbi_engaged),
        full_well_fraction=full_well_fraction(n_a, n_b, chain.limit.full_well_e),
        headroom=headroom(chain, n_a, n_b, chain.readout_moments(charges).u),
    )


def monte_carlo(chain: Chain, sweep: Sweep, key: PRNGKeyArray, iterations: int, keep_frames: int,
                dark_slopes_v_per_s=None, chunking: tuple[int, int] = (CHUNK_ELEMENTS, BLOCK_POINTS),
                progress: bool = False, raw: bool = False) -> Result:
    """:func:`simulate` on a built chain (``chunking``: phase images per chunk, points per block)."""
    prepared = prepare(chain, sweep, dark_slopes_v_per_s)
    sums, kept = run_blocks(frames_step(chain, key_words(key), raw=raw), prepared.consts, sweep.samples, iterations,
                            keep_frames, drawn_phases(chain.n_phases, chain.processing), *chunking,
                            progress=progress)
    return assemble(chain, sweep, prepared, sums, kept, iterations)


def simulate(
    params: Params,
    sweep: Sweep,
    key: PRNGKeyArray,
    iterations: int = 2000,
    *,
    smooth: Smooth | None = None,
    fixed_pattern: bool = False,
    pattern: PixelPattern | None = None,
    keep_frames: int = 0,
    raw: bool = False,
    progress: bool = False,
    processing: tuple = (),
) -> Result:
    """Monte Carlo simulation: ``iterations`` noisy frames at every operating point.

    Per frame, phase image and tap: Gaussian noise of the sources before the limit (shot noise of
    every collected electron, reset kTC), then SBI and saturation of the noisy charge, then the
    sources after it (hold kTC), the ADC, and the phase/amplitude/depth estimators. A frame is
    valid when no tap of any phase image saturated and no code hit an end of the ADC range;
    statistics use valid frames only (circular statistics for the phase). Frames are drawn and
    reduced in chunks, so memory stays bounded for any number of frames (docs/model.md, "Monte
    Carlo": the random-number economy and the chunking).

    **Arguments:**
    - ``params``, ``sweep``: as :func:`tofjax.predict` (any shape of operating points).
    - ``key``: a ``jax.random`` key; the same key gives the same frames.
    - ``iterations``: frames per operating point (static; each value compiles once).
    - ``smooth``: ``None`` for the hard mode, or :class:`tofjax.Smooth` temperatures.
    - ``fixed_pattern``: if true, the taps' dark slopes are drawn once (per key) from the
      pixel population (mean, sigma of ``pixel.dark_slope_*``) instead of taking the mean pixel.
    - ``pattern``: the swept pixel's own parameters, a :class:`tofjax.PixelPattern` of one pixel
      (as :func:`tofjax.predict`'s); ``None``: the mean pixel (or ``fixed_pattern``'s slopes).
    - ``keep_frames``: how many frames of each point to return whole (``codes``, ``phase_rad``,
      ``depth_m``, ...; static, 0 .. ``iterations``); the statistics always use every frame.
    - ``raw``: the kept frames carry their whole raw phase images, both taps' electrons as read
      (``frames_tap_a_e``, ``frames_tap_b_e``) beside the codes (static; the same frames either
      way; docs/model.md, "Raw phase images").
    - ``processing``: the camera's processing stages (:mod:`tofjax.processing`): the statistics are
      the delivered frames' (a sweep's point drawn as the centre of a uniform patch where a stage
      reads neighbours); ``()``: the sensor's frames.
    - ``progress``: report every chunk of frames to :mod:`tofjax.progress`: the chunks are run
      from the host, one compiled call each (the same numbers to rounding; programs that JAX's persistent
      compilation cache keeps), or under a transformation by a host callback per chunk in the
      program (which that cache never keeps).

    **Returns:** a :class:`tofjax.Result` with ``method = "mc"``.

    Called directly, a 1-D sweep runs padded as :func:`tofjax.predict`'s while the padding draws at
    most :data:`tofjax._executor.PADDING_PHASE_IMAGES` phase images (sweeps of similar length share
    the compiled programs; a point's frames are its own, so the padding changes none of them).
    """
    check_inputs(params, sweep)
    check_counts(iterations, keep_frames, sweep.samples, params.pixel.n_phases, raw=raw)
    sample = one_pixel(pattern)
    if fixed_pattern and sample is not None:
        raise ValueError("give fixed_pattern or pattern, not both: fixed_pattern draws the taps' dark slopes from the "
                         "key, pattern is the pixel's whole sample")
    phases = drawn_phases(params.pixel.n_phases, processing)
    padded = _executor.padded(sweep, (params, sweep, key, smooth, sample, processing), iterations * phases)
    chain = kept_chain(params, smooth, padded.samples, sample, processing)
    return unpad(execute(_setup, _consts, _finish,
                         (params, padded, key, smooth, fixed_pattern, sample, raw, iterations, chain),
                         points=padded.samples, frames=iterations, keep=keep_frames, phases=phases,
                         progress=progress), sweep, padded)


def drawn_phases(n_phases: int, stages, image: bool = False) -> int:
    """Raw phase images drawn per delivered frame of a point (the executor's chunking, a sweep's
    padding): the sensor's ``n_phases``, times the processing ``stages``' raw frames and a sweep's
    patch (:func:`tofjax._processing.draw_factor`)."""
    return n_phases * draw_factor(stages, image)


@_jit.jit
def _setup(params, sweep, key, smooth, fixed_pattern, sample, raw, iterations, chain):
    """:func:`simulate`'s run (:func:`tofjax._executor.execute`) with the camera's ``chain``
    (:func:`tofjax._chain.kept_chain`, an argument of :func:`_finish` too): the expected charges and
    frames' constants (carried to :func:`_finish`), and the chunk step; ``fixed_pattern``: the taps'
    dark slopes drawn from the key (else the mean pixel's, or the sample's)."""
    pattern_key, key = jr.split(key)
    slopes = pixel_dark_slopes(params, pattern_key) if fixed_pattern else None
    return prepare(chain, sweep, slopes), frames_step(chain, key_words(key), raw=raw)


def _consts(params, sweep, key, smooth, fixed_pattern, sample, raw, iterations, chain, carry) -> PointConstants:
    return carry.consts


@_jit.jit
def _finish(params, sweep, key, smooth, fixed_pattern, sample, raw, iterations, chain, carry, sums, kept) -> Result:
    return assemble(chain, sweep, carry, sums, kept, iterations)
