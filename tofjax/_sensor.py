"""A ToF camera stepped by a robot simulator (issue 51; docs/simulators.md): :class:`ToFSensor` holds
what persists between steps (the prepared camera and its fixed pattern, the random key stream, the
clock and the resampling plans of the renderers' buffers) and turns one simulator frame, a depth
buffer with what else the renderer has, into one :class:`SensorFrame`, the camera's delivered depth
in the conventions of ROS REP 117 and 118.

One step is one compiled program (:func:`_step`), compiled once per shape of its inputs and choice of
options: the buffer's resampling onto the camera's rays (:mod:`tofjax._sensorbuffers`), the direct
returns of what each ray meets (:func:`tofjax._returns.direct_returns`, as ``camera.returns`` of a
depth map makes them), optionally their motion over the frame's phase images (:mod:`tofjax._motion`)
and two-bounce light from the buffers (:mod:`tofjax._buffermultipath`), then one noisy frame of the
camera's chain, its processing and its frequencies' fusion (the frame ``PreparedCamera.sample``
draws for the same key), the analytic noise its flags read, and the outputs.
"""

from __future__ import annotations

import dataclasses
import math

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array

from . import _jit
from ._analytic import analytic, moments
from ._flags import (CAMERA_FLAGS, FLAG_INVALIDATED, FLAG_LOW_AMPLITUDE, FLAG_LOW_SIGNAL, FLAG_SATURATED)
from ._frame import NoisyFrames, _bit, _point_charges, _sweep, scene_flags
from ._frames import draw_delivered
from ._framegeometry import _with_interference, frame_rays, frame_shape, intrinsics as camera_intrinsics
from ._motion import MAX_SUBSTEPS
from ._random import key_words
from ._returns import direct_returns
from ._scene import Surface, _facing, dot3
from ._sensorbuffers import (EDGE_FRACTION, PLANAR_TOLERANCE, buffer_intrinsics, continuity, depth_normals,
                             interpolated_inverse_depth, make_plan, planar_depth, same_camera)

#: A depth buffer's conventions (``depth_type``): the planar depth along the optical axis (``"z"`` is
#: :class:`tofjax.renderers.Render`'s name for it), or the distance along each pixel's ray.
DEPTH_TYPES = {"planar": False, "z": False, "radial": True}
#: The frames normals may be given in: tofjax's camera frame (x right, y up, z along the axis; a
#: :class:`tofjax.renderers.Render`'s) or the optical frame (x right, y down, z along the axis; OpenCV's, ROS REP 103's).
NORMAL_FRAMES = ("tofjax", "optical")
#: The nearest a surface may be, m (:data:`tofjax._framegeometry.DEPTH_RANGE_M`).
NEAREST_M = 1e-3


@dataclasses.dataclass(frozen=True, eq=False)
class SensorFrame:
    """One step's frame (:meth:`ToFSensor.step`), NumPy arrays ``(rows, cols)`` unless said.

    - ``depth_m`` float32: the planar depth along the optical axis (Z), m, the measured distance
      times its ray's z (ROS REP 118); NaN where the camera does not deliver the pixel (REP 117's
      "invalid": :attr:`delivered` false).
    - ``radial_m`` float32: the measured distance along the pixel's ray, m (what a ToF pixel measures,
      wrapped by the unambiguity range, fused for several frequencies); NaN where not delivered.
    - ``amplitude_lsb`` float32: the frame's measured amplitude (the first frequency's), every pixel.
    - ``confidence`` float32 in [0, 1]: 1 - sigma / sigma_max, sigma the pixel's expected phase noise
      (the analytic noise of its expected charges; the worst frequency's) and sigma_max the camera's
      low-signal threshold ``frame.max_phase_noise_rad``: 1 noise-free, 0 at the threshold, where
      the camera stops delivering; 0 where it does not deliver.
    - ``flags`` int32: tofjax's bits (:data:`tofjax.schema.FLAGS`), decided for this frame: saturated
      (this frame's pixel or ADC, any frequency), low signal and low amplitude (the expected noise
      and amplitude, as a frame's), invalidated (this frame's processing rejected it), and the
      truth's diagnostics (no return, wrapped, mixed, outside the illumination).
    - ``delivered`` bool: none of the camera's own flags (:data:`tofjax._flags.CAMERA_FLAGS`).
    - ``points_m`` ``(rows, cols, 3)`` float32: the organized point cloud in the optical frame (x
      right, y down, z along the axis: REP 103's ``*_optical_frame``, OpenCV's, the one
      :meth:`camera_info`'s K projects), m; NaN where not delivered.
    - ``true_radial_m`` float32: the truth, the distance along each centre ray to the surface it
      meets (inf: none), for training and evaluation; ``true_depth_m`` float32 the same as planar
      depth (Z, REP 118's convention; inf: none).
    - ``stamp_s``: the frame's time (the buffer's time; the middle of the exposure, where tofjax's
      motion places the scene as given); ``exposure_s``: (start, end) of its exposure; ``step``: its
      number (0, 1, ...).
    - ``codes``, ``tap_a_e``, ``tap_b_e``: with ``raw=True``, the frame's raw phase images
      ``(phases, rows, cols)`` (several frequencies: ``(frequencies, phases, rows, cols)``): the ADC
      codes of the taps' difference and each tap's electrons (docs/model.md, "Raw phase images");
      else ``None``.
    - ``intrinsics``: the camera's (:func:`tofjax.optics.intrinsics`); ``frame_id``: the sensor's.
    """

    depth_m: np.ndarray
    radial_m: np.ndarray
    amplitude_lsb: np.ndarray
    confidence: np.ndarray
    flags: np.ndarray
    delivered: np.ndarray
    points_m: np.ndarray
    true_radial_m: np.ndarray
    true_depth_m: np.ndarray
    stamp_s: float
    exposure_s: tuple[float, float]
    step: int
    intrinsics: dict
    frame_id: str
    codes: np.ndarray | None = None
    tap_a_e: np.ndarray | None = None
    tap_b_e: np.ndarray | None = None

    def image(self, what: str = "depth", encoding: str | None = None, *, ros_version: int = 2) -> dict:
        """A sensor_msgs/Image's fields of ``what``: ``"depth"`` (``"32FC1"`` metres, NaN invalid, the
        default; ``"16UC1"`` millimetres, 0 invalid), ``"amplitude"`` (``"32FC1"``), ``"confidence"``
        (``"32FC1"``) or ``"flags"`` (``"8UC1"``) (:func:`tofjax._rosmsg.image`)."""
        from ._rosmsg import image

        arrays = {"depth": (self.depth_m, "32FC1"), "amplitude": (self.amplitude_lsb, "32FC1"),
                  "confidence": (self.confidence, "32FC1"), "flags": (self.flags, "8UC1"),
                  "radial": (self.radial_m, "32FC1")}
        if what not in arrays:
            raise ValueError(f"what = {what!r}: allowed {', '.join(map(repr, arrays))}")
        array, default = arrays[what]
        return image(array, encoding or default, stamp_s=self.stamp_s, frame_id=self.frame_id,
                     ros_version=ros_version)

    def camera_info(self, *, ros_version: int = 2) -> dict:
        """A sensor_msgs/CameraInfo's fields (:func:`tofjax._rosmsg.camera_info`)."""
        from ._rosmsg import camera_info

        return camera_info(self.intrinsics, stamp_s=self.stamp_s, frame_id=self.frame_id, ros_version=ros_version)

    def pointcloud2(self, *, intensity: bool = True, ros_version: int = 2) -> dict:
        """A sensor_msgs/PointCloud2's fields: the organized cloud, x, y, z float32 (and the
        amplitude as ``intensity``) (:func:`tofjax._rosmsg.pointcloud2`)."""
        from ._rosmsg import pointcloud2

        return pointcloud2(self.points_m, self.amplitude_lsb if intensity else None, stamp_s=self.stamp_s,
                           frame_id=self.frame_id, ros_version=ros_version)


class ToFSensor:
    """A ToF camera in a robot simulator's loop (module docstring; docs/simulators.md).

    **Arguments:** ``camera`` (a :class:`tofjax.Camera`: any preset, several frequencies and
    processing stages included); ``seed`` (the sensor's randomness: its fixed pattern, drawn once,
    and its frames' key stream; the same seed, the same frames); ``fixed_pattern`` (draw the camera's
    pixel-to-pixel sample from the seed with ``tj.draw_pattern``; ``False``: every pixel the mean
    pixel; a camera that carries its own ``pattern`` keeps it); ``subpixel_samples`` (rays per pixel
    and axis that read the buffer: 1, or the camera's ``frame.subpixel_samples`` for flying pixels at
    depth edges, at s^2 returns per pixel); ``reflectivity`` (each surface's near-infrared
    Lambertian reflectivity where a step gives none); ``max_range_m`` (a buffer value beyond it is
    no surface: a renderer's far plane); ``edge_fraction``, ``planar_tolerance`` (the resampling's
    depth-edge tests, :mod:`tofjax._sensorbuffers`); ``multipath_patches`` (about how many patches
    the buffer is cut into for two-bounce light), ``multipath_bins`` (its returns per pixel);
    ``substeps`` (instants per phase image of a moving depth); ``max_depth_change`` (a pixel whose
    depth changes by more than this fraction since ``previous_depth`` saw another surface, not a
    moving one: no velocity); ``start_time_s`` (the first frame's stamp without ``time_s``);
    ``frame_id`` (the messages' frame, an optical frame).
    """

    def __init__(self, camera, *, seed: int = 0, fixed_pattern: bool = True, subpixel_samples: int = 1,
                 reflectivity: float = 0.9, max_range_m: float = 1e3, edge_fraction: float = EDGE_FRACTION,
                 planar_tolerance: float = PLANAR_TOLERANCE, multipath_patches: int = 128, multipath_bins: int = 8,
                 substeps: int = 4, max_depth_change: float = 0.1, start_time_s: float = 0.0,
                 frame_id: str = "tof_optical_frame"):
        from ._camera import Camera
        from ._motion import MovingScene
        from ._pattern import draw_pattern

        if not isinstance(camera, Camera):
            raise TypeError(f"ToFSensor: camera must be a tofjax.Camera, got {type(camera).__name__}")
        if isinstance(seed, bool) or not isinstance(seed, int | np.integer) or not 0 <= seed < 2**32:
            raise ValueError(f"ToFSensor: seed = {seed!r}: allowed an integer 0 <= seed < 2^32")
        for name, value, lo, hi in (("subpixel_samples", subpixel_samples, 1, 8),
                                    ("multipath_patches", multipath_patches, 1, 4096),
                                    ("multipath_bins", multipath_bins, 1, 64)):
            if isinstance(value, bool) or not isinstance(value, int | np.integer) or not lo <= value <= hi:
                raise ValueError(f"ToFSensor: {name} = {value!r}: allowed an integer {lo} <= value <= {hi}")
        MovingScene.check_substeps(substeps, "ToFSensor")
        for name, value, lo, hi in (("reflectivity", reflectivity, 0.0, 1.0), ("max_range_m", max_range_m, 1e-3, 1e3),
                                    ("edge_fraction", edge_fraction, 0.0, 1.0),
                                    ("planar_tolerance", planar_tolerance, 0.0, 1.0),
                                    ("max_depth_change", max_depth_change, 0.0, 10.0)):
            if not (isinstance(value, int | float | np.floating | np.integer) and lo <= float(value) <= hi):
                raise ValueError(f"ToFSensor: {name} = {value!r}: allowed a number {lo} <= value <= {hi}")
        self.seed = int(seed)
        root = jax.random.key(self.seed)
        pattern_key, self._stream = jax.random.split(root)
        shape = frame_shape(camera.params)
        if camera.pattern is None and fixed_pattern:
            camera = eqx.tree_at(lambda c: c.pattern, camera, draw_pattern(camera.params, camera.settings, shape,
                                                                            pattern_key),
                                 is_leaf=lambda x: x is None)
        #: The camera, with the sensor's fixed pattern (``camera.pattern``).
        self.camera = camera
        #: The camera prepared once (its chain, pattern, rays): every step reuses it.
        self.prepared = camera.prepare()
        self.shape = shape
        self.intrinsics = camera_intrinsics(camera.params, camera.settings)
        self.timing = camera.timing
        self.frame_period_s = float(self.timing.frame_time_s)
        self.subpixel_samples = int(subpixel_samples)
        self.rays = frame_rays(camera.params, camera.settings, self.subpixel_samples)
        centre = np.asarray(self.rays.centre)
        self._directions = (centre[:, :, None, :] if self.subpixel_samples == 1 else
                            np.concatenate([centre[:, :, None, :], np.asarray(self.rays.samples)], axis=2))
        self.options = {"reflectivity": float(reflectivity), "max_range_m": float(max_range_m),
                        "edge_fraction": float(edge_fraction), "planar_tolerance": float(planar_tolerance),
                        "multipath_patches": int(multipath_patches), "multipath_bins": int(multipath_bins),
                        "substeps": int(substeps), "max_depth_change": float(max_depth_change),
                        "frequencies": camera._n_frequencies}
        self.start_time_s = float(start_time_s)
        self.frame_id = str(frame_id)
        self.steps = 0
        self.last_stamp_s: float | None = None
        self._plans: dict = {}

    @property
    def pattern(self):
        """The sensor's fixed pattern (:class:`tofjax.PixelPattern`; ``None``: the mean pixel)."""
        return self.camera.pattern

    def key(self, step: int):
        """The random key of frame ``step``: the seed's stream folded with the step's number."""
        return jax.random.fold_in(self._stream, step)

    def plan(self, intrinsics: dict):
        """The resampling plan of a buffer of ``intrinsics`` (:func:`tofjax._sensorbuffers.buffer_intrinsics`),
        made once per buffer camera."""
        key = (intrinsics["width"], intrinsics["height"], intrinsics["fx"], intrinsics["fy"], intrinsics["cx"],
               intrinsics["cy"], tuple(intrinsics["dist_coeffs"]))
        plan = self._plans.get(key)
        if plan is None:
            buffer = dict(intrinsics)
            if same_camera(buffer, self.intrinsics):  # read pixel for pixel: the camera's own numbers
                buffer.update({k: self.intrinsics[k] for k in ("fx", "fy", "cx", "cy", "dist_coeffs")})
            plan = self._plans[key] = make_plan(self._directions, buffer)
        return plan

    def instants_s(self, substeps: int = 1) -> np.ndarray:
        """The times, s from a frame's stamp, at which to render a stack of buffers for one step
        (``step(depth=stack)``, ``stack[i]`` the scene at ``instants_s(substeps)[i]``): the centres of
        ``substeps`` equal slices of each of the frame's phase images (tofjax's motion model,
        docs/model.md "A camera in time: motion"; a camera of several frequencies: each frequency's
        phase images in turn, every one at its own time), N x ``substeps`` times in order (N the
        frame's phase images, ``camera.timing.phase_images``). Each instant is
        exposed to its own buffer: what moves across the image during the frame (a moving edge)
        is seen where it stands at each phase image."""
        from ._motion import instants_s

        from ._motion import MovingScene

        MovingScene.check_substeps(substeps, "ToFSensor.instants_s")
        t = self.timing
        return np.asarray(instants_s(t.phase_images, t.phase_image_time_s, t.readout_time_s,
                                     int(substeps))).reshape(-1)

    def step(self, depth, *, intrinsics=None, fov_deg=None, depth_type: str = "planar", normals=None,
             normals_frame: str = "tofjax", reflectivity=None, segmentation=None, reflectivity_table=None,
             velocity_m_per_s=None, previous_depth=None, time_s: float | None = None, raw: bool = False,
             multipath: bool = False) -> SensorFrame:
        """One frame of one simulator step (docs/simulators.md).

        - ``depth`` ``(rows, cols)``, any float dtype, metres: the renderer's depth buffer, planar
          (Z, ``depth_type="planar"`` or ``"z"``) or ``"radial"`` (along each buffer pixel's ray);
          NaN, inf, values <= 0 and values beyond ``max_range_m``: no surface.
        - ``intrinsics`` / ``fov_deg``: the buffer's camera (:func:`tofjax._sensorbuffers.buffer_intrinsics`);
          neither: the ToF camera's own, so ``depth`` must be at its resolution. A buffer of other
          intrinsics or resolution is resampled onto the camera's rays (:mod:`tofjax._sensorbuffers`).
        - ``normals`` ``(rows, cols, 3)``: the buffer's unit surface normals in ``normals_frame``
          (``"tofjax"``: x right, y up, z along the axis, a :class:`tofjax.renderers.Render`'s;
          ``"optical"``: y down); ``None``: from the depth's derivatives.
        - ``reflectivity``: a number or a ``(rows, cols)`` image of near-infrared Lambertian
          reflectivity in [0, 1]; or ``segmentation`` ``(rows, cols)`` integer ids with
          ``reflectivity_table`` {id: reflectivity} (other ids: ``reflectivity`` if a number, else the
          sensor's). A segmentation also keeps the resampling from interpolating across objects.
        - ``velocity_m_per_s``: how fast each pixel's depth grows (a number or a ``(rows, cols)`` map,
          in ``depth_type``'s convention), or ``previous_depth`` (the previous step's buffer, the same
          camera): the depth then moves over the frame's phase images (docs/model.md, "A camera in
          time: motion"); the velocity from ``previous_depth`` is its change over the time since the
          previous step (``time_s`` minus its stamp, else the camera's frame period), 0 where either
          holds no surface or the depth changed by more than ``max_depth_change`` of itself. Or a
          *stack* of buffers, ``depth`` ``(instants, rows, cols)`` (and ``normals``, ``segmentation``,
          a ``reflectivity`` image likewise): the scene rendered at each of :meth:`instants_s`'
          times, each instant of the exposure seeing its own buffer, so that what moves across the
          image (an edge, an arm swinging by) is exposed where it stands at each phase image; the
          truth and the two-bounce light are the buffer's nearest the stamp.
        - ``time_s``: the buffer's time (the frame's stamp); ``None``: ``start_time_s`` plus the step's
          number of frame periods (``camera.timing``).
        - ``raw``: also the raw phase images; ``multipath``: add two-bounce light computed from the
          buffers (:mod:`tofjax._buffermultipath`).

        Returns a :class:`SensorFrame`. Every call with the same shapes and options runs one compiled
        program (the first compiles it).
        """
        stamp = self.start_time_s + self.steps * self.frame_period_s if time_s is None else float(time_s)
        if not math.isfinite(stamp):
            raise ValueError(f"time_s = {time_s!r}: allowed a finite time in seconds")
        scene = self._inputs(depth, intrinsics, fov_deg, depth_type, normals, normals_frame, reflectivity, segmentation,
                             reflectivity_table, velocity_m_per_s, previous_depth, time_s, stamp, multipath)
        out = _step(self.prepared, *scene, self._stream, np.asarray(self.steps, dtype=np.uint32), bool(raw), self.shape)
        out = jax.tree_util.tree_map(np.asarray, out)
        half = 0.5 * float(self.timing.exposure_time_s)
        frame = SensorFrame(out["depth_m"], out["radial_m"], out["amplitude_lsb"], out["confidence"], out["flags"],
                            out["delivered"], out["points_m"], out["true_radial_m"], out["true_depth_m"], stamp,
                            (stamp - half, stamp + half),
                            self.steps, self.intrinsics, self.frame_id, out.get("codes"), out.get("tap_a_e"),
                            out.get("tap_b_e"))
        self.steps += 1
        self.last_stamp_s = stamp
        return frame

    def returns(self, depth, *, intrinsics=None, fov_deg=None, depth_type: str = "planar", normals=None,
                normals_frame: str = "tofjax", reflectivity=None, segmentation=None, reflectivity_table=None,
                velocity_m_per_s=None, previous_depth=None, time_s: float | None = None, multipath: bool = False):
        """The :class:`tofjax.Returns` a step of these arguments exposes the camera to (:meth:`step`'s
        scene without its frame; the sensor's clock does not advance): for tofjax's other tools
        (``tj.predict(sensor.camera, returns)``, ``tj.simulate``)."""
        stamp = self.start_time_s + self.steps * self.frame_period_s if time_s is None else float(time_s)
        scene = self._inputs(depth, intrinsics, fov_deg, depth_type, normals, normals_frame, reflectivity, segmentation,
                             reflectivity_table, velocity_m_per_s, previous_depth, time_s, stamp, multipath)
        return _returns(_first(self.prepared), *scene)

    def _inputs(self, depth, intrinsics, fov_deg, depth_type, normals, normals_frame, reflectivity, segmentation,
                reflectivity_table, velocity_m_per_s, previous_depth, time_s, stamp, multipath) -> tuple:
        """A step's arguments checked and as the program takes them (:func:`_scene`'s after the camera)."""
        depth = _float_image(depth, "depth", stack=True)
        instants = None
        if depth.ndim == 3:  # one buffer per instant of the frame's exposure (instants_s)
            n = self.timing.phase_images  # every frequency's
            k = depth.shape[0]
            if k % n or not 1 <= k // n <= MAX_SUBSTEPS:
                raise ValueError(f"depth has shape {depth.shape}: a stack of buffers holds one per instant of "
                                 f"sensor.instants_s(substeps), n x substeps = {n}, {2 * n}, ..., {MAX_SUBSTEPS * n} "
                                 "(the frame's phase images, every frequency's, times its instants in each)")
            if velocity_m_per_s is not None or previous_depth is not None:
                raise ValueError("a stack of buffers (one per instant) is the motion: give no velocity_m_per_s or "
                                 "previous_depth with it")
            instants = k // n
        if depth_type not in DEPTH_TYPES:
            raise ValueError(f"depth_type = {depth_type!r}: allowed {', '.join(map(repr, DEPTH_TYPES))}")
        radial = DEPTH_TYPES[depth_type]
        near = (depth > 0.0) & (depth < NEAREST_M)
        if np.any(near):
            i = np.unravel_index(int(np.argmax(near)), depth.shape)
            raise ValueError(f"depth[{', '.join(map(str, i))}] = {float(depth[i])!r} m is nearer than {NEAREST_M} m: allowed a surface "
                             "at 1 mm or more, or NaN, inf, 0 for no surface (metres, not millimetres)")
        buffer = buffer_intrinsics(depth.shape[-2:], self.intrinsics, intrinsics, fov_deg)
        plan = self.plan(buffer)
        opts = self.options
        if normals_frame not in NORMAL_FRAMES:
            raise ValueError(f"normals_frame = {normals_frame!r}: allowed {', '.join(map(repr, NORMAL_FRAMES))}")
        if normals is not None:
            normals = _float_image(normals, "normals", depth.shape + (3,))
            if normals_frame == "optical":
                normals = normals * np.array([1.0, -1.0, 1.0])
        seg = None
        if segmentation is not None:
            seg = np.asarray(segmentation)
            if seg.shape != depth.shape or not np.issubdtype(seg.dtype, np.integer):
                raise ValueError(f"segmentation has shape {seg.shape} and dtype {seg.dtype}: allowed integer ids of the "
                                 f"depth's shape {depth.shape}")
        rho = _reflectivity(reflectivity, seg, reflectivity_table, opts["reflectivity"], depth.shape)
        if seg is not None:
            seg = seg.astype(np.int64)
        velocity = None
        if velocity_m_per_s is not None and previous_depth is not None:
            raise ValueError("give velocity_m_per_s or previous_depth, not both")
        if velocity_m_per_s is not None:
            velocity = np.asarray(velocity_m_per_s, dtype=float)
            if velocity.shape not in ((), depth.shape) or not np.all(np.isfinite(velocity)) \
                    or np.any(np.abs(velocity) > 1e4):
                raise ValueError(f"velocity_m_per_s has shape {velocity.shape}: allowed a finite number or map of the "
                                 f"depth's shape {depth.shape}, |v| <= 1e4 m/s")
            motion = ("velocity", velocity)
        elif instants is not None:
            motion = ("instants", instants)
        elif previous_depth is not None:
            previous = _float_image(previous_depth, "previous_depth", depth.shape)
            dt = stamp - self.last_stamp_s if (time_s is not None and self.last_stamp_s is not None) \
                else self.frame_period_s
            if not dt > 0.0:
                raise ValueError(f"previous_depth: the time since the previous step is {dt} s: allowed > 0 (time_s "
                                 "must grow)")
            motion = ("previous", (previous, np.asarray(dt)))
        else:
            motion = None
        return (plan, self.rays, jnp.asarray(depth), radial, None if normals is None else jnp.asarray(normals),
                jnp.asarray(rho), None if seg is None else jnp.asarray(seg), motion, bool(multipath),
                tuple(sorted(opts.items())))

    def camera_info(self, *, stamp_s: float = 0.0, ros_version: int = 2) -> dict:
        """The camera's sensor_msgs/CameraInfo fields (:func:`tofjax._rosmsg.camera_info`)."""
        from ._rosmsg import camera_info

        return camera_info(self.intrinsics, stamp_s=stamp_s, frame_id=self.frame_id, ros_version=ros_version)


def _float_image(x, what: str, shape: tuple | None = None, stack: bool = False) -> np.ndarray:
    """``x`` as a float64 array of ``shape`` (``None``: ``(rows, cols)``, or with ``stack`` also
    ``(instants, rows, cols)``); ``ValueError`` naming ``what`` otherwise."""
    a = np.asarray(x)
    if not np.issubdtype(a.dtype, np.floating):
        raise ValueError(f"{what} has dtype {a.dtype}: allowed a float array in metres (a depth in millimetres: divide "
                         "by 1000)" if what.endswith("depth") else f"{what} has dtype {a.dtype}: allowed a float array")
    allowed = (2, 3) if stack else (2,)
    if shape is None and a.ndim not in allowed or shape is not None and a.shape != shape:
        wanted = shape if shape else "(rows, cols)" + (" or (instants, rows, cols)" if stack else "")
        raise ValueError(f"{what} has shape {a.shape}: allowed {wanted}")
    return a.astype(np.float64, copy=False)


def _reflectivity(reflectivity, seg, table, default: float, shape) -> np.ndarray:
    """Each buffer pixel's reflectivity, or one number (a 0-d array: one compiled program for any)."""
    number = default if reflectivity is None or np.ndim(reflectivity) else float(reflectivity)
    if reflectivity is not None and np.ndim(reflectivity):
        rho = _float_image(reflectivity, "reflectivity", shape)
        if table is not None:
            raise ValueError("give a reflectivity image or a reflectivity_table, not both")
    elif table is not None:
        if seg is None:
            raise ValueError("reflectivity_table needs segmentation (the ids it maps)")
        keys = np.array(sorted(table), dtype=np.int64)
        values = np.array([float(table[k]) for k in keys])
        rho = np.full(shape, number)
        if keys.size:
            i = np.clip(np.searchsorted(keys, seg), 0, keys.size - 1)
            rho = np.where(keys[i] == seg, values[i], number)
    else:
        rho = np.asarray(number, dtype=np.float64)
    bad = ~((rho >= 0.0) & (rho <= 1.0))
    if np.any(bad):
        raise ValueError(f"reflectivity: {float(np.asarray(rho)[bad].ravel()[0])!r} is out of range: allowed 0 to 1")
    return rho


def _first(prepared):
    """The single-frequency camera (the first frequency's of several)."""
    return prepared._first if hasattr(prepared, "cameras") else prepared


def _buffer(plan, depth, radial, normals, reflectivity, segmentation, opts) -> tuple:
    """One buffer onto the camera's rays: the :class:`tofjax._scene.Surface` its rays meet (sub-pixel
    rays, centre ray), and the buffer's own points, normals, reflectivity, surface mask and planar
    depth."""
    z, surface = planar_depth(depth, radial, plan.buffer_ray_z, opts["max_range_m"])
    w = jnp.where(surface, 1.0 / z, 0.0)
    along_rows, along_cols = continuity(w, surface, segmentation, opts["edge_fraction"], opts["planar_tolerance"])
    points = (z / plan.buffer_ray_z)[..., None] * plan.buffer_rays
    if normals is None:
        n_buffer = depth_normals(points, along_rows, along_cols, plan.buffer_rays)
    else:
        length = jnp.sqrt(dot3(normals, normals))
        ok = surface & jnp.isfinite(length) & (length > 0.0)
        n_buffer = _facing(jnp.where(ok[..., None], normals / jnp.where(ok, length, 1.0)[..., None],
                                     -plan.buffer_rays), plan.buffer_rays)
    rho_buffer = jnp.broadcast_to(reflectivity, depth.shape)
    # Every camera ray (centre first, then the sub-pixel rays): what it meets.
    w_ray, hit = interpolated_inverse_depth(plan, w, surface, along_rows, along_cols)
    t = jnp.where(hit, 1.0 / jnp.where(hit, w_ray, 1.0) / plan.ray_z, jnp.inf)
    n_ray = plan.at_rays(n_buffer)
    rho_ray = plan.at_rays(rho_buffer)
    sub = slice(0, 1) if t.shape[-1] == 1 else slice(1, None)
    surf = Surface(t[..., sub], n_ray[..., sub, :], rho_ray[..., sub], jnp.ones_like(t[..., sub]), t[..., 0],
                   n_ray[..., 0, :], rho_ray[..., 0])
    return surf, points, n_buffer, rho_buffer, surface, z


def _scene(camera, plan, rays, depth, radial, normals, reflectivity, segmentation, motion, multipath, options):
    """The returns of a step's buffers on ``camera`` (a single frequency's prepared camera): the
    buffer onto the rays, their direct returns, their motion, two-bounce light (module docstring).
    A stack of buffers (``motion = ("instants", m)``): each of the frame's n x m instants exposed to
    its own buffer (:meth:`ToFSensor.instants_s`), the truth and the two-bounce light the buffer's
    nearest the frame's centre time."""
    opts = dict(options)
    params, settings = camera.chain.params, camera.settings
    fe, baseline = settings.illumination_falloff_exponent, settings.baseline_m

    def direct(surf):
        return _with_interference(params, settings, surf, rays, direct_returns(params.illumination, fe, baseline, surf,
                                                                               rays))

    if motion is not None and motion[0] == "instants":
        from ._motion import _stacked
        from ._timing import frame_phase_images

        def one(i):
            pick = (lambda x: None if x is None else x[i])  # noqa: E731
            rho = reflectivity if reflectivity.ndim < depth.ndim else reflectivity[i]
            return _buffer(plan, depth[i], radial, pick(normals), rho, pick(segmentation), opts)

        k = depth.shape[0]
        parts = jax.vmap(one)(jnp.arange(k))
        n_images = frame_phase_images(params, opts["frequencies"])
        centre = _centre_instant(n_images, motion[1])
        surf, points, n_buffer, rho_buffer, surface, z = jax.tree_util.tree_map(lambda x: x[centre], parts)
        static = direct(surf)
        returns = _stacked(jax.vmap(direct)(parts[0]), n_images, motion[1], static)
        shape = depth.shape[1:]
    else:
        surf, points, n_buffer, rho_buffer, surface, z = _buffer(plan, depth, radial, normals, reflectivity,
                                                                 segmentation, opts)
        static = direct(surf)
        returns = static
        if motion is not None:
            returns = _moving(params, settings, rays, surf, static, motion, radial, plan, z, surface, opts)
        shape = depth.shape
    if multipath:
        from ._buffermultipath import buffer_patches, patch_grid, two_bounce

        patches = buffer_patches(points, n_buffer, rho_buffer, surface, plan.buffer_rays, plan.solid_angle_sr,
                                 patch_grid(opts["multipath_patches"], shape))
        returns = returns + two_bounce(params.illumination, fe, baseline, patches, surf.centre_t_m,
                                       surf.centre_normal, surf.centre_reflectivity, rays.centre,
                                       opts["multipath_bins"])
    return returns


def _centre_instant(n_images: int, substeps: int) -> int:
    """The index of the instant nearest the frame's centre time of the ``n_images`` x ``substeps``
    instants (:func:`tofjax._motion.instants_s`; of two equally near, the earlier): by symmetry,
    n x substeps // 2 - 1 for an even count, the middle for an odd one."""
    count = n_images * substeps
    return count // 2 - (1 - count % 2)


_returns = _jit.jit(_scene)


@_jit.jit
def _step(prepared, plan, rays, depth, radial, normals, reflectivity, segmentation, motion, multipath, options, stream,
          step, raw, shape) -> dict:
    """One step (module docstring): the buffer's returns, one frame of them and its outputs."""
    returns = _scene(_first(prepared), plan, rays, depth, radial, normals, reflectivity, segmentation, motion,
                     multipath, options)
    frame = _frame(prepared, returns, jax.random.fold_in(stream, step), raw, shape)
    return _outputs(frame, returns, rays)


def _moving(params, settings, rays, surf, static, motion, radial, plan, z, surface, opts):
    """The returns of the rays' depths moving over the frame's phase images (tofjax's motion model,
    :func:`tofjax._motion._over_instants`): each ray's distance grows at its rate (from the buffer's
    velocity or its change since the previous step), the normals as they are."""
    from ._motion import _over_instants
    from ._timing import frame_timing

    kind, value = motion
    if kind == "velocity":
        v = value
        vz = v * plan.buffer_ray_z if radial else v  # the planar depth's rate
        vz = jnp.broadcast_to(vz, z.shape)
    else:
        previous, dt = value
        zp, surface_p = planar_depth(previous, radial, plan.buffer_ray_z, opts["max_range_m"])
        same = surface & surface_p & (jnp.abs(z - zp) <= opts["max_depth_change"] * z)
        vz = jnp.where(same, (z - zp) / dt, 0.0)
    rate = plan.at_rays(vz) / plan.ray_z  # along each camera ray
    sub = slice(0, 1) if rate.shape[-1] == 1 else slice(1, None)
    rate_sub, rate_centre = rate[..., sub], rate[..., 0]
    fe, baseline = settings.illumination_falloff_exponent, settings.baseline_m

    def at(tt):
        moved = Surface(jnp.maximum(surf.t_m + rate_sub * tt, NEAREST_M), surf.normal, surf.reflectivity, surf.ambient,
                        surf.centre_t_m + rate_centre * tt, surf.centre_normal, surf.centre_reflectivity)
        return _with_interference(params, settings, moved, rays, direct_returns(params.illumination, fe, baseline,
                                                                                moved, rays))

    return _over_instants(frame_timing(params, opts["frequencies"]), opts["substeps"], static, at)


class _Frame(eqx.Module):
    radial_m: Array
    amplitude_lsb: Array
    valid: Array
    saturated: Array
    phase_std_rad: Array
    expected_amplitude_lsb: Array
    scene_flags: Array
    max_phase_noise_rad: Array
    min_amplitude_lsb: Array
    codes: Array | None
    tap_a_e: Array | None
    tap_b_e: Array | None


def _draw(chain, exposure, key, stream, raw, shape):
    """Frame 0 of ``key`` (the frame ``PreparedCamera.sample(returns, key)`` draws) and its saturation."""
    f = draw_delivered(chain, _point_charges(chain, exposure), key_words(key), jnp.uint32(0), 1, stream,
                       frames_first=True, taps=raw, image=shape)
    to_m = chain.unambiguity_range_m / (2.0 * jnp.pi)
    radial = jnp.where(f.valid, jnp.mod(f.phase, 2.0 * jnp.pi) * to_m, jnp.nan)[0].reshape(shape)
    saturated = (f.pixel_saturated[0] | f.adc_saturated[0]).reshape(shape)
    image = (lambda x: x[:, 0].reshape((x.shape[0], *shape))) if raw else (lambda x: None)  # noqa: E731
    return (radial, f.amplitude[0].reshape(shape), f.valid[0].reshape(shape), saturated, image(f.codes),
            image(f.tap_a_e), image(f.tap_b_e))


def _expected(chain, radial_true, exposure):
    """The analytic frame of the expected charges (what a frame's flags read)."""
    sweep = _sweep(chain.params, radial_true)
    return analytic(chain, sweep, moments(chain, sweep, exposure.charges(), image=True))


def _frame(prepared, returns, key, raw, shape) -> _Frame:
    """One noisy frame of ``returns``: the single frequency's, or every frequency's fused as
    :meth:`tofjax._multiframe.MultiPreparedCamera.sample` fuses them."""
    first = _first(prepared)
    returns = first._check(returns)
    settings = first.settings
    if not hasattr(prepared, "cameras"):
        exposure = prepared.expose(returns)
        expected = _expected(prepared.chain, returns.radial_m, exposure)
        radial, amplitude, valid, saturated, codes, tap_a, tap_b = _draw(prepared.chain, exposure, key, 0, raw, shape)
        phase_std = expected.depth_std_m * 2.0 * jnp.pi / expected.unambiguity_range_m
        flags = scene_flags(first.chain.params, settings, returns, first.direction)
        return _Frame(radial, amplitude, valid, saturated, phase_std, expected.amplitude_mean_lsb, flags,
                      settings.max_phase_noise_rad, settings.min_amplitude_lsb, codes, tap_a, tap_b)
    from ._multiframe import _fuse_frames, over_frequencies

    freq = prepared.freq
    cameras = prepared.cameras
    n = len(freq.ranges)
    exposures = over_frequencies(lambda c, r: c.expose(r), cameras, returns, n)  # each frequency's phase images
    expected = jax.vmap(lambda c, e: _expected(c.chain, returns.radial_m, e))(cameras, exposures)
    per = jax.vmap(lambda ch, e, s: _draw(ch, e, key, s, raw, shape))(cameras.chain, exposures,
                                                                     jnp.arange(n, dtype=jnp.uint32))
    radial, amplitude, valid, saturated, codes, tap_a, tap_b = per
    # Fused as MultiPreparedCamera.sample fuses its frames (one frame: a frames axis of 1).
    fused = _fuse_frames(NoisyFrames(radial[:, None], amplitude[:, None], valid[:, None]), freq, expected.depth_std_m)
    phase_std = expected.depth_std_m * 2.0 * jnp.pi / freq.column(2)
    flags = scene_flags(first.chain.params, settings, returns, first.direction, jnp.asarray(freq.extended))
    return _Frame(fused.radial_m[0], fused.amplitude_lsb[0], fused.valid[0], jnp.any(saturated, axis=0),
                  jnp.max(phase_std, axis=0), jnp.min(expected.amplitude_mean_lsb, axis=0), flags,
                  settings.max_phase_noise_rad, settings.min_amplitude_lsb, codes, tap_a, tap_b)


def _outputs(frame: _Frame, returns, rays) -> dict:
    """The step's outputs (:class:`SensorFrame`) from its frame."""
    sat = frame.saturated
    low = ~(frame.phase_std_rad <= frame.max_phase_noise_rad)
    dim = frame.expected_amplitude_lsb < frame.min_amplitude_lsb
    invalidated = ~frame.valid & ~sat & ~low & ~dim
    flags = (_bit(sat, FLAG_SATURATED) | _bit(low, FLAG_LOW_SIGNAL) | _bit(dim, FLAG_LOW_AMPLITUDE)
             | _bit(invalidated, FLAG_INVALIDATED) | frame.scene_flags.astype(jnp.int32))
    delivered = ((flags & CAMERA_FLAGS) == 0) & jnp.isfinite(frame.radial_m)
    d = rays.centre.astype(frame.radial_m.dtype)
    radial = jnp.where(delivered, frame.radial_m, jnp.nan)
    optical = jnp.stack([d[..., 0], -d[..., 1], d[..., 2]], axis=-1)
    confidence = jnp.where(delivered, jnp.clip(1.0 - frame.phase_std_rad / frame.max_phase_noise_rad, 0.0, 1.0), 0.0)
    f32 = jnp.float32
    out = {"depth_m": (radial * d[..., 2]).astype(f32), "radial_m": radial.astype(f32),
           "amplitude_lsb": frame.amplitude_lsb.astype(f32), "confidence": confidence.astype(f32), "flags": flags,
           "delivered": delivered, "points_m": (radial[..., None] * optical).astype(f32),
           "true_radial_m": returns.radial_m.astype(f32), "true_depth_m": (returns.radial_m * d[..., 2]).astype(f32)}
    if frame.codes is not None:
        out.update(codes=frame.codes, tap_a_e=frame.tap_a_e.astype(f32), tap_b_e=frame.tap_b_e.astype(f32))
    return out
