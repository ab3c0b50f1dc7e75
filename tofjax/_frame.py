"""Full frames: the composed chain for every pixel of the array (thesis §6.1.1-6.1.3, future work;
docs/model.md, "Full frames").

A frame is the chain of :mod:`tofjax._chain` run with one operating point per pixel. Only the
exposure differs from the centre pixel's: each pixel collects the returns of its scene
(:mod:`tofjax._returns`) through the lens, with the camera equation's relative illumination,

    flux = L x pi A_pixel k_lens cos^m(phi) (1 - v h^2) / (4 N^2)                    (Eqs 3.5-3.11)

(L the radiance the pixel sees, phi its field angle, m = ``frame.relative_illumination_exponent``,
h its image height over the half diagonal, v = ``frame.vignetting``, N the f-number); on the axis
and with L = rho E / pi this is the thesis' rho E FF A k_lens / (4 N^2). The mixer sorts each return
by its own delay (the phasors of several returns add), the fixed pattern (:mod:`tofjax._pattern`)
scales, shifts and splits the charges and sets each pixel's full well, and from there noise, SBI,
saturation, ADC and demodulation are the centre pixel's, per pixel: :func:`predict_frame` walks
them with means and variances (the per-pixel noise image), :func:`render_frame` with Monte Carlo
frames.
"""

from __future__ import annotations

import math

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float, PRNGKeyArray

from . import _jit
from ._analytic import analytic, moments
from ._chain import Chain, build_chain
from ._frames import draw_frames, drive_blocks, equal_parts, point_constants
from ._mixer import TapCharges, scene_photon_irradiance
from ._montecarlo import Prepared, assemble, assemble_jit, check_counts, frames_step, run_blocks
from ._noise import dark_electrons
from ._optics import photon_energy_j, quantum_efficiency
from ._params import Params, _check, _float, _static
from ._pattern import PixelPattern, mean_pattern
from ._random import key_words
from ._result import Result
from ._returns import Returns, direct_returns, two_bounce_returns
from ._scene import Rays, SceneGeometry, pixel_rays, resolution, surface, surface_from_depth
from ._smooth import Smooth
from ._sweep import Sweep
from ._waveforms import waveform_mean

#: Bits of :attr:`FrameResult.flags`.
FLAG_SATURATED = 1
FLAG_LOW_SIGNAL = 2
FLAG_NO_RETURN = 4
FLAGS = {
    FLAG_SATURATED: "saturated: the pixel or the ADC saturated (analytic: expected; Monte Carlo: in any frame)",
    FLAG_LOW_SIGNAL: "low signal: the phase noise exceeds 0.3 rad (a camera's amplitude threshold would reject it)",
    FLAG_NO_RETURN: "no return: the pixel's centre ray meets no surface of the scene (truth, not a measurement)",
}
#: Phase standard deviation above which a pixel is flagged as low signal, rad.
LOW_SIGNAL_PHASE_STD_RAD = 0.3


class FrameSettings(eqx.Module):
    """The ``[frame]`` section: the array's optics and its fixed-pattern sigmas (schema docs).

    ``subpixel_samples`` and ``seed`` are static; the rest are traced float leaves (a gradient
    reaches them).
    """

    subpixel_samples: int = _static("frame", "subpixel_samples")
    illumination_falloff_exponent: Float[Array, ""] = _float("frame", "illumination_falloff_exponent")
    baseline_m: Float[Array, "2"] = _float("frame", "baseline_m")
    relative_illumination_exponent: Float[Array, ""] = _float("frame", "relative_illumination_exponent")
    vignetting: Float[Array, ""] = _float("frame", "vignetting")
    prnu_sigma: Float[Array, ""] = _float("frame", "prnu_sigma")
    phase_offset_sigma_rad: Float[Array, ""] = _float("frame", "phase_offset_sigma_rad")
    tap_asymmetry_sigma: Float[Array, ""] = _float("frame", "tap_asymmetry_sigma")
    threshold_sigma: Float[Array, ""] = _float("frame", "threshold_sigma")
    seed: int = _static("frame", "seed")

    def __check_init__(self):
        _check(self, "frame")


def frame_settings(values) -> FrameSettings:
    """The :class:`FrameSettings` of a configuration's ``[frame]`` values (a mapping)."""
    return FrameSettings(**{k: (tuple(v) if isinstance(v, list) else v) for k, v in values.items()})


def frame_shape(params: Params) -> tuple[int, int]:
    """(rows, cols) of the pixel array (``camera.optical_area_m / camera.pixel_pitch_m``)."""
    return resolution(params.camera)


def frame_rays(params: Params, settings: FrameSettings, subpixel_samples: int | None = None,
               shape: tuple[int, int] | None = None) -> Rays:
    """The rays of every pixel of the camera (``subpixel_samples``: per axis, default the settings';
    ``shape``: (rows, cols), default the camera's, which needs concrete camera values)."""
    s = settings.subpixel_samples if subpixel_samples is None else subpixel_samples
    return pixel_rays(params.camera, frame_shape(params) if shape is None else shape, s)


@_jit.jit
def _scene_returns(params, settings, geometry, sun_direction, bins, shape):
    rays = frame_rays(params, settings, shape=shape)
    surf = surface(geometry, rays, sun_direction)
    out = direct_returns(params.illumination, settings.illumination_falloff_exponent, settings.baseline_m, surf, rays)
    if geometry.patches is not None:
        out = out + two_bounce_returns(params.illumination, settings.illumination_falloff_exponent,
                                       settings.baseline_m, surf, rays, geometry.patches, bins)
    return out


def scene_returns(params: Params, settings: FrameSettings, geometry: SceneGeometry, *, sun_direction=None,
                  bins: int = 32) -> Returns:
    """Every pixel's returns from a scene: the direct return of each sub-pixel ray and, for a scene
    with patches (:func:`tofjax.scenes.corner`), its two-bounce light in ``bins`` returns.
    ``sun_direction``: the background light's direction (:func:`tofjax._scene.surface`)."""
    sun = None if sun_direction is None else jnp.asarray(sun_direction, dtype=float)
    return _scene_returns(params, settings, geometry, sun, bins, frame_shape(params))


def depth_returns(params: Params, settings: FrameSettings, depth_m, reflectivity, *, radial: bool = False) -> Returns:
    """Every pixel's direct return from a depth map ``(rows, cols)`` (Z depth, or the radial
    distance with ``radial=True``) and a reflectivity map or number; one ray per pixel."""
    shape = frame_shape(params)
    depth = jnp.asarray(depth_m, dtype=float)
    if depth.shape != shape:
        raise ValueError(f"depth map has shape {depth.shape}, the camera {shape} (rows, cols; "
                         "camera.optical_area_m / camera.pixel_pitch_m)")
    return _depth_returns(params, settings, depth, jnp.asarray(reflectivity, dtype=float), radial, depth.shape)


@_jit.jit
def _depth_returns(params, settings, depth, reflectivity, radial, shape):
    rays = frame_rays(params, settings, 1, shape)
    surf = surface_from_depth(depth, reflectivity, rays, radial)
    return direct_returns(params.illumination, settings.illumination_falloff_exponent, settings.baseline_m, surf, rays)


def pixel_etendue_m2_sr(params: Params, settings: FrameSettings, rays: Rays) -> Float[Array, "rows cols"]:
    """pi A_pixel FF k_lens cos^m(phi) (1 - v h^2) / (4 N^2): the flux on a pixel per unit radiance
    of what it sees (module docstring), m^2 sr."""
    cam = params.camera
    area = cam.pixel_pitch_m[0] * cam.pixel_pitch_m[1] * cam.fill_factor
    relative = rays.cos_field_angle ** settings.relative_illumination_exponent
    vignette = 1.0 - settings.vignetting * rays.image_height**2
    return jnp.pi * area * cam.k_lens * relative * vignette / (4.0 * cam.f_number**2)


def frame_charges(chain: Chain, settings: FrameSettings, returns: Returns, pattern: PixelPattern,
                  rays: Rays | None = None) -> TapCharges:
    """Expected tap electrons of every pixel at the scene's nominal illuminance and integration
    time: ``(rows, cols, phases)`` (module docstring); ``rays``: the pixels' centre rays, if made."""
    params = chain.params
    scene, ill, consts, pixel = params.scene, params.illumination, params.constants, params.pixel
    t = scene.integration_time_s
    rays = frame_rays(params, settings, 1, returns.shape) if rays is None else rays
    per_radiance = pixel_etendue_m2_sr(params, settings, rays) * pattern.gain  # flux per radiance, m^2 sr
    qe = quantum_efficiency(pixel, ill.wavelength_m, consts)
    emitted = ill.peak_power_w * waveform_mean(params.illumination_waveform)
    to_electrons = t / photon_energy_j(ill.wavelength_m, consts) * qe  # per joule
    per_return = emitted * returns.radiance_per_w * (per_radiance * to_electrons)[..., None]  # (rows, cols, k)
    background = scene_photon_irradiance(params, scene.illuminance_lx) * returns.ambient_reflectivity / jnp.pi \
        * per_radiance * t * qe
    # Each return's delay f * path / c in periods (Eq 3.22), plus the pixel's phase offset.
    delay = params.illumination_waveform.modulation_frequency_hz * returns.path_m / consts.speed_of_light_m_per_s
    a = chain.correlation(delay + (pattern.phase_offset_rad / (2.0 * jnp.pi))[..., None])  # (rows, cols, k, phases)
    contrast = pixel.demodulation_contrast
    signal = jnp.sum(per_return, axis=-1)
    modulated = contrast * jnp.einsum("rck,rckp->rcp", per_return, a)  # the returns' phasors add (Eqs 3.19-3.21)
    equal = (0.5 * (1.0 - contrast) * signal + 0.5 * background)[..., None]
    photo_a = (modulated + equal) * (1.0 + pattern.tap_asymmetry)[..., None]
    photo_b = (contrast * signal[..., None] - modulated + equal) * (1.0 - pattern.tap_asymmetry)[..., None]
    dark_a = dark_electrons(pixel, t, consts, pattern.dark_slope_a_v_per_s)
    dark_b = dark_electrons(pixel, t, consts, pattern.dark_slope_b_v_per_s)
    return TapCharges(photo_a, photo_b, dark_a, dark_b, signal, background)


class FrameResult(eqx.Module):
    """A frame's per-pixel results, ``(rows, cols)`` leading axes.

    **Fields:** ``result`` (a :class:`tofjax.Result` with one operating point per pixel: expected
    and measured depth, its standard deviation, amplitude, intensity, noise budget, flags; Monte
    Carlo frames, when kept, on the axis after the pixels); ``radial_true_m`` (the centre ray's true
    distance, inf where it meets nothing); ``direction`` (each pixel's unit ray, ``(rows, cols,
    3)``); ``pattern`` (the camera sample).

    Measured distances are radial (along the pixel's ray, what a ToF pixel measures, wrapped to
    the unambiguity range); ``z_m`` is the Z depth (the distance's projection on the optical axis).
    """

    result: Result
    radial_true_m: Float[Array, "rows cols"]
    direction: Float[Array, "rows cols 3"]
    pattern: PixelPattern

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
        """Bits of :data:`FLAGS` per pixel (0: a good pixel)."""
        r = self.result
        saturated = jnp.where(r.valid_fraction < 1.0, FLAG_SATURATED, 0)
        phase_std = r.depth_std_m * 2.0 * jnp.pi / r.unambiguity_range_m
        low = jnp.where(~(phase_std <= LOW_SIGNAL_PHASE_STD_RAD), FLAG_LOW_SIGNAL, 0)
        none = jnp.where(jnp.isfinite(self.radial_true_m), 0, FLAG_NO_RETURN)
        return (saturated | low | none).astype(jnp.int32)

    def points_m(self, radial_m: Array | None = None) -> np.ndarray:
        """The point cloud ``(n, 3)`` of the pixels without flags (x right, y up, z along the axis),
        from the measured radial distances (or ``radial_m``)."""
        radial = np.asarray(self.radial_m if radial_m is None else radial_m)
        keep = (np.asarray(self.flags) == 0) & np.isfinite(radial)
        return (radial[..., None] * np.asarray(self.direction))[keep]


def _frame_chain(params: Params, smooth: Smooth | None, points: int, pattern: PixelPattern) -> Chain:
    """The chain with each pixel's own full well ``(rows, cols, 1)``."""
    chain = build_chain(params, smooth, points)
    well = chain.limit.full_well_e * pattern.full_well_scale[..., None]
    return eqx.tree_at(lambda c: c.limit.full_well_e, chain, well)


def _sweep(params: Params, returns: Returns) -> Sweep:
    """One operating point per pixel: its true distance (half the path where it meets nothing, for
    the record only: the exposure comes from the returns) at the scene's illuminance and time."""
    d = jnp.where(jnp.isfinite(returns.radial_m), returns.radial_m, 0.5 * params.unambiguity_range_m)
    return Sweep("distance", d)


def _pattern(params: Params, shape, pattern: PixelPattern | None) -> PixelPattern:
    return mean_pattern(params, shape) if pattern is None else pattern


def _check_frame(params, settings, returns):
    if not isinstance(params, Params):
        raise TypeError(f"params must be a tofjax.Params, got {type(params).__name__}")
    if not isinstance(settings, FrameSettings):
        raise TypeError(f"settings must be a tofjax.FrameSettings, got {type(settings).__name__}")
    if not isinstance(returns, Returns):
        raise TypeError(f"returns must be tofjax.Returns, got {type(returns).__name__}")
    if tuple(returns.shape) != frame_shape(params):
        raise ValueError(f"the returns have {returns.shape[0]} x {returns.shape[1]} pixels, the camera "
                         f"{frame_shape(params)[0]} x {frame_shape(params)[1]} (rows x cols)")


def _setup(params, settings, returns, pattern, smooth):
    """What both paths need: the pattern, the frame's chain, one operating point per pixel, the
    expected charges and the pixels' centre rays (computed once)."""
    shape = returns.shape
    pattern = _pattern(params, shape, pattern)
    chain = _frame_chain(params, smooth, math.prod(shape) * returns.path_m.shape[-1], pattern)
    rays = frame_rays(params, settings, 1, shape)
    charges = frame_charges(chain, settings, returns, pattern, rays)
    return pattern, chain, _sweep(params, returns), charges, rays.centre


@_jit.jit
def _predict_frame(params, settings, returns, pattern, smooth):
    pattern, chain, sweep, charges, direction = _setup(params, settings, returns, pattern, smooth)
    result = analytic(chain, sweep, moments(chain, sweep, charges))
    return FrameResult(result, returns.radial_m, direction, pattern)


def noise_image(params: Params, settings: FrameSettings, returns: Returns, pattern: PixelPattern | None = None, *,
                smooth: Smooth | None = None) -> Float[Array, "rows cols"]:
    """The per-pixel noise image of a scene: the analytic standard deviation of each pixel's radial
    distance, m (``predict_frame(...).depth_std_m``, arguments as :func:`predict_frame`), computing
    nothing else. Of a scene exposed once, :meth:`PreparedFrame.noise_image` skips the exposure."""
    _check_frame(params, settings, returns)
    _, chain, sweep, charges, _ = _setup_jit(params, settings, returns, pattern, smooth)
    return _noise_image_prepared(chain, sweep, charges)


def predict_frame(params: Params, settings: FrameSettings, returns: Returns, pattern: PixelPattern | None = None, *,
                  smooth: Smooth | None = None) -> FrameResult:
    """The analytic frame: every pixel's expected depth, amplitude and intensity and the standard
    deviations propagated through the chain (:func:`tofjax.predict` per pixel): the noise image.

    **Arguments:** ``params`` (the camera; ``scene.illuminance_lx`` and ``scene.integration_time_s``
    set the operating point, the returns the geometry), ``settings`` (:class:`FrameSettings`),
    ``returns`` (:func:`scene_returns`, :func:`depth_returns` or :func:`tofjax.load_returns`),
    ``pattern`` (:func:`tofjax.draw_pattern`; ``None``: every pixel the mean pixel), ``smooth``.
    """
    _check_frame(params, settings, returns)
    return _predict_frame(params, settings, returns, pattern, smooth)


class PreparedFrame(eqx.Module):
    """A scene exposed once on a camera (:func:`prepare_frame`): the frame's chain, every pixel's
    expected charges and its Monte Carlo per-pixel constants, so that frames (:meth:`render`) and
    the noise image (:meth:`predict`) of the same scene and operating point cost only the chain
    after the exposure. What a live view or a stream of training frames of a static scene needs."""

    chain: Chain
    sweep: Sweep  # one operating point per pixel, (rows, cols)
    prepared: Prepared  # charges (rows, cols, phases) and the frames' constants (pixels flattened)
    radial_true_m: Float[Array, "rows cols"]
    direction: Float[Array, "rows cols 3"]
    pattern: PixelPattern

    @property
    def shape(self) -> tuple[int, int]:
        return tuple(self.radial_true_m.shape)

    def render(self, key: PRNGKeyArray, frames: int = 1, *, keep_frames: int = 0, progress: bool = False) -> FrameResult:
        """``frames`` Monte Carlo frames (:func:`render_frame`, which is ``prepare_frame(...).render(...)``)."""
        check_counts(frames, keep_frames, math.prod(self.shape), self.chain.n_phases)
        if progress and not _jit.traced((self, key)):  # chunk by chunk from the host (tofjax.simulate's progress)
            step = frames_step(self.chain, _key_words_jit(key))
            sums, kept = drive_blocks(step, self.prepared.consts, math.prod(self.shape), frames, keep_frames,
                                      self.chain.n_phases, FRAME_CHUNK_ELEMENTS)
            return self._wrap(assemble_jit(self.chain, self.sweep, self.prepared, sums, kept, frames))
        return self._wrap(_render_prepared(self, key, frames, keep_frames, progress))

    def predict(self) -> FrameResult:
        """The analytic frame, the noise image (:func:`predict_frame`)."""
        return self._wrap(_predict_prepared(self.chain, self.sweep, self.prepared.charges))

    def noise_image(self) -> Float[Array, "rows cols"]:
        """Only the noise image: each pixel's analytic standard deviation of the radial distance, m
        (:attr:`FrameResult.depth_std_m` of :meth:`predict`), as a program that computes nothing
        else (about 4x faster than :meth:`predict` at 224 x 172, ``bench/bench_frame.py``)."""
        return _noise_image_prepared(self.chain, self.sweep, self.prepared.charges)

    def sample(self, key: PRNGKeyArray, frames: int = 1) -> NoisyFrames:
        """Only the frames: ``frames`` noisy frames' radial distance, amplitude and validity, without
        the per-pixel statistics of :meth:`render` (the frames :meth:`render` keeps for the same key)."""
        check_counts(frames, frames, math.prod(self.shape), self.chain.n_phases)
        return _sample_prepared(self.chain, self.prepared.consts, key, frames, self.shape)

    def _wrap(self, result: Result) -> FrameResult:
        # Outside the programs: the geometry and the pattern are passed on, not copied by a program.
        return FrameResult(result, self.radial_true_m, self.direction, self.pattern)


class NoisyFrames(eqx.Module):
    """Noisy frames (:meth:`PreparedFrame.sample`), ``(frames, rows, cols)``: ``radial_m`` (NaN
    where the pixel or the ADC saturated), ``amplitude_lsb``, ``valid``."""

    radial_m: Float[Array, "frames rows cols"]
    amplitude_lsb: Float[Array, "frames rows cols"]
    valid: Array


# Separate programs for the exposure, the frames' constants and the frames: in one, XLA on a CPU
# fuses a producer into each of its consumers and evaluates it several times (one frame of 224 x 172
# in one program: 32 ms). Under an outer jit they are traced into one program as usual.
_setup_jit = _jit.jit(_setup)
_key_words_jit = _jit.jit(key_words)

#: Phase images per chunk of a frame's Monte Carlo (``run_blocks``' ``elements``): a whole 640 x 480
#: frame of 4 phase images (1.2 M) is one block. On a CPU, XLA runs the loop over several blocks
#: (``lax.map``) 4-5x slower per pixel than one block (one 640 x 480 frame: 124 ms in 3 blocks of
#: the sweeps' 2^19, 27 ms in one), at no more peak memory (649 against 672 MB resident; a chunk's
#: float64 array is at most 16 MB). Sweeps keep ``CHUNK_ELEMENTS``.
FRAME_CHUNK_ELEMENTS = 1 << 21


@_jit.jit
def _frame_constants(chain, charges):
    n = math.prod(charges.a.shape[:-1])
    flat = jax.tree_util.tree_map(lambda x: x.reshape((n,) + x.shape[2:]), charges)
    return point_constants(chain, flat, jnp.arange(n, dtype=jnp.uint32), chain.limit.full_well_e.reshape(n))


def prepare_frame(params: Params, settings: FrameSettings, returns: Returns, pattern: PixelPattern | None = None, *,
                  smooth: Smooth | None = None) -> PreparedFrame:
    """Expose a scene once (arguments as :func:`predict_frame`): the :class:`PreparedFrame` renders
    frames and the noise image of that scene and operating point without exposing it again."""
    _check_frame(params, settings, returns)
    pattern, chain, sweep, charges, direction = _setup_jit(params, settings, returns, pattern, smooth)
    consts = _frame_constants(chain, charges)
    return PreparedFrame(chain, sweep, Prepared(charges, consts), returns.radial_m, direction, pattern)


@_jit.jit
def _render_prepared(frame: PreparedFrame, key, frames, keep_frames, progress) -> Result:
    chain, n = frame.chain, math.prod(frame.shape)
    sums, kept = run_blocks(frames_step(chain, key_words(key)), frame.prepared.consts, n, frames, keep_frames,
                            chain.n_phases, FRAME_CHUNK_ELEMENTS, progress=progress)
    return assemble(chain, frame.sweep, frame.prepared, sums, kept, frames)


@_jit.jit
def _predict_prepared(chain, sweep, charges) -> Result:
    return analytic(chain, sweep, moments(chain, sweep, charges))


@_jit.jit
def _noise_image_prepared(chain, sweep, charges) -> Array:
    return analytic(chain, sweep, moments(chain, sweep, charges)).depth_std_m


@_jit.jit
def _sample_prepared(chain, consts, key, frames, shape) -> NoisyFrames:
    # Frames first throughout (the frames :func:`run_blocks` keeps are points first): no transposes,
    # which cost more than the frames themselves (8 frames of 224 x 172: 19 of 35 ms). Chunks of
    # frames as in run_blocks, in a lax.map when there are several.
    n, words = math.prod(shape), key_words(key)
    chunk = equal_parts(frames, FRAME_CHUNK_ELEMENTS // (n * chain.n_phases))
    n_chunks = -(-frames // chunk)
    to_m = chain.unambiguity_range_m / (2.0 * jnp.pi)

    def one(first):
        f = draw_frames(chain, consts, words, first, chunk, frames_first=True)
        valid = ~f.pixel_saturated & ~f.adc_saturated
        return jnp.where(valid, jnp.mod(f.phase, 2.0 * jnp.pi) * to_m, jnp.nan), f.amplitude, valid

    if n_chunks == 1:
        out = one(jnp.uint32(0))
    else:
        out = jax.tree_util.tree_map(lambda x: x.reshape((n_chunks * chunk, n))[:frames],
                                     jax.lax.map(one, chunk * jnp.arange(n_chunks, dtype=jnp.uint32)))
    return NoisyFrames(*(x.reshape((frames, *shape)) for x in out))


def sample_frame(params: Params, settings: FrameSettings, returns: Returns, key: PRNGKeyArray, frames: int = 1, *,
                 pattern: PixelPattern | None = None, smooth: Smooth | None = None) -> NoisyFrames:
    """Only noisy frames of a scene, exposed in the same call: ``frames`` frames' radial distance,
    amplitude and validity, ``(frames, rows, cols)`` (:class:`NoisyFrames`), without the per-pixel
    statistics of :func:`render_frame`. What a simulated camera streams when its scene changes every
    frame (for a static scene, :func:`prepare_frame` once and its ``sample`` skip the exposure).
    Arguments as :func:`render_frame`; the frames are those ``prepare_frame(...).sample(key, frames)``
    returns (and :func:`render_frame` keeps) for the same key."""
    _check_frame(params, settings, returns)
    check_counts(frames, frames, math.prod(returns.shape), params.pixel.n_phases)
    _, chain, _, charges, _ = _setup_jit(params, settings, returns, pattern, smooth)
    if math.prod(returns.shape) * chain.n_phases <= FUSED_SAMPLE_ELEMENTS:
        return _sample_charges(chain, charges, key, frames, returns.shape)
    return _sample_prepared(chain, _frame_constants(chain, charges), key, frames, returns.shape)


#: Phase images up to which :func:`sample_frame` computes the frames' constants and the frames in one
#: program (XLA then leaves out the constants only the statistics use, the noise-free reference
#: phase and amplitude): 224 x 172 (1.5e5) took 2.9 ms that way against 4.3 ms as two programs. A
#: larger frame's constants are materialised by a program of their own first: in one program XLA
#: re-reads the charges transposed in every fusion that uses them, and 640 x 480 (1.2e6) took 56-65
#: ms against 30-34 ms as two.
FUSED_SAMPLE_ELEMENTS = 1 << 19


@_jit.jit
def _sample_charges(chain, charges, key, frames, shape) -> NoisyFrames:
    return _sample_prepared(chain, _frame_constants(chain, charges), key, frames, shape)


def render_frame(params: Params, settings: FrameSettings, returns: Returns, key: PRNGKeyArray, frames: int = 1, *,
                 keep_frames: int = 0, pattern: PixelPattern | None = None, smooth: Smooth | None = None,
                 progress: bool = False) -> FrameResult:
    """Monte Carlo frames of a scene: ``frames`` noisy frames of every pixel through the chain
    (:func:`tofjax.simulate` per pixel, the same random-number streams and chunking); the result
    holds their per-pixel statistics (mean and standard deviation of the distance, amplitude,
    valid fraction) and the first ``keep_frames`` frames whole (``FrameResult.frames_radial_m``).

    Arguments as :func:`predict_frame`, plus ``key`` (a ``jax.random`` key; the same key gives the
    same frames), ``frames`` and ``keep_frames`` (static) and ``progress``. Rendering the same
    scene again (another key, more frames): :func:`prepare_frame` once, then its ``render``.
    """
    _check_frame(params, settings, returns)
    check_counts(frames, keep_frames, math.prod(returns.shape), params.pixel.n_phases)
    return prepare_frame(params, settings, returns, pattern, smooth=smooth).render(
        key, frames, keep_frames=keep_frames, progress=progress)


def sharded_map(fn, batch, *, devices=None):
    """``fn`` over the leading axis of the pytree ``batch``, the batch split over JAX devices with
    ``jax.sharding`` (every CPU core, GPU or host process JAX sees; docs/model.md "Scaling out"):
    each device runs ``lax.map(fn, ...)`` over its share. The batch is padded to a multiple of the
    device count with copies of its last element, and the padding dropped from the result."""
    from jax.sharding import Mesh, PartitionSpec

    devices = jax.devices() if devices is None else list(devices)
    leaves = jax.tree_util.tree_leaves(batch)
    size = leaves[0].shape[0]
    count = len(devices)
    padded = -(-size // count) * count

    def pad(x):
        x = jnp.asarray(x)
        return jnp.concatenate([x, jnp.repeat(x[-1:], padded - size, axis=0)]) if padded > size else x

    mesh = Mesh(np.array(devices), ("batch",))
    spec = PartitionSpec("batch")
    mapped = jax.jit(jax.shard_map(lambda b: jax.lax.map(fn, b), mesh=mesh, in_specs=spec, out_specs=spec))
    out = mapped(jax.tree_util.tree_map(pad, batch))
    return jax.tree_util.tree_map(lambda x: x[:size], out)
