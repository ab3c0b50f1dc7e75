"""The camera as one object, and the two verbs that run it (docs/model.md, "One camera, two verbs").

:class:`Camera` holds everything that describes a camera: its parameters, its frame settings (the
array's optics and fixed-pattern sigmas), its modulation frequencies and how they are fused, an
optional camera sample (:class:`tofjax.PixelPattern`) and an optional smooth relaxation. The verbs
take a camera and a scene:

- :func:`predict` ``(camera, scene)``: the analytic path (expected values, propagated noise);
- :func:`simulate` ``(camera, scene, key, frames)``: Monte Carlo frames and their statistics.

A scene is a :class:`tofjax.Sweep` (operating points of the centre pixel: the pixel on the optical
axis, one return each), a :class:`tofjax.Returns` (every pixel of a frame and its returns), a
:class:`tofjax.scenes.SceneGeometry` (ray-cast into returns) or a depth map (an array of the frame's
shape, Z depth in metres). A camera with several frequencies fuses them (sweeps and frames).

What is prepared once is one explicit step: :meth:`Camera.expose` (a static scene exposed on the
camera: its ``predict``, ``render``, ``sample`` and ``noise_image`` cost only the chain after the
exposure) or :meth:`Camera.prepare` (the camera's own constants, for a stream of changing scenes:
its methods take the scene).

A :class:`tofjax.Params` in the camera's place is the camera of those parameters with the default
frame settings, for a sweep: ``tj.predict(params, sweep)`` is ``tj.predict(tj.Camera(params),
sweep)``; its ``smooth``, ``pattern`` and ``fixed_pattern`` keywords are the sweep's.
"""

from __future__ import annotations

import equinox as eqx
import jax
import numpy as np
from jaxtyping import PRNGKeyArray

from . import _jit
from ._framegeometry import FrameSettings, check_lens, depth_returns, scene_returns
from ._motion import MovingScene, moving_depth_returns, moving_returns, per_phase_returns
from ._params import Params
from ._pattern import PixelPattern
from ._precision import PRECISIONS, in_precision
from ._processing import check_processing
from ._returns import Returns
from ._scene import SceneGeometry
from ._schema import FUSIONS
from ._smooth import Smooth
from ._sweep import Sweep


def _frequencies(f) -> tuple[float, ...]:
    """The frequencies as a tuple of floats (any sequence or array of concrete numbers)."""
    return tuple(float(x) for x in np.atleast_1d(np.asarray(f, dtype=float))) if np.size(f) else ()


class Camera(eqx.Module):
    """One camera (module docstring).

    **Fields:** ``params`` (:class:`tofjax.Params`); ``settings`` (:class:`tofjax.FrameSettings`,
    the ``[frame]`` section); ``frequencies_hz`` (static: the modulation frequencies, the first
    being ``params``'; ``()``: ``params``' own one only); ``fusion`` (static: how several
    frequencies combine, ``illumination_waveform.frequency_fusion``); ``pattern`` (a camera sample
    for frames, or of one pixel, ``(1, 1)``, the swept pixel's own sample for sweeps; ``None``:
    every pixel the mean pixel); ``smooth`` (``None``: the hard limits and ADC; a
    :class:`tofjax.Smooth`: their differentiable relaxation, analytic path); ``precision`` (static:
    ``"float64"``, or ``"float32"`` for frames computed in float32, :meth:`astype`); ``processing``
    (the camera's own depth processing after the demodulation, an ordered tuple of
    :mod:`tofjax.processing` stages: its factory calibration, spatial and temporal filters and
    invalidation; ``()``: the sensor's raw reading).

    Build it from a configuration with :meth:`from_config`, or directly: ``tj.Camera(tj.Params())``.
    It is a pytree: ``jax.jit``, ``jax.vmap`` and ``jax.grad`` see its parameters as leaves.
    """

    params: Params = eqx.field(default_factory=Params)
    settings: FrameSettings = eqx.field(default_factory=FrameSettings)
    frequencies_hz: tuple[float, ...] = eqx.field(static=True, default=(), converter=_frequencies)
    fusion: str = eqx.field(static=True, default="inverse_variance")
    pattern: PixelPattern | None = None
    smooth: Smooth | None = None
    precision: str = eqx.field(static=True, default="float64")
    processing: tuple = ()

    def __check_init__(self):
        if self.precision not in PRECISIONS:
            raise ValueError(f"Camera: precision = {self.precision!r} is not allowed: expected one of "
                             + ", ".join(map(repr, PRECISIONS)))
        if not isinstance(self.params, Params):
            raise TypeError(f"Camera: params must be a tofjax.Params, got {type(self.params).__name__}")
        if not isinstance(self.settings, FrameSettings):
            raise TypeError(f"Camera: settings must be a tofjax.FrameSettings, got {type(self.settings).__name__}")
        if self.pattern is not None and not isinstance(self.pattern, PixelPattern):
            raise TypeError(f"Camera: pattern must be a tofjax.PixelPattern or None, got {type(self.pattern).__name__}")
        if self.fusion not in FUSIONS:
            raise ValueError(f"Camera: fusion = {self.fusion!r} is not allowed: expected one of "
                             + ", ".join(map(repr, FUSIONS)))
        check_lens(self.params, self.settings)
        check_processing(self.processing)
        f = self.frequencies_hz
        if f and (len(f) < 2 or len(set(f)) != len(f) or not all(x > 0 for x in f)):
            raise ValueError(f"Camera: frequencies_hz = {list(f)} must be empty (the parameters' one) or two or more "
                             "distinct frequencies > 0 Hz")

    @classmethod
    def from_config(cls, config, *, pattern: PixelPattern | None = None, smooth: Smooth | None = None) -> Camera:
        """The camera of a :class:`tofjax.Config` (its parameters, ``[frame]`` settings, frequencies
        and fusion, ``[processing]`` stages), with an optional camera sample and smooth relaxation."""
        freqs = tuple(float(f) for f in config.modulation_frequencies_hz)
        fusion = config.values["illumination_waveform"]["frequency_fusion"]
        return cls(config.params, config.frame, freqs if len(freqs) > 1 else (), fusion, pattern, smooth,
                   processing=config.processing)

    @_jit.method
    def astype(self, precision: str) -> Camera:
        """This camera with its frames computed in ``precision``: ``"float64"`` (the default) or
        ``"float32"`` (consumer GPUs run float64 at 1/32-1/64 of float32's speed). The parameters stay
        as they are; :meth:`prepare` and :meth:`expose` cast the prepared chain, the pixels' constants
        and every scene's returns, and the Monte Carlo draws in that precision. Frames only: a sweep
        runs in float64. The error against float64 is stated and tested in docs/model.md, "float32
        frames"."""
        return Camera(self.params, self.settings, self.frequencies_hz, self.fusion, self.pattern, self.smooth, precision,
                      self.processing)

    @property
    def multifrequency(self) -> bool:
        """Whether the camera fuses several modulation frequencies."""
        return len(self.frequencies_hz) > 1

    @_jit.method
    def returns(self, scene, *, reflectivity=0.9, radial: bool = False, sun_direction=None, bins: int = 32,
                velocity_m_per_s=None, substeps: int = 4) -> Returns:
        """A frame scene's :class:`tofjax.Returns`, every pixel's returns: as given; ray-cast from a
        :class:`tofjax.scenes.SceneGeometry` (the direct return of each sub-pixel ray and, for a
        scene with patches, its two-bounce light in ``bins`` returns; ``sun_direction``: the
        background light's direction); or a depth map's, ``(rows, cols)`` Z depth in metres (the
        radial distance with ``radial=True``) with a ``reflectivity`` map or number, one ray per
        pixel. A scene moving during the frame (:func:`tofjax.scenes.moving`), or a list of one
        :class:`Returns` per phase image of the frame (a renderer's; several frequencies: each
        frequency's phase images in turn), gives every phase image's own returns
        (:mod:`tofjax._motion`); so does a depth map with ``velocity_m_per_s`` (a number or a map: how
        fast each pixel's depth grows, in the map's own convention, Z or radial) over ``substeps``
        instants per phase image. Once per scene: the verbs call it for a scene that is not yet
        :class:`Returns`."""
        if isinstance(scene, Returns):
            return scene
        if isinstance(scene, MovingScene):
            return moving_returns(self, scene, sun_direction=sun_direction, bins=bins)
        if isinstance(scene, list | tuple):
            from ._timing import frame_phase_images

            n = frame_phase_images(self.params, self._n_frequencies)  # every frequency's, in turn
            if len(scene) != n:
                what = ("pixel.n_phases" if not self.multifrequency else
                        f"pixel.n_phases x {len(self.frequencies_hz)} frequencies, each frequency's in turn")
                raise ValueError(f"a scene given per phase image has {len(scene)} tofjax.Returns: the camera's frame has "
                                 f"{n} phase images ({what}), one Returns each")
            return per_phase_returns(scene)
        if isinstance(scene, SceneGeometry):
            return scene_returns(self.params, self.settings, scene, sun_direction=sun_direction, bins=bins)
        if isinstance(scene, jax.Array | np.ndarray):
            if velocity_m_per_s is not None:
                return moving_depth_returns(self, scene, reflectivity, radial, velocity_m_per_s, substeps)
            return depth_returns(self.params, self.settings, scene, reflectivity, radial=radial)
        raise TypeError(f"scene must be a tofjax.Sweep, tofjax.Returns, a tofjax.scenes.SceneGeometry, a moving one "
                        "(tofjax.scenes.moving), one tofjax.Returns per phase image (a list) or a depth map (an array "
                        f"of the frame's shape), got {type(scene).__name__}")

    @_jit.method
    def prepare(self):
        """The camera prepared for frames once: its frame chain, each pixel's conversion of radiance
        to electrons, dark electrons and ray (``tofjax._frame.PreparedCamera``). Its methods take a
        scene's :class:`tofjax.Returns` and cost only its exposure and the chain after it:
        ``predict(returns)``, ``render(returns, key, frames, keep_frames=, raw=, progress=)``,
        ``sample(returns, key, frames, raw=)`` (noisy frames only, :class:`tofjax.NoisyFrames`: what a
        simulated camera streams when its scene changes every frame), ``noise_image(returns)`` (each
        pixel's analytic distance noise only) and ``prepare(returns)`` (as :meth:`expose`). A camera
        of several frequencies: every frequency's frames, fused pixel by pixel and frame by frame
        (``tofjax._multiframe.MultiPreparedCamera``, the same methods)."""
        from ._frame import prepare_camera

        if self.multifrequency:  # every frequency's frames, fused (tofjax._multiframe)
            from ._multiframe import multi_prepare_camera

            prepared = multi_prepare_camera(self.params, self.settings, self.pattern, smooth=self.smooth,
                                            processing=self.processing, frequencies_hz=self.frequencies_hz,
                                            fusion=self.fusion)
        else:
            prepared = prepare_camera(self.params, self.settings, self.pattern, smooth=self.smooth,
                                      processing=self.processing)
        return prepared if self.precision == "float64" else in_precision(prepared, self.precision)

    @_jit.method
    def expose(self, scene):
        """A frame scene exposed once on this camera (``tofjax._frame.PreparedFrame``): its
        ``predict()``, ``render(key, frames, keep_frames=, raw=, progress=)``, ``sample(key, frames,
        raw=)`` and ``noise_image()`` then cost only the chain after the exposure."""
        return self.prepare().prepare(self.returns(scene))

    @property
    def _n_frequencies(self) -> int:
        """The modulation frequencies a frame takes: 1, or ``len(frequencies_hz)``."""
        return max(len(self.frequencies_hz), 1)

    @property
    def timing(self):
        """The frame's timing and the illumination's power over it (``tofjax._timing.FrameTiming``:
        phase images, exposure, frame rate, lit fraction, peak / lit / average power), at the
        parameters' integration time; ``[timing]`` configures it (docs/model.md, "Frame timing and
        eye safety"). A frame rate its phase images do not fit is a ``ValueError`` naming
        ``timing.frame_rate_hz`` (as the commands refuse it; under a transformation, where the values
        are traced, it is not checked)."""
        from ._timing import check_frame_rate, frame_timing

        timing = frame_timing(self.params, self._n_frequencies)
        if not _jit.traced(timing):
            check_frame_rate(timing)
        return timing

    @property
    def eye_safety(self):
        """An estimate of the illumination against IEC 60825-1:2014 class 1 (``tofjax._timing.EyeSafety``:
        the accessible emissions through 7 mm at 100 mm against their limits, ``.ratio`` the largest;
        an estimate, not a classification: docs/model.md, "Frame timing and eye safety")."""
        from ._timing import eye_safety

        return eye_safety(self.params, self.timing, self.settings.illumination_falloff_exponent)

    @_jit.method
    def _no_pattern(self, what: str) -> None:
        if self.pattern is not None:
            raise ValueError(f"{what} runs the mean pixel: this camera has a pattern (Camera.pattern), which it would "
                             "not honour; drop it, or sweep one frequency")

    @_jit.method
    def _double(self, what: str) -> None:
        if self.precision != "float64":
            raise ValueError(f"{what} runs in float64: this camera computes its frames in precision = "
                             f"{self.precision!r} (Camera.astype), which a sweep does not honour; use "
                             "camera.astype('float64')")


def predict(camera, scene, *, smooth: Smooth | None = None, pattern: PixelPattern | None = None):
    """The analytic path: expected values and standard deviations propagated through the chain.

    **Arguments:** ``camera`` (:class:`tofjax.Camera`), ``scene`` (a :class:`tofjax.Sweep`: a
    :class:`tofjax.Result`, or with several frequencies a :class:`tofjax.MultiFrequencyResult`; a
    frame's :class:`tofjax.Returns`, :class:`tofjax.scenes.SceneGeometry` or depth map: a
    :class:`tofjax.FrameResult`).

    ``camera`` may be a :class:`tofjax.Params` for a sweep (module docstring):
    ``predict(params, sweep, smooth=..., pattern=...)``.

    **Gradients.** In the hard mode (no ``camera.smooth``) a point where the pixel or the ADC
    saturates has NaN statistics (``depth_std_m``, ...) and their gradient is 0, not NaN: an
    optimiser that skips NaN values (``jnp.nansum``) gets no warning that it left the camera's range.
    Differentiate a camera with ``smooth=tj.Smooth()``, whose values and gradients are finite
    everywhere (docs/model.md, "Smooth relaxation"), or hold the points valid
    (``Result.valid_fraction``, ``full_well_fraction``).

    Example::

        camera = tj.Camera(tj.Params())
        r = tj.predict(camera, tj.Sweep.linspace("distance", 0.5, 5.0, 10))
        r.depth_std_m                                  # (10,) m
        tj.predict(camera, scenes.wall(1.2)).depth_std_m   # (rows, cols) m: a frame (within 1.87 m)
    """
    from ._analytic import predict as predict_sweep

    if isinstance(camera, Params):
        return predict_sweep(camera, scene, smooth=smooth, pattern=pattern)
    camera = _camera(camera, smooth, pattern)
    if isinstance(scene, Sweep):
        camera._double("a sweep")
        if camera.multifrequency:
            camera._no_pattern("a multi-frequency sweep")
            from ._multifrequency import predict_multifrequency

            return predict_multifrequency(camera.params, scene, camera.frequencies_hz, fusion=camera.fusion,
                                          smooth=camera.smooth, processing=camera.processing)
        return predict_sweep(camera.params, scene, smooth=camera.smooth, pattern=camera.pattern,
                             processing=camera.processing)
    return _said_if_no_good_pixels(camera.prepare().predict(camera.returns(scene)))


def simulate(camera, scene, key: PRNGKeyArray, frames: int = 2000, *, keep_frames: int = 0, raw: bool = False,
             progress: bool = False, smooth: Smooth | None = None, fixed_pattern: bool = False,
             pattern: PixelPattern | None = None):
    """Monte Carlo: ``frames`` noisy frames of every operating point or pixel, and their statistics.

    **Arguments:** ``camera`` (:class:`tofjax.Camera`), ``scene`` (as :func:`predict`), ``key`` (a
    ``jax.random`` key: the same key, the same frames), ``frames`` (static), ``keep_frames`` (frames
    returned whole, static), ``raw`` (the kept frames' raw phase images too, static; with several
    frequencies, each frequency's in ``per_frequency``),
    ``progress`` (report the chunks to :mod:`tofjax.progress`). Returns a :class:`tofjax.Result`,
    :class:`tofjax.MultiFrequencyResult` or :class:`tofjax.FrameResult`, as :func:`predict`.

    ``camera`` may be a :class:`tofjax.Params` for a sweep (module docstring):
    ``simulate(params, sweep, key, frames, smooth=..., fixed_pattern=..., pattern=...)``.

    Example::

        camera = tj.Camera(tj.Params())
        r = tj.simulate(camera, tj.Sweep("distance", [1.0, 2.0]), jax.random.key(0), 2000)
        r.depth_std_m                                  # (2,) m, over 2000 frames each
    """
    from ._montecarlo import simulate as simulate_sweep

    if isinstance(camera, Params):
        return simulate_sweep(camera, scene, key, frames, smooth=smooth, fixed_pattern=fixed_pattern, pattern=pattern,
                              keep_frames=keep_frames, raw=raw, progress=progress)
    camera = _camera(camera, smooth, pattern)
    if fixed_pattern:
        raise ValueError("simulate(camera, ...): fixed_pattern belongs to the earlier simulate(params, ...); a camera "
                         "carries its sample as Camera.pattern (frames)")
    if isinstance(scene, Sweep):
        camera._double("a sweep")
        from ._montecarlo import check_counts

        check_counts(frames, keep_frames, scene.samples, camera.params.pixel.n_phases, names=("frames", "keep_frames"),
                     raw=raw)
        if camera.multifrequency:
            camera._no_pattern("a multi-frequency sweep")
            from ._multifrequency import simulate_multifrequency

            return simulate_multifrequency(camera.params, scene, key, frames, camera.frequencies_hz,
                                           keep_frames=keep_frames, progress=progress, fusion=camera.fusion, raw=raw,
                                           processing=camera.processing)
        return simulate_sweep(camera.params, scene, key, frames, smooth=camera.smooth, pattern=camera.pattern,
                              keep_frames=keep_frames, raw=raw, progress=progress, processing=camera.processing)
    return _said_if_no_good_pixels(camera.expose(scene).render(key, frames, keep_frames=keep_frames, raw=raw,
                                                               progress=progress))


def _said_if_no_good_pixels(frame):
    """``frame`` (a :class:`tofjax.FrameResult`), with a :class:`tofjax.schema.NoGoodPixelsWarning`
    when none of its pixels is good: an all-flagged frame (a wall beyond the unambiguity range) reads
    plausible distances and gives an empty point cloud, and nothing else would say so. Concrete
    values only (under a transformation the flags are traced)."""
    if _jit.traced(frame):
        return frame
    from ._flags import NoGoodPixelsWarning, flag_fractions, no_good_pixels, no_good_pixels_line

    flags = np.asarray(frame.flags)
    if flags.size and no_good_pixels(flags):
        import warnings

        warnings.warn(no_good_pixels_line(flag_fractions(flags), float(frame.result.unambiguity_range_m)),
                      NoGoodPixelsWarning, stacklevel=3)
    return frame


def _camera(camera, smooth, pattern) -> Camera:
    if not isinstance(camera, Camera):
        raise TypeError(f"camera must be a tofjax.Camera (or, for the earlier sweep functions, a tofjax.Params), got "
                        f"{type(camera).__name__}")
    for name, value in (("smooth", smooth), ("pattern", pattern)):
        if value is not None:
            raise ValueError(f"{name} belongs to the camera: tj.Camera(..., {name}=...)")
    return camera
