"""Full frames: the composed chain for every pixel of the array (thesis §6.1.1-6.1.3, future work;
docs/model.md, "Full frames").

A frame is the chain of :mod:`tofjax._chain` run with one operating point per pixel. Only the
exposure differs from the centre pixel's: each pixel collects the returns of its scene
(:mod:`tofjax._returns`) through the lens, with the camera equation's relative illumination
(:mod:`tofjax._framegeometry`), the mixer sorts each return by its own delay (the phasors of several
returns add), the fixed pattern (:mod:`tofjax._pattern`) scales, shifts and splits the charges and
sets each pixel's full well, and from there noise, SBI, saturation, ADC and demodulation are the
centre pixel's, per pixel: :func:`tofjax.predict` of a frame scene folds their moments (the
per-pixel noise image), :func:`tofjax.simulate` draws Monte Carlo frames.

What does not depend on the scene (the chain, each pixel's conversion of radiance to electrons, its
dark electrons) is a :class:`PreparedCamera`, computed once by :meth:`tofjax.Camera.prepare`; what
does not depend on the frames' noise (a scene's charges and the frames' per-pixel constants) is a
:class:`PreparedFrame` (:meth:`tofjax.Camera.expose`). The verbs prepare the camera on every call.
"""

from __future__ import annotations

import dataclasses
import math
import weakref

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float, PRNGKeyArray

from . import _jit
from ._analytic import analytic, moments
from ._chain import Chain, build_chain
from ._correlation import UNROLLED_RETURNS
from ._flags import (FLAG_INVALIDATED, FLAG_LOW_AMPLITUDE, FLAG_LOW_SIGNAL, FLAG_MIXED, FLAG_NO_RETURN,
                     FLAG_OUTSIDE_ILLUMINATION, FLAG_SATURATED, FLAG_WRAPPED, delivered)
from ._framegeometry import FrameSettings, frame_shape, lens_distortion, pixel_etendue_m2_sr
from ._executor import BLOCK_POINTS, equal_parts, execute, frame_chunk_elements, programs
from ._frames import PointCharges, draw_delivered
from ._charges import Exposure, TapCharges, written_out
from ._mixer import phase_drift_periods
from ._montecarlo import Prepared, assemble, check_counts, drawn_phases, frames_step
from ._noise import dark_electrons
from ._photometry import active_e_per_radiance, background_e_per_reflectivity
from ._params import Params
from ._pattern import PixelPattern, mean_pattern
from ._precision import in_precision
from ._processing import whole_frames
from ._random import key_words
from ._reduce import sum_by_slices
from ._result import Result
from ._returns import Returns, _illuminator, intensity_per_w
from ._scene import pixel_directions, pixel_field
from ._smooth import Smooth
from ._sweep import Sweep

class FrameQuality(eqx.Module):
    """What a frame's flags need besides its statistics, per pixel ``(rows, cols)``: the bits that
    come from the scene and the camera's geometry (:func:`scene_flags`), the expected (analytic)
    phase noise and amplitude, and the configured thresholds (``[frame]``)."""

    scene_flags: Array
    expected_phase_std_rad: Float[Array, "rows cols"]
    expected_amplitude_lsb: Float[Array, "rows cols"]
    max_phase_noise_rad: Float[Array, ""]
    min_amplitude_lsb: Float[Array, ""]


def scene_flags(params: Params, settings: FrameSettings, returns: Returns, direction: Array,
                unambiguity_m: Array | None = None) -> Array:
    """The flags of :data:`FLAGS` that the scene and the geometry decide: no return, wrapped,
    mixed, outside the illumination (int32, ``(rows, cols)``); ``unambiguity_m``: the camera's
    unambiguity range (default: its frequency's; several frequencies: their extended range)."""
    du = params.unambiguity_range_m if unambiguity_m is None else unambiguity_m

    def over_returns(x):  # adds of the few returns' slices, not XLA's slow reduction over a short axis
        return sum_by_slices(x, -1, UNROLLED_RETURNS)

    own = returns.own_light()  # the scene's flags are this camera's light's (another camera's is not a return)
    radiance = returns.radiance_per_w if own is None else returns.radiance_per_w * jnp.asarray(
        own, returns.radiance_per_w.dtype).reshape(1, 1, -1)
    total = over_returns(radiance)
    radial = returns.radial_m
    surface = jnp.isfinite(radial)
    none = ~(total > 0.0) | ~surface
    wrapped = surface & (radial >= du)
    # The spread of the distances the pixel's light comes from: the radiance-weighted standard
    # deviation of its returns' one-way distances (two surfaces sharing w and 1 - w of the light
    # at a distance D apart: D sqrt(w (1 - w))).
    weight = radiance / jnp.where(total > 0.0, total, 1.0)[..., None]
    one_way = 0.5 * returns.path_m
    mean = over_returns(weight * one_way)
    spread = jnp.sqrt(jnp.maximum(over_returns(weight * (one_way - mean[..., None]) ** 2), 0.0))
    mixed = ~none & (spread > settings.mixed_spread_fraction * du)
    # The illumination's intensity towards what the pixel sees (its centre ray's point; its direction
    # where it meets nothing), from the illumination's position (the baseline).
    point = jnp.where(surface, radial, 1.0)[..., None] * direction
    outside = intensity_per_w(params.illumination, settings.illumination_falloff_exponent,
                              point - jnp.broadcast_to(_illuminator(settings.baseline_m), point.shape)) <= 0.0
    return (_bit(none, FLAG_NO_RETURN) | _bit(wrapped, FLAG_WRAPPED) | _bit(mixed, FLAG_MIXED)
            | _bit(outside, FLAG_OUTSIDE_ILLUMINATION))


def _bit(condition: Array, flag: int) -> Array:
    """``flag`` where ``condition`` holds, else 0, as int32. Every term of a flags' OR is int32: XLA's
    CPU compiler (jax 0.10.2) crashes on the OR of an int64 and an int32 array."""
    return jnp.where(condition, jnp.int32(flag), jnp.int32(0))


def _quality(chain: Chain, settings: FrameSettings, returns: Returns, direction: Array, phase_std_rad: Array,
             amplitude_lsb: Array) -> FrameQuality:
    """A frame's :class:`FrameQuality`: its scene flags, and its expected phase noise and amplitude
    (the analytic frame's: :func:`_phase_noise`)."""
    return FrameQuality(_scene_flags(chain.params, settings, returns, direction), phase_std_rad, amplitude_lsb,
                        settings.max_phase_noise_rad, settings.min_amplitude_lsb)


def _phase_noise(expected: Result) -> tuple[Array, Array]:
    """The expected phase noise (rad) and amplitude of an analytic frame: what its flags read."""
    return expected.depth_std_m * 2.0 * jnp.pi / expected.unambiguity_range_m, expected.amplitude_mean_lsb


class PreparedCamera(eqx.Module):
    """A camera prepared for frames once (:meth:`tofjax.Camera.prepare`): everything of a frame that does
    not depend on the scene, so that a scene's frames, noise image or analytic frame cost only its
    exposure and the chain after it. What a simulated camera streaming a changing scene needs.

    **Fields** (``(rows, cols)`` per pixel):
    - ``chain``: the frame's chain (:func:`tofjax.chain.build_chain`, each pixel's own full well);
    - ``settings``: the ``[frame]`` settings (:class:`tofjax.FrameSettings`);
    - ``pattern``: the camera sample (:class:`tofjax.PixelPattern`);
    - ``active_e_per_radiance``: active electrons per phase image and per unit of a return's
      ``radiance_per_w`` (W m^-2 sr^-1 per W): peak power x the waveform's mean x the pixel's
      etendue x its PRNU gain x t / (h c / lambda) x QE (the camera equation, :mod:`tofjax._framegeometry`);
    - ``background_e_per_reflectivity``: background electrons per unit of a pixel's
      ``ambient_reflectivity`` (the background photon irradiance / pi x etendue x gain x t x QE);
    - ``dark_a_e``, ``dark_b_e``: each tap's dark electrons;
    - ``direction``: each pixel's unit ray ``(rows, cols, 3)``.

    The methods take a scene's :class:`tofjax.Returns` and work under ``jit``, ``vmap`` and ``grad``
    like the verbs they share their programs with (``tj.predict(camera, returns)`` is
    ``camera.prepare().predict(returns)``, and so on).
    """

    chain: Chain
    settings: FrameSettings
    pattern: PixelPattern
    active_e_per_radiance: Float[Array, "rows cols"]
    background_e_per_reflectivity: Float[Array, "rows cols"]
    dark_a_e: Float[Array, "rows cols"]
    dark_b_e: Float[Array, "rows cols"]
    direction: Float[Array, "rows cols 3"]

    @property
    def shape(self) -> tuple[int, int]:
        return tuple(self.dark_a_e.shape)

    @_jit.method
    def expose(self, returns: Returns) -> Exposure:
        """Every pixel's :class:`Exposure` of a scene, at the camera's illuminance and
        integration time: each return sorted by the mixer with its own delay f path / c (Eq 3.22)
        plus the pixel's phase offset, the returns' phasors added (Eqs 3.19-3.21).

        A program of its own, which returns only what depends on the scene (a program's output that
        is one of its inputs is a copy). Inside a transformation of the caller's (``jit``, ``vmap``,
        ``grad``: one program with what reads it), the modulated sum is written out by
        :func:`tofjax._charges.written_out` instead."""
        return self._with_camera(*programs(_scene_light, _scene_light_materialised, (self, returns)))

    @_jit.method
    def _scene_light(self, returns: Returns) -> tuple[Array, Array, Array]:
        """What of the exposure depends on the scene: (modulated, signal, background) electrons."""
        params = self.chain.params
        per_return = returns.radiance_per_w * self.active_e_per_radiance[..., None]  # (rows, cols, k)
        periods_per_m = params.illumination_waveform.modulation_frequency_hz / params.constants.speed_of_light_m_per_s
        mask = returns.phase_mask(self.chain.n_phases)  # a moving scene: each return lights its own phase images
        own = returns.own_light()  # another camera's light in the scene: its returns apart
        offset = self.pattern.phase_offset_rad / (2.0 * jnp.pi) + phase_drift_periods(params.pixel)
        background = returns.ambient_reflectivity * self.background_e_per_reflectivity
        contrast = params.pixel.demodulation_contrast
        if own is None:
            modulated = contrast * self.chain.correlation.weighted_sum(per_return, returns.path_m, periods_per_m,
                                                                       offset, mask)
            signal = (sum_by_slices(per_return, -1, UNROLLED_RETURNS) if mask is None
                      else jnp.einsum("...k,kp->...p", per_return, jnp.asarray(mask)))  # then per phase image
            return modulated, signal, background
        from . import _interference as interference

        if self.chain.drift is None:
            raise ValueError("these returns include another camera's light (Returns.source) but this camera's "
                             "interference.enabled is false: make the returns with this camera")
        phases = np.ones((own.size, self.chain.n_phases)) if mask is None else mask
        mine, theirs = phases * own[:, None], phases * (1.0 - own[:, None])
        weight = jnp.asarray(own) + jnp.asarray(1.0 - own) * interference.electrons_scale(params)  # (k,)
        scaled = per_return * weight.reshape((1,) * (per_return.ndim - 1) + (-1,))  # the interferer's electrons
        fractions = interference.averaged_fractions(
            self.chain.correlation, self.chain.drift, interference.delay_periods(params, returns.path_m)
            + offset[..., None], params.interference.frequency_offset_hz, params.scene.integration_time_s,
            params.timing.readout_time_s)
        modulated = contrast * (self.chain.correlation.weighted_sum(per_return, returns.path_m, periods_per_m, offset,
                                                                    mine)
                                + jnp.einsum("...k,kp,...kp->...p", scaled, jnp.asarray(theirs), fractions))
        signal = jnp.einsum("...k,kp->...p", scaled, jnp.asarray(phases))
        return modulated, signal, background

    @_jit.method
    def _with_camera(self, modulated: Array, signal: Array, background: Array) -> Exposure:
        return Exposure(modulated, signal, background, self.chain.params.pixel.demodulation_contrast,
                             self.pattern.tap_asymmetry, self.dark_a_e, self.dark_b_e)

    @_jit.method
    def sample(self, returns: Returns, key: PRNGKeyArray, frames: int = 1, *, raw: bool = False) -> NoisyFrames:
        """``frames`` noisy frames of a scene (what a stream of changing scenes needs): radial distance, amplitude and
        validity, ``(frames, rows, cols)``, and with ``raw`` their raw phase images."""
        returns = self._check(returns)
        check_counts(frames, frames, math.prod(self.shape), self.chain.n_phases, names=FRAME_COUNTS)
        return _sample_charges(self.chain, self.expose(returns), key, frames, self.shape, raw)

    @_jit.method
    def noise_image(self, returns: Returns) -> Float[Array, "rows cols"]:
        """A scene's noise image: each pixel's analytic standard deviation of
        its radial distance, m."""
        returns = self._check(returns)
        return _noise_image_prepared(self.chain, returns.radial_m, self.expose(returns))

    @_jit.method
    def predict(self, returns: Returns) -> FrameResult:
        """A scene's analytic frame (``tj.predict(camera, returns)``)."""
        return self._predict(self._check(returns))

    def _predict(self, returns: Returns) -> FrameResult:
        """:meth:`predict` of returns already checked (:meth:`_check`): inside a program of tofjax's own,
        where a check of traced values would be a host callback, and a program holding one is never
        written to the persistent compilation cache (compiled again by every process)."""
        result = _predict_prepared(self.chain, returns.radial_m, self.expose(returns))
        quality = _quality(self.chain, self.settings, returns, self.direction, *_phase_noise(result))
        return FrameResult(result, returns.radial_m, self.direction, self.pattern, quality)

    @_jit.method
    def prepare(self, returns: Returns) -> PreparedFrame:
        """A scene exposed once (:meth:`tofjax.Camera.expose`), with its flags' expected noise and amplitude
        (the analytic frame's) and the scene's own flags."""
        return self._prepare(self._check(returns))

    def _prepare(self, returns: Returns) -> PreparedFrame:
        """:meth:`prepare` of returns already checked (as :meth:`_predict`)."""
        exposure = self.expose(returns)
        sweep, charges, consts = _charges_and_constants(self.chain, returns.radial_m, exposure)
        quality = _quality(self.chain, self.settings, returns, self.direction, *_expected(self.chain, sweep, charges))
        return PreparedFrame(self.chain, sweep, Prepared(charges, consts), returns.radial_m, self.direction,
                             self.pattern, quality)

    @_jit.method
    def render(self, returns: Returns, key: PRNGKeyArray, frames: int = 1, *, keep_frames: int = 0,
               raw: bool = False, progress: bool = False) -> FrameResult:
        """Monte Carlo frames of a scene and their statistics (``tj.simulate(camera, returns, ...)``)."""
        returns = self._check(returns)
        check_counts(frames, keep_frames, math.prod(self.shape), self.chain.n_phases, names=FRAME_COUNTS, raw=raw)
        return self.prepare(returns).render(key, frames, keep_frames=keep_frames, raw=raw, progress=progress)

    @_jit.method
    def _check(self, returns) -> Returns:
        """``returns`` for this camera: its type and shape, its values where traced
        (:meth:`tofjax.Returns.checked`)."""
        if not isinstance(returns, Returns):
            raise TypeError(f"returns must be tofjax.Returns, got {type(returns).__name__}")
        if tuple(returns.shape) != self.shape:
            raise ValueError(f"the returns have {returns.shape[0]} x {returns.shape[1]} pixels, the camera "
                             f"{self.shape[0]} x {self.shape[1]} (rows x cols)")
        if self.chain.dtype != jnp.float64:  # a float32 camera (Camera.astype): the scene in its precision
            if returns.phase_image is not None or returns.source is not None:
                raise ValueError("a float32 camera (Camera.astype) runs a static scene of its own light; these returns "
                                 "are a moving scene's or carry another camera's light: use camera.astype('float64')")
            returns = in_precision(returns, self.chain.dtype.name)
        return returns.checked()


#: The frame functions' names of the Monte Carlo counts (:func:`tofjax._montecarlo.check_counts`).
FRAME_COUNTS = ("frames", "keep_frames")


def _camera(params: Params, settings: FrameSettings, pattern: PixelPattern | None, smooth: Smooth | None,
            shape: tuple[int, int], distortion: Array | None, chain: Chain | None = None, processing: tuple = ()
            ) -> PreparedCamera:
    """The :class:`PreparedCamera` of ``params`` (``distortion``: the lens', decided outside the
    program, :func:`tofjax._framegeometry.lens_distortion`; ``chain``: the frame's chain, if built;
    ``processing``: the camera's processing stages, else)."""
    pattern = _pattern(params, shape, pattern)
    chain = _frame_chain(params, smooth, math.prod(shape), pattern, processing) if chain is None else chain
    scene, consts, pixel = params.scene, params.constants, params.pixel
    t = scene.integration_time_s
    per_radiance = pixel_etendue_m2_sr(params, settings, pixel_field(params.camera, shape)) * pattern.gain  # m^2 sr
    active = active_e_per_radiance(params, per_radiance, t)
    background = background_e_per_reflectivity(params, per_radiance, scene.illuminance_lx, t)
    return PreparedCamera(chain, settings, pattern, active, background,
                          dark_electrons(pixel, t, consts, pattern.dark_slope_a_v_per_s),
                          dark_electrons(pixel, t, consts, pattern.dark_slope_b_v_per_s),
                          pixel_directions(params.camera, shape, distortion))


def prepare_camera(params: Params, settings: FrameSettings, pattern: PixelPattern | None = None, *,
                   smooth: Smooth | None = None, processing: tuple = ()) -> PreparedCamera:
    """Prepare a camera for frames once (:class:`PreparedCamera`): its chain, each pixel's
    conversion of radiance to electrons and its dark electrons. Its methods then expose scenes
    (``sample``, ``noise_image``, ``predict``, ``prepare``, ``render``), each call costing only the
    scene's exposure and the chain after it (:meth:`tofjax.Camera.prepare`)."""
    _check_camera(params, settings, pattern)
    shape = frame_shape(params)
    if pattern is not None:
        for field in dataclasses.fields(pattern):
            if (got := tuple(jnp.shape(getattr(pattern, field.name)))) != shape:
                raise ValueError(f"pattern.{field.name} has shape {got}, the camera {shape[0]} x "
                                 f"{shape[1]} pixels: allowed a pattern of the camera's shape, "
                                 f"tj.draw_pattern(params, settings, {shape})")
    return _prepare_camera(params, settings, pattern, smooth, shape, lens_distortion(settings), None, processing)


def frame_exposure(chain: Chain, settings: FrameSettings, returns: Returns, pattern: PixelPattern) -> Exposure:
    """Every pixel's :class:`Exposure` on the frame's ``chain`` (:meth:`PreparedCamera.expose`)."""
    return _camera(chain.params, settings, pattern, None, returns.shape, lens_distortion(settings), chain
                   ).expose(returns)


def frame_charges(chain: Chain, settings: FrameSettings, returns: Returns, pattern: PixelPattern) -> TapCharges:
    """Expected tap electrons of every pixel at the scene's nominal illuminance and integration
    time: ``(rows, cols, phases)`` (module docstring)."""
    return frame_exposure(chain, settings, returns, pattern).charges()


class FrameResult(eqx.Module):
    """A frame's per-pixel results, ``(rows, cols)`` leading axes.

    **Fields:** ``result`` (a :class:`tofjax.Result` with one operating point per pixel: expected
    and measured depth, its standard deviation, amplitude, intensity, noise budget, flags; Monte
    Carlo frames, when kept, on the axis after the pixels); ``radial_true_m`` (the centre ray's true
    distance, inf where it meets nothing); ``direction`` (each pixel's unit ray, ``(rows, cols,
    3)``); ``pattern`` (the camera sample); ``quality`` (what :attr:`flags` needs besides the
    statistics: :class:`FrameQuality`).

    Measured distances are radial (along the pixel's ray, what a ToF pixel measures, wrapped to
    the unambiguity range); ``z_m`` is the Z depth (the distance's projection on the optical axis).
    """

    result: Result
    radial_true_m: Float[Array, "rows cols"]
    direction: Float[Array, "rows cols 3"]
    pattern: PixelPattern
    quality: FrameQuality

    @property
    def method(self) -> str:
        return self.result.method

    @property
    def radial_m(self) -> Array:
        """Measured radial distance (analytic: expected; Monte Carlo: mean of the frames), m."""
        return self.result.depth_mean_m

    @property
    def z_m(self) -> Array:
        """Measured Z depth, m."""
        return self.result.depth_mean_m * self.direction[..., 2]

    @property
    def z_true_m(self) -> Array:
        return self.radial_true_m * self.direction[..., 2]

    @property
    def depth_std_m(self) -> Array:
        """Per-pixel standard deviation of the radial distance, m (the noise image)."""
        return self.result.depth_std_m

    @property
    def amplitude_lsb(self) -> Array:
        return self.result.amplitude_mean_lsb

    @property
    def intensity_e(self) -> Array:
        """Mean electrons per tap and phase image (the grey-value image)."""
        return self.result.intensity_e

    @property
    def frames_radial_m(self) -> Array | None:
        """The kept Monte Carlo frames' radial distances, ``(frames, rows, cols)`` (``None``: none kept)."""
        d = self.result.depth_m
        return None if d is None else jnp.moveaxis(d, -1, 0)

    @property
    def flags(self) -> Array:
        """Bits of :data:`FLAGS` per pixel (int32; 0: a good pixel with no diagnostic). Low signal and
        low amplitude come from the expected noise and amplitude (:class:`FrameQuality`), not from
        the frames' own spread, which a few frames do not pin down; the camera's own invalidation
        (its processing) from the delivered fraction. The camera delivers a pixel without
        :data:`~tofjax._flags.CAMERA_FLAGS` (:attr:`delivered`); the rest are diagnostics of the
        truth (:mod:`tofjax._flags`)."""
        q, r = self.quality, self.result
        saturated = (r.pixel_saturated_fraction > 0.0) | (r.adc_saturated_fraction > 0.0)
        low = ~(q.expected_phase_std_rad <= q.max_phase_noise_rad)
        dim = q.expected_amplitude_lsb < q.min_amplitude_lsb
        invalidated = (r.valid_fraction < 0.5) & ~saturated & ~low & ~dim
        return (_bit(saturated, FLAG_SATURATED) | _bit(low, FLAG_LOW_SIGNAL) | _bit(dim, FLAG_LOW_AMPLITUDE)
                | _bit(invalidated, FLAG_INVALIDATED) | q.scene_flags)

    @property
    def delivered(self) -> Array:
        """Whether the camera delivers each pixel: none of its own flags
        (:data:`~tofjax._flags.CAMERA_FLAGS`: saturated, low signal, low amplitude, invalidated). The
        truth's diagnostics (mixed, wrapped, no return, outside the illumination) never remove one:
        a camera delivers a mixed pixel's biased depth unless its own data reject it."""
        return delivered(self.flags)

    def points_m(self, radial_m: Array | None = None) -> np.ndarray:
        """The point cloud ``(n, 3)`` of the pixels the camera delivers (:attr:`delivered`; x right, y
        up, z along the axis), from the measured radial distances (or ``radial_m``)."""
        radial = np.asarray(self.radial_m if radial_m is None else radial_m)
        keep = np.asarray(self.delivered) & np.isfinite(radial)
        return (radial[..., None] * np.asarray(self.direction))[keep]


def _frame_chain(params: Params, smooth: Smooth | None, points: int, pattern: PixelPattern, processing: tuple = ()
                 ) -> Chain:
    """The chain of the frame's pixels: each its own full well ``(rows, cols, 1)`` (:func:`build_chain`),
    and the camera's processing stages."""
    return build_chain(params, smooth, points, pattern, processing)


def _sweep(params: Params, radial_m: Array | Sweep) -> Sweep:
    """One operating point per pixel: its true distance (half the unambiguity range where it meets
    nothing, for the record only: the exposure comes from the returns) at the scene's illuminance and
    time (a :class:`tofjax.Sweep` passes as it is)."""
    if isinstance(radial_m, Sweep):
        return radial_m
    return Sweep("distance", jnp.where(jnp.isfinite(radial_m), radial_m, 0.5 * params.unambiguity_range_m))


def _pattern(params: Params, shape, pattern: PixelPattern | None) -> PixelPattern:
    return mean_pattern(params, shape) if pattern is None else pattern


def _check_camera(params, settings, pattern) -> None:
    if not isinstance(params, Params):
        raise TypeError(f"params must be a tofjax.Params, got {type(params).__name__}")
    if not isinstance(settings, FrameSettings):
        raise TypeError(f"settings must be a tofjax.FrameSettings, got {type(settings).__name__}")
    if pattern is not None and not isinstance(pattern, PixelPattern):
        raise TypeError(f"pattern must be a tofjax.PixelPattern or None, got {type(pattern).__name__}")


class PreparedFrame(eqx.Module):
    """A scene exposed once on a camera (:meth:`tofjax.Camera.expose`): the frame's chain, every pixel's
    expected charges and its Monte Carlo per-pixel constants, so that frames (:meth:`render`) and
    the noise image (:meth:`predict`) of the same scene and operating point cost only the chain
    after the exposure. What a live view or a stream of training frames of a static scene needs."""

    chain: Chain
    sweep: Sweep  # one operating point per pixel, (rows, cols)
    prepared: Prepared  # charges (rows, cols, phases) and the frames' constants (pixels flattened)
    radial_true_m: Float[Array, "rows cols"]
    direction: Float[Array, "rows cols 3"]
    pattern: PixelPattern
    quality: FrameQuality

    @property
    def shape(self) -> tuple[int, int]:
        return tuple(self.radial_true_m.shape)

    @_jit.method
    def render(self, key: PRNGKeyArray, frames: int = 1, *, keep_frames: int = 0, raw: bool = False,
               progress: bool = False) -> FrameResult:
        """``frames`` Monte Carlo frames (``tj.simulate(camera, scene, ...)`` is ``camera.expose(scene).render(...)``)."""
        check_counts(frames, keep_frames, math.prod(self.shape), self.chain.n_phases, names=FRAME_COUNTS, raw=raw)
        points, elements = math.prod(self.shape), frame_chunk_elements()
        phases = drawn_phases(self.chain.n_phases, self.chain.processing, image=True)
        whole = whole_frames(self.chain.processing)  # a stage reads neighbours or per-pixel values: whole frames
        return self._wrap(execute(_render_setup, _render_consts, _render_finish, (self, key, raw, frames),
                                  points=points, frames=frames, keep=keep_frames, phases=phases,
                                  elements=max(elements, points * phases) if whole else elements,
                                  block_points=points if whole else BLOCK_POINTS, progress=progress))

    @_jit.method
    def predict(self) -> FrameResult:
        """The analytic frame, the noise image (``tj.predict(camera, scene)``)."""
        return self._wrap(_predict_prepared(self.chain, self.sweep, self.prepared.charges))

    @_jit.method
    def noise_image(self) -> Float[Array, "rows cols"]:
        """Only the noise image: each pixel's analytic standard deviation of the radial distance, m
        (:attr:`FrameResult.depth_std_m` of :meth:`predict`), as a program that computes nothing
        else (about 4x faster than :meth:`predict` at 224 x 172, ``bench/bench_frame.py``)."""
        return _noise_image_prepared(self.chain, self.sweep, self.prepared.charges)

    @_jit.method
    def sample(self, key: PRNGKeyArray, frames: int = 1, *, raw: bool = False) -> NoisyFrames:
        """Only the frames: ``frames`` noisy frames' radial distance, amplitude and validity, without
        the per-pixel statistics of :meth:`render` (the frames :meth:`render` keeps for the same key);
        with ``raw`` (static) their raw phase images too."""
        check_counts(frames, frames, math.prod(self.shape), self.chain.n_phases, names=FRAME_COUNTS)
        return _sample_prepared(self.chain, self.prepared.consts, key, frames, self.shape, raw)

    @_jit.method
    def _wrap(self, result: Result) -> FrameResult:
        # Outside the programs: the geometry and the pattern are passed on, not copied by a program.
        return FrameResult(result, self.radial_true_m, self.direction, self.pattern, self.quality)


class NoisyFrames(eqx.Module):
    """Noisy frames (:meth:`PreparedFrame.sample`), ``(frames, rows, cols)``: ``radial_m`` (NaN
    where the pixel or the ADC saturated), ``amplitude_lsb``, ``valid``; with ``raw=True`` the raw
    phase images they were demodulated from, ``(frames, phases, rows, cols)``: ``codes`` (the ADC
    codes of the taps' difference), ``tap_a_e`` and ``tap_b_e`` (each tap's electrons as read;
    docs/model.md, "Raw phase images"), else ``None``."""

    radial_m: Float[Array, "frames rows cols"]
    amplitude_lsb: Float[Array, "frames rows cols"]
    valid: Array
    codes: Float[Array, "frames phases rows cols"] | None = None
    tap_a_e: Float[Array, "frames phases rows cols"] | None = None
    tap_b_e: Float[Array, "frames phases rows cols"] | None = None


# Programs: the camera, the exposure, and what reads it, each its own program: in one, XLA on a CPU
# fuses a producer into each of its consumers and evaluates it several times (docs/model.md,
# "Performance", measurement 15), and the exposure's sum over the returns has two (the taps; Exposure).
# Under an outer jit they are traced into one program as usual.
_prepare_camera = _jit.jit(_camera)
_key_words = _jit.jit(key_words)
_assemble = _jit.jit(assemble)
_scene_flags = _jit.jit(scene_flags)


@_jit.jit
def _scene_light(camera: PreparedCamera, returns: Returns) -> tuple[Array, Array, Array]:
    return camera._scene_light(returns)


def _scene_light_materialised(camera: PreparedCamera, returns: Returns) -> tuple[Array, Array, Array]:
    """:meth:`PreparedCamera._scene_light` inside one program, its modulated sum written out."""
    modulated, signal, background = camera._scene_light(returns)
    return written_out(modulated), signal, background


def _point_charges(chain, exposed: Exposure) -> PointCharges:
    """The pixels as the frames' points (flattened), each with its own full well; their charges are
    made where the frames are drawn."""
    n = math.prod(exposed.dark_a_e.shape)
    flat = jax.tree_util.tree_map(lambda x: x.reshape((n,) + x.shape[2:]) if x.ndim >= 2 else x, exposed)
    return PointCharges(flat, jnp.arange(n, dtype=jnp.uint32), chain.limit.full_well_e.reshape(n))


@_jit.jit
def _charges_and_constants(chain, radial_m, exposure: Exposure):
    return _sweep(chain.params, radial_m), exposure.charges(), _point_charges(chain, exposure).constants(chain)


def _render_setup(frame: PreparedFrame, key, raw, frames):
    """A prepared frame's run (:func:`tofjax._executor.execute`): nothing to carry, the chunk step of
    the frame's chain (only the key's words computed)."""
    return None, frames_step(frame.chain, _key_words(key), raw=raw, image=frame.shape)


def _render_consts(frame: PreparedFrame, key, raw, frames, carry):
    return frame.prepared.consts


def _render_finish(frame: PreparedFrame, key, raw, frames, carry, sums, kept) -> Result:
    return _assemble(frame.chain, frame.sweep, frame.prepared, sums, kept, frames)


@_jit.jit
def _predict_prepared(chain, sweep, exposed) -> Result:
    """The analytic frame (``sweep``: the pixels' :class:`Sweep`, or their true distances)."""
    sweep = _sweep(chain.params, sweep)
    return analytic(chain, sweep, moments(chain, sweep, exposed.charges(), image=True))


@_jit.jit
def _expected(chain, sweep, charges) -> tuple[Array, Array]:
    """A scene's expected phase noise and amplitude, for its flags: of the analytic frame only these,
    in a program of their own (the whole analytic frame cost a one-frame render a third of its
    time; with the scene's flags in the same program XLA evaluated the chain twice). The camera's
    spatial processing takes its closed form for a uniform neighbourhood here (``image=False``): the
    flags' thresholds need the noise's size, not its exact shape across an edge, and the analytic
    frame's order statistics of a median filter cost a second of a 224 x 172 frame (the noise image,
    :meth:`PreparedFrame.predict`, takes them)."""
    return _phase_noise(analytic(chain, sweep, moments(chain, sweep, charges, image=False)))


@_jit.jit
def _noise_image_prepared(chain, sweep, exposed) -> Array:
    sweep = _sweep(chain.params, sweep)
    return analytic(chain, sweep, moments(chain, sweep, exposed.charges(), image=True)).depth_std_m


@_jit.jit
def _sample_prepared(chain, source, key, frames, shape, raw=False, stream=0) -> NoisyFrames:
    # Frames first throughout (the frames :func:`run_blocks` keeps are points first): no transposes,
    # which cost more than the frames themselves (docs/model.md, "Performance", measurement 16). Chunks of
    # frames as in run_blocks, in a lax.map when there are several. ``source``: the pixels'
    # PointConstants, or their PointCharges, from which one chunk makes the constants as it draws
    # and several make them once.
    n, words = math.prod(shape), key_words(key)
    phases = drawn_phases(chain.n_phases, chain.processing, image=True)
    chunk = equal_parts(frames, max(1, frame_chunk_elements() // (n * phases)))
    n_chunks = -(-frames // chunk)
    to_m = chain.unambiguity_range_m / (2.0 * jnp.pi)

    if n_chunks > 1:
        source = source.constants(chain)

    def one(first):
        f = draw_delivered(chain, source, words, first, chunk, stream, frames_first=True, taps=raw, image=shape)
        valid = f.valid
        out = (jnp.where(valid, jnp.mod(f.phase, 2.0 * jnp.pi) * to_m, jnp.nan), f.amplitude, valid)
        # The raw images (phases, frames, points) -> frames first, as the images.
        return out + (tuple(jnp.moveaxis(x, 0, 1) for x in (f.codes, f.tap_a_e, f.tap_b_e)) if raw else ())

    if n_chunks == 1:
        out = one(jnp.uint32(0))
    else:
        out = jax.tree_util.tree_map(lambda x: x.reshape((n_chunks * chunk,) + x.shape[2:])[:frames],
                                     jax.lax.map(one, chunk * jnp.arange(n_chunks, dtype=jnp.uint32)))
    return NoisyFrames(*(x.reshape((frames, *x.shape[1:-1], *shape)) for x in out))


@_jit.jit
def _sample_charges(chain, exposed, key, frames, shape, raw=False) -> NoisyFrames:
    return _sample_prepared(chain, _point_charges(chain, exposed), key, frames, shape, raw)


def sharded_map(fn, batch, *, devices=None):
    """``fn`` over the leading axis of the pytree ``batch``, the batch split over JAX devices with
    ``jax.sharding`` (every CPU core, GPU or host process JAX sees; docs/model.md "Scaling out"):
    each device runs ``lax.map(fn, ...)`` over its share. The batch is padded to a multiple of the
    device count with copies of its last element, and the padding dropped from the result. The
    sharded program is built once per ``fn`` and devices (as ``jax.jit`` caches per function): a
    later call with a batch of the same shapes runs it without tracing or compiling again."""
    devices = jax.devices() if devices is None else list(devices)
    leaves = jax.tree_util.tree_leaves(batch)
    size = leaves[0].shape[0]
    count = len(devices)
    padded = -(-size // count) * count

    def pad(x):
        x = jnp.asarray(x)
        return jnp.concatenate([x, jnp.repeat(x[-1:], padded - size, axis=0)]) if padded > size else x

    out = _sharded(fn, tuple(devices))(jax.tree_util.tree_map(pad, batch))
    return jax.tree_util.tree_map(lambda x: x[:size], out)


#: The compiled sharded programs of :func:`sharded_map`, per function (kept as long as it is) and devices.
_SHARDED: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def _sharded(fn, devices: tuple):
    from jax.sharding import Mesh, PartitionSpec

    try:
        per_fn = _SHARDED.setdefault(fn, {})
    except TypeError:  # no weak reference or no hash (an equinox BoundMethod, a module): built per call
        per_fn = {}
    if devices not in per_fn:
        spec = PartitionSpec("batch")
        mesh = Mesh(np.array(devices), ("batch",))
        per_fn[devices] = jax.jit(jax.shard_map(lambda b: jax.lax.map(fn, b), mesh=mesh, in_specs=spec, out_specs=spec))
    return per_fn[devices]
