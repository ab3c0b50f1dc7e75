"""Frames of a camera with several modulation frequencies (docs/model.md, "Frames of several
frequencies"): every pixel measured at each frequency (each frequency a whole frame of its phase
images, its own random stream) and fused as the sweep's centre pixel is (:mod:`tofjax._multifrequency`:
the candidate where the frequencies agree, the camera's fusion weights, each frequency's processing
before the fusion).

:class:`MultiPreparedCamera` and :class:`MultiPreparedFrame` are :class:`tofjax._frame.PreparedCamera`
and :class:`tofjax._frame.PreparedFrame` with the same methods: their per-frequency parts are those
classes stacked on a leading frequency axis (one :func:`jax.vmap` over the frequencies), and what
they return is a frame of the fused distance: a :class:`tofjax.FrameResult` whose result is the first
frequency's with the distance fields fused (``depth_mean_m`` in [0, extended range), ``depth_std_m``,
``valid_fraction``, ``unambiguity_range_m`` the extended range, ``wrong_unwrap_fraction``), and
:class:`tofjax.NoisyFrames` of the fused distance.

The flags of a fused frame: wrapped against the extended range; low signal where any frequency's
expected phase noise exceeds the threshold (a camera needs every frequency to unwrap); low amplitude
on the weakest frequency's amplitude.
"""

from __future__ import annotations

import dataclasses
import math

import equinox as eqx
import jax
import jax.numpy as jnp
import jax.random as jr
import numpy as np
from jaxtyping import Array, PRNGKeyArray

from . import _jit
from ._executor import BLOCK_POINTS, execute, frame_chunk_elements
from ._frame import (FRAME_COUNTS, FrameQuality, FrameResult, NoisyFrames, PreparedCamera, PreparedFrame,
                     _sample_prepared, scene_flags)
from ._montecarlo import check_counts, drawn_phases
from ._multifrequency import (_finish, _Step, extended_range_m, fusion_weights, fused_std, unwrap_frequencies,
                              wrong_unwrap_probability)
from ._processing import whole_frames
from ._random import key_words
from ._result import Result
from ._returns import Returns


def _ranges(frequencies_hz, c: float) -> tuple[float, ...]:
    return tuple(float(c / (2.0 * f)) for f in frequencies_hz)


class _Frequencies(eqx.Module):
    """The frequencies' static facts: the frequencies, their fusion, unambiguity ranges and extended range."""

    frequencies_hz: tuple[float, ...] = eqx.field(static=True)
    fusion: str = eqx.field(static=True)
    ranges: tuple[float, ...] = eqx.field(static=True)
    extended: float = eqx.field(static=True)

    @classmethod
    def of(cls, frequencies_hz, fusion: str, c: float) -> _Frequencies:
        f = tuple(float(x) for x in frequencies_hz)
        return cls(f, fusion, _ranges(f, c), float(extended_range_m(f, c)))

    def column(self, ndim: int) -> Array:
        """The unambiguity ranges on a leading axis against ``ndim`` more axes."""
        return jnp.asarray(self.ranges).reshape((-1,) + (1,) * ndim)


def fuse_expected(per: Result, freq: _Frequencies) -> dict[str, Array]:
    """The fused distance of every frequency's expected result (a leading frequency axis): the
    distance where the frequencies' expected phases agree, its noise, the wrong-unwrap rate, the
    delivered fraction, and the fusion's weights (:func:`tofjax._multifrequency.predict_multifrequency`)."""
    ndim = per.depth_mean_m.ndim - 1
    weights = fusion_weights(per.depth_std_m**2, np.asarray(freq.ranges), freq.fusion)
    phases = 2.0 * jnp.pi * per.depth_mean_m / freq.column(ndim)
    ok = jnp.all(jnp.isfinite(phases), axis=0)
    mean = unwrap_frequencies(jnp.where(ok, phases, 0.0), np.asarray(freq.ranges), freq.extended,
                              jnp.where(ok, weights, 1.0))
    return {"depth_mean_m": jnp.where(ok, mean, jnp.nan), "depth_std_m": fused_std(per.depth_std_m, weights),
            "wrong_unwrap_fraction": wrong_unwrap_probability(per.depth_std_m / freq.column(ndim),
                                                              np.asarray(freq.ranges), freq.extended),
            "valid_fraction": jnp.prod(per.valid_fraction, axis=0), "weights": weights}


def _fused_result(per: Result, freq: _Frequencies, fused: dict, frames: dict | None = None) -> Result:
    """The first frequency's result with the distance fields fused (module docstring)."""
    first = _at(per, 0)
    extra = {} if frames is None else frames
    return dataclasses.replace(
        first, depth_mean_m=fused["depth_mean_m"], depth_std_m=fused["depth_std_m"],
        depth_unwrapped_mean_m=fused["depth_mean_m"], valid_fraction=fused["valid_fraction"],
        unambiguity_range_m=jnp.asarray(freq.extended, dtype=first.depth_std_m.dtype),
        wrong_unwrap_fraction=fused["wrong_unwrap_fraction"], **extra)


def _quality(per: FrameQuality, flags: Array) -> FrameQuality:
    """A fused frame's quality (module docstring): the worst frequency's expected noise and amplitude."""
    return FrameQuality(flags, jnp.max(per.expected_phase_std_rad, axis=0), jnp.min(per.expected_amplitude_lsb, axis=0),
                        per.max_phase_noise_rad[0], per.min_amplitude_lsb[0])


@eqx.filter_jit
def _at(tree, i: int):
    """Frequency ``i`` of every leaf, as one program per structure (eagerly, one dispatch per leaf: a
    prepared frame's 118 took 0.47 s the first time, as one program 0.1 s)."""
    return jax.tree_util.tree_map(lambda x: x[i], tree)


class MultiPreparedCamera(eqx.Module):
    """A camera of several frequencies prepared for frames (module docstring): ``cameras``, one
    :class:`tofjax._frame.PreparedCamera` per frequency on a leading axis, and the frequencies."""

    cameras: PreparedCamera
    freq: _Frequencies

    @property
    def shape(self) -> tuple[int, int]:
        return tuple(self.cameras.dark_a_e.shape[1:])

    @property
    def _first(self) -> PreparedCamera:
        return _at(self.cameras, 0)

    def _flags(self, returns: Returns) -> Array:
        first = self._first
        return _scene_flags(first.chain.params, first.settings, returns, first.direction,
                            jnp.asarray(self.freq.extended))

    @_jit.method
    def predict(self, returns: Returns) -> FrameResult:
        """A scene's analytic frame of the fused distance (``tj.predict(camera, returns)``)."""
        return _camera_predict(self, self._first._check(returns))

    @_jit.method
    def noise_image(self, returns: Returns) -> Array:
        """Only the fused distance's analytic noise, m."""
        return self.predict(returns).depth_std_m

    @_jit.method
    def prepare(self, returns: Returns) -> MultiPreparedFrame:
        """A scene exposed once at every frequency (:meth:`tofjax.Camera.expose`)."""
        return _camera_prepare(self, self._first._check(returns))

    @_jit.method
    def sample(self, returns: Returns, key: PRNGKeyArray, frames: int = 1, *, raw: bool = False) -> NoisyFrames:
        """``frames`` noisy frames of the fused distance (what a stream of changing scenes needs)."""
        check_counts(frames, frames, math.prod(self.shape), self._first.chain.n_phases, names=FRAME_COUNTS)
        _no_raw(raw)
        return self.prepare(returns).sample(key, frames)

    @_jit.method
    def render(self, returns: Returns, key: PRNGKeyArray, frames: int = 1, *, keep_frames: int = 0,
               raw: bool = False, progress: bool = False) -> FrameResult:
        """Monte Carlo frames of a scene and their fused statistics (``tj.simulate(camera, returns, ...)``)."""
        return self.prepare(returns).render(key, frames, keep_frames=keep_frames, raw=raw, progress=progress)


class MultiPreparedFrame(eqx.Module):
    """A scene exposed once at every frequency (module docstring): ``frames``, one
    :class:`tofjax._frame.PreparedFrame` per frequency on a leading axis; ``quality``: the fused
    frame's flags' inputs."""

    frames: PreparedFrame
    freq: _Frequencies
    quality: FrameQuality

    @property
    def shape(self) -> tuple[int, int]:
        return tuple(self.frames.radial_true_m.shape[1:])

    @property
    def _first(self) -> PreparedFrame:
        return _at(self.frames, 0)

    @_jit.method
    def predict(self) -> FrameResult:
        """The analytic frame of the fused distance."""
        return self._wrap(_frame_predict(self))

    @_jit.method
    def noise_image(self) -> Array:
        return self.predict().depth_std_m

    @_jit.method
    def sample(self, key: PRNGKeyArray, frames: int = 1, *, raw: bool = False) -> NoisyFrames:
        """Only the frames of the fused distance."""
        check_counts(frames, frames, math.prod(self.shape), self._first.chain.n_phases, names=FRAME_COUNTS)
        _no_raw(raw)
        return _frame_sample(self, key, frames)

    @_jit.method
    def render(self, key: PRNGKeyArray, frames: int = 1, *, keep_frames: int = 0, raw: bool = False,
               progress: bool = False) -> FrameResult:
        """``frames`` Monte Carlo frames of every frequency, fused frame by frame, and their statistics
        (the sweep's multi-frequency engine, :func:`tofjax._multifrequency._Step`, on the pixels)."""
        n = math.prod(self.shape)
        n_freq = len(self.freq.ranges)
        # Frames are kept per frequency and once more fused.
        check_counts(frames, keep_frames, n * (n_freq + 1), self._first.chain.n_phases, names=FRAME_COUNTS, raw=raw)
        phases = n_freq * drawn_phases(self._first.chain.n_phases, self._first.chain.processing, image=True)
        elements = frame_chunk_elements()
        whole = whole_frames(self._first.chain.processing)
        mf = execute(_render_setup, _render_consts, _render_finish, (self, key, raw, frames), points=n, frames=frames,
                     keep=keep_frames, phases=phases, elements=max(elements, n * phases) if whole else elements,
                     block_points=n if whole else BLOCK_POINTS, progress=progress)
        per, kept = mf.per_frequency, None
        if mf.depth_m is not None:
            kept = {"depth_m": mf.depth_m, "valid": mf.valid, "phase_rad": 2.0 * jnp.pi * mf.depth_m / self.freq.extended,
                    "depth_unwrapped_m": mf.depth_m}
        fused = {"depth_mean_m": mf.depth_mean_m, "depth_std_m": mf.depth_std_m, "valid_fraction": mf.valid_fraction,
                 "wrong_unwrap_fraction": mf.wrong_unwrap_fraction}
        return self._wrap(_fused_result(per, self.freq, fused, kept))

    @_jit.method
    def _wrap(self, result: Result) -> FrameResult:
        first = self._first
        return FrameResult(result, first.radial_true_m, first.direction, first.pattern, self.quality)


def _no_raw(raw: bool) -> None:
    if raw:
        raise ValueError("raw = True: a multi-frequency camera's noisy frames carry the fused distance only; its "
                         "raw phase images come with tj.simulate(camera, scene, key, frames, keep_frames=..., "
                         "raw=True) (each frequency's in result.frames_tap_a_e ...)")


def _sample_stream(chain, consts, key, frames, shape, stream) -> NoisyFrames:
    return _sample_prepared(chain, consts, key, frames, shape, False, stream)


def _expected_depth_std(frame: MultiPreparedFrame) -> Array:
    """Each frequency's expected depth noise of a prepared frame (its flags' expected phase noise,
    :func:`tofjax._frame._expected`): what the fusion weighs the frequencies by."""
    return frame.frames.quality.expected_phase_std_rad * frame.freq.column(2) / (2.0 * jnp.pi)


def _fuse_frames(per: NoisyFrames, freq: _Frequencies, expected_std_m: Array) -> NoisyFrames:
    """Every frequency's noisy frames (a leading axis) fused frame by frame, with the fusion's weights
    of each frequency's expected noise ``expected_std_m``."""
    ndim = per.radial_m.ndim - 1
    weights = fusion_weights(expected_std_m**2, np.asarray(freq.ranges), freq.fusion)
    valid = jnp.all(per.valid, axis=0)
    phases = 2.0 * jnp.pi * jnp.where(valid[None], per.radial_m, 0.0) / freq.column(ndim)
    fused = unwrap_frequencies(phases, np.asarray(freq.ranges), freq.extended, weights[:, None])
    return NoisyFrames(jnp.where(valid, fused, jnp.nan), per.amplitude_lsb[0], valid)


def multi_prepare_camera(params, settings, pattern, *, smooth, processing, frequencies_hz, fusion) -> MultiPreparedCamera:
    """The :class:`MultiPreparedCamera` of a camera of several frequencies."""
    from ._frame import prepare_camera
    from ._multifrequency import _with_frequency

    freq = _Frequencies.of(frequencies_hz, fusion, float(params.constants.speed_of_light_m_per_s))
    cameras = jax.vmap(lambda f: prepare_camera(_with_frequency(params, f), settings, pattern, smooth=smooth,
                                                processing=processing))(jnp.asarray(freq.frequencies_hz))
    return MultiPreparedCamera(cameras, freq)


def over_frequencies(fn, cameras, returns: Returns, n_frequencies: int):
    """``jax.vmap`` of ``fn(camera, returns)`` over the frequencies' prepared ``cameras`` (a leading
    axis), each frequency with the returns of its own phase images: a static scene's returns are
    every frequency's; returns tagged with the frame's phase images (:attr:`tofjax.Returns.phase_image`,
    a moving scene's) give frequency i those tagged i n .. i n + n - 1, as its phase images 0 .. n - 1
    (n phases per frequency, each frequency's phase images in turn: docs/model.md, "A camera in time:
    motion"), and those tagged -1 (every phase image). Every frequency must then have the same
    tags; ``ValueError`` otherwise."""
    if returns.phase_image is None:
        return jax.vmap(lambda c: fn(c, returns))(cameras)
    n = int(cameras.chain.n_phases)
    tags = np.asarray(returns.phase_image)
    total = n * n_frequencies
    if tags.max(initial=-1) >= total:
        raise ValueError(f"tofjax.Returns: phase_image names phase image {int(tags.max())}: the camera's frame has "
                         f"{total} ({n} phases x {n_frequencies} frequencies, each frequency's in turn; -1: every one)")
    picks = [np.flatnonzero((tags == -1) | (tags // n == i)) for i in range(n_frequencies)]
    local = {tuple(int(t) for t in np.where(tags[p] == -1, -1, tags[p] % n)) for p in picks}
    sources = {None if returns.source is None else tuple(np.asarray(returns.source)[p].tolist()) for p in picks}
    if len(local) != 1 or len(sources) != 1:
        raise ValueError("tofjax.Returns: phase_image: every frequency's phase images need the same returns (the same "
                         "number tagged with each of its phase images): a moving scene's returns made with this camera "
                         "have them")
    (phase_image,), (source,) = local, sources
    index = jnp.asarray(np.stack(picks))  # (frequencies, returns of each)

    def one(camera, pick):
        return fn(camera, Returns(returns.path_m[..., pick], returns.radiance_per_w[..., pick],
                                  returns.ambient_reflectivity, returns.radial_m, phase_image, source))

    return jax.vmap(one)(cameras, index)


_scene_flags = _jit.jit(scene_flags)


# One program each (a vmap over the frequencies of the single frequency's programs, traced inline).
@_jit.jit
def _camera_predict(camera: MultiPreparedCamera, returns: Returns) -> FrameResult:
    per = over_frequencies(lambda c, r: c._predict(r), camera.cameras, returns, len(camera.freq.ranges))
    first = camera._first
    return FrameResult(_fused_result(per.result, camera.freq, fuse_expected(per.result, camera.freq)), returns.radial_m,
                       first.direction, first.pattern, _quality(per.quality, camera._flags(returns)))


@_jit.jit
def _camera_prepare(camera: MultiPreparedCamera, returns: Returns) -> MultiPreparedFrame:
    frames = over_frequencies(lambda c, r: c._prepare(r), camera.cameras, returns, len(camera.freq.ranges))
    return MultiPreparedFrame(frames, camera.freq, _quality(frames.quality, camera._flags(returns)))


@_jit.jit
def _frame_predict(frame: MultiPreparedFrame) -> Result:
    per = jax.vmap(lambda f: f.predict())(frame.frames).result
    return _fused_result(per, frame.freq, fuse_expected(per, frame.freq))


@_jit.jit
def _frame_sample(frame: MultiPreparedFrame, key, frames: int) -> NoisyFrames:
    shape = frame.shape
    per = jax.vmap(lambda ch, c, s: _sample_stream(ch, c, key, frames, shape, s))(
        frame.frames.chain, frame.frames.prepared.consts, jnp.arange(len(frame.freq.ranges), dtype=jnp.uint32))
    return _fuse_frames(per, frame.freq, _expected_depth_std(frame))


@_jit.jit
def _render_setup(frame: MultiPreparedFrame, key, raw, frames):
    """The run's chunk step: every frequency's chain, its own random stream, fused frame by frame on
    the pixels (whole frames where a processing stage reads neighbours); carried: the noise-free fused
    distance, the true distance and the fusion's weights (of each frequency's expected noise). One
    program (the run's setup from the host, :func:`tofjax._executor.execute`), where its operations
    each compiled one."""
    words = key_words(jr.split(key)[1])
    image = frame.shape if whole_frames(frame._first.chain.processing) else None
    step = _Step(frame.frames.chain, words, jnp.arange(len(frame.freq.ranges), dtype=jnp.uint32),
                 frame.freq.ranges, frame.freq.extended, raw, image)
    ranges = np.asarray(frame.freq.ranges)
    weights = fusion_weights(_expected_depth_std(frame)**2, ranges, frame.freq.fusion).reshape(len(ranges), -1)
    reference = unwrap_frequencies(jnp.mod(frame.frames.prepared.consts.ref_phase, 2.0 * jnp.pi), ranges,
                                   frame.freq.extended, weights)
    truth = jnp.mod(frame._first.sweep.values.reshape(-1), frame.freq.extended)
    return (reference, truth, weights), step


def _render_consts(frame: MultiPreparedFrame, key, raw, frames, carry):
    """The blocks' inputs: every frequency's constants (as prepared: not copied) and the setup's."""
    return (frame.frames.prepared.consts, *carry)


@_jit.jit
def _render_finish(frame: MultiPreparedFrame, key, raw, frames, carry, sums, kept):
    first = frame._first
    return _finish(first.chain.params, first.sweep, frames, jnp.asarray(frame.freq.frequencies_hz), frame.freq.extended,
                   frame.freq.fusion, frame.frames.chain, frame.frames.prepared, carry[0], sums, kept)
