"""A camera in time: a scene that moves during a frame (issue 36 item 1; docs/model.md, "A camera in
time: motion").

A frame's phase images integrate one after the other (:attr:`tofjax.Camera.timing`): phase image j
from t_j = j (t + t_ro) to t_j + t, t the phase image time and t_ro the readout time; a camera of
several frequencies takes each frequency's phase images in turn, so the frame's phase image j is
phase j mod n of frequency j // n (n phases per frequency), and every frequency sees the scene where
it stands during its own phase images. A scene that
moves is exposed at the instants it occupies: each phase image sees the scene at ``substeps``
instants spread evenly over its integration (the centre of each of ``substeps`` equal slices), each
carrying 1/``substeps`` of its light, so the exposure integrates the motion within a phase image
and the scene has moved between phase images. Its returns are the returns of every instant, each
tagged with its phase image (:attr:`tofjax.Returns.phase_image`); the mixer sorts each into its own
phase image only. The truth (``radial_m``) and the background light are the scene's at the frame's
centre time, (N t + (N - 1) t_ro) / 2 (N the frame's phase images, every frequency's), where the scene
stands as given.

What moves: a :class:`MovingScene` (:func:`moving`: a scene's primitives and patches in rigid
motion, a constant velocity and a constant angular velocity about a pivot), or a user's renderer's
returns, one :class:`tofjax.Returns` per phase image (:func:`per_phase_returns`). A scene that does
not move is the static scene, to the bit.
"""

from __future__ import annotations

import equinox as eqx
import jax
import jax.scipy.linalg
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from ._returns import Returns
from ._scene import SceneGeometry
from ._schema import checked_range

#: The most sub-steps per phase image (each one a ray cast of the whole frame).
MAX_SUBSTEPS = 64


class MovingScene(eqx.Module):
    """A scene in rigid motion (:func:`moving`): ``geometry`` where it stands at the frame's centre
    time, moving at ``velocity_m_per_s`` (camera coordinates: x right, y up, z along the optical
    axis) and turning at ``angular_velocity_rad_per_s`` (a rotation vector: its direction the axis by
    the right-hand rule, its length the rate; ``None``: not turning) about ``pivot_m`` (where that
    point stands at the centre time), exposed at ``substeps`` instants per phase image (static)."""

    geometry: SceneGeometry
    velocity_m_per_s: Float[Array, "3"]
    substeps: int = eqx.field(static=True, default=4)
    angular_velocity_rad_per_s: Float[Array, "3"] | None = None
    pivot_m: Float[Array, "3"] | None = None

    def __check_init__(self):
        if not isinstance(self.geometry, SceneGeometry):
            raise TypeError(f"tofjax.scenes.moving: scene must be a tofjax.scenes.SceneGeometry, got "
                            f"{type(self.geometry).__name__}")
        for name, unit in (("velocity_m_per_s", "(vx, vy, vz) in m/s"),
                           ("angular_velocity_rad_per_s", "(wx, wy, wz) in rad/s"), ("pivot_m", "(x, y, z) in m")):
            value = getattr(self, name)
            if value is not None and jnp.shape(value) != (3,):
                raise ValueError(f"tofjax.scenes.moving: {name} has shape {jnp.shape(value)}: allowed three numbers "
                                 f"{unit}")
        if (self.angular_velocity_rad_per_s is None) != (self.pivot_m is None):
            raise ValueError("tofjax.scenes.moving: pivot_m is required with angular_velocity_rad_per_s (and only "
                             "with it): the point, m in camera coordinates, the scene turns about")
        self.check_substeps(self.substeps, "tofjax.scenes.moving")
        if self.turning:
            problem = self.geometry.rotation_problem()
            if problem:
                raise ValueError(f"tofjax.scenes.moving: angular_velocity_rad_per_s: the scene cannot turn: {problem} "
                                 "(turn unbounded planes, spheres and patches; render anything else per phase image)")

    @staticmethod
    def check_substeps(substeps, what: str) -> None:
        """``ValueError`` naming ``what`` unless ``substeps`` is a whole number in 1..:data:`MAX_SUBSTEPS`."""
        if isinstance(substeps, bool) or not isinstance(substeps, int) or not 1 <= substeps <= MAX_SUBSTEPS:
            raise ValueError(f"{what}: substeps = {substeps!r} is out of range: allowed integer 1 <= value <= "
                             f"{MAX_SUBSTEPS} (instants per phase image)")

    @property
    def turning(self) -> bool:
        """Whether the scene has an angular velocity that is not concretely zero."""
        return self.angular_velocity_rad_per_s is not None and not _still(self.angular_velocity_rad_per_s)

    @property
    def still(self) -> bool:
        """Whether the velocity is concretely zero and the scene does not turn (then the frame is the
        static scene's)."""
        return _still(self.velocity_m_per_s) and not self.turning

    def at(self, t_s) -> SceneGeometry:
        """The scene at ``t_s`` from the frame's centre time: translated by v t, and turned by the
        rotation exp([w t]x) about the pivot, which itself moves with v (Rodrigues' rotation as a
        matrix exponential, exact and differentiable at w = 0)."""
        offset = t_s * self.velocity_m_per_s
        if not self.turning:
            return self.geometry.translated(offset)
        wx, wy, wz = self.angular_velocity_rad_per_s * t_s
        zero = jnp.zeros_like(wx)
        skew = jnp.stack([jnp.stack([zero, -wz, wy]), jnp.stack([wz, zero, -wx]), jnp.stack([-wy, wx, zero])])
        return self.geometry.turned(jax.scipy.linalg.expm(skew), self.pivot_m, offset)


def _still(velocity) -> bool:
    """Whether a velocity (a vector or a map) is concretely zero everywhere."""
    from ._schema import _is_tracer

    return not _is_tracer(velocity) and not np.any(np.asarray(velocity))


def moving(scene: SceneGeometry, velocity_m_per_s=(0.0, 0.0, 0.0), *, angular_velocity_rad_per_s=None,
           pivot_m=None, substeps: int = 4) -> MovingScene:
    """``scene`` in rigid motion during the frame, standing as given at the frame's centre time, its
    exposure integrated over ``substeps`` instants per phase image (module docstring).

    - ``velocity_m_per_s``: (vx, vy, vz), m/s, camera coordinates (x right, y up, z away from the camera).
    - ``angular_velocity_rad_per_s``: (wx, wy, wz), rad/s, a rotation vector (axis by the right-hand
      rule, length the rate) about ``pivot_m`` (m, camera coordinates; required with it). Planes
      without bounds, spheres and patches turn; a bounded plane or a box (axis-aligned) is refused.
    """
    v = jnp.asarray(checked_range(velocity_m_per_s, "tofjax.scenes.moving: velocity_m_per_s", -1e4, 1e4,
                                  unit="m/s"), dtype=float)
    w = None if angular_velocity_rad_per_s is None else jnp.asarray(checked_range(
        angular_velocity_rad_per_s, "tofjax.scenes.moving: angular_velocity_rad_per_s", -1e4, 1e4, unit="rad/s"),
        dtype=float)
    pivot = None if pivot_m is None else jnp.asarray(checked_range(pivot_m, "tofjax.scenes.moving: pivot_m",
                                                                   unit="m"), dtype=float)
    return MovingScene(scene, v, substeps, w, pivot)


def instants_s(n_phases: int, phase_image_time_s, readout_time_s, substeps: int) -> Float[Array, "phases substeps"]:
    """The instants a moving scene is exposed at, relative to the frame's centre time, s: phase
    image j's slice k centred at j (t + t_ro) + (k + 1/2) t / substeps (module docstring)."""
    j = jnp.arange(n_phases, dtype=float)[:, None]
    k = jnp.arange(substeps, dtype=float)[None, :]
    t, ro = phase_image_time_s, readout_time_s
    centre = 0.5 * (n_phases * t + (n_phases - 1) * ro)
    return j * (t + ro) + (k + 0.5) * t / substeps - centre


def _stacked(parts: Returns, n_phases: int, substeps: int, static: Returns) -> Returns:
    """Returns of ``n_phases x substeps`` instants (a leading axis; ``n_phases`` the frame's phase
    images, every frequency's) as one pixel's returns, each instant's radiance 1/``substeps`` of its
    phase image's, tagged with its phase image; the truth and the background ``static``'s."""
    rows, cols, k = parts.path_m.shape[1:]
    n = n_phases * substeps

    def flat(x):  # (instants, rows, cols, k) -> (rows, cols, instants x k)
        return jnp.moveaxis(x, 0, 2).reshape(rows, cols, n * k)

    tags = tuple(int(j) for j in np.repeat(np.arange(n_phases), substeps * k))
    source = None if parts.source is None else tuple(parts.source) * n  # each instant's own and interfering light
    return Returns(flat(parts.path_m), flat(parts.radiance_per_w) / substeps, static.ambient_reflectivity,
                   static.radial_m, tags, source)


def moving_returns(camera, scene: MovingScene, **kwargs) -> Returns:
    """The returns of a :class:`MovingScene` seen by ``camera`` (a :class:`tofjax.Camera`; its
    timing places the instants): every instant's ray cast, tagged (module docstring). ``kwargs``:
    :meth:`tofjax.Camera.returns`' ``sun_direction`` and ``bins``."""
    static = camera.returns(scene.geometry, **kwargs)
    if scene.still:
        return static
    return _over_instants(_timing(camera), scene.substeps, static, lambda t: camera.returns(scene.at(t), **kwargs))


def _timing(camera):
    """A :class:`tofjax.Camera`'s frame timing (its frequencies' phase images in turn), unchecked: the
    instants are where the scene is seen, whatever the frame rate."""
    from ._timing import frame_timing

    return frame_timing(camera.params, camera._n_frequencies)


def _over_instants(timing, substeps: int, static: Returns, returns_at) -> Returns:
    """The returns ``returns_at(t)`` of every instant the frame's phase images expose (``timing``, a
    :class:`tofjax._timing.FrameTiming`: all of them, every frequency's; ``t`` from the frame's centre,
    s; one ``vmap``ed program), stacked and tagged (:func:`_stacked`)."""
    n = timing.phase_images
    times = instants_s(n, timing.phase_image_time_s, timing.readout_time_s, substeps).reshape(-1)
    return _stacked(jax.vmap(returns_at)(times), n, substeps, static)


def moving_depth_returns(camera, depth_m, reflectivity, radial: bool, velocity_m_per_s, substeps: int) -> Returns:
    """The returns of a depth map whose depths change at ``velocity_m_per_s`` (a number or a map of
    the frame's shape, m/s, in the map's convention: Z, or radial with ``radial``), the map giving
    the depths at the frame's centre time (module docstring; ``substeps`` instants per phase image)."""
    from ._framegeometry import depth_returns

    static = depth_returns(camera.params, camera.settings, depth_m, reflectivity, radial=radial)
    MovingScene.check_substeps(substeps, "velocity_m_per_s of a depth map")
    v = jnp.asarray(checked_range(velocity_m_per_s, "depth map: velocity_m_per_s", -1e4, 1e4, unit="m/s"),
                    dtype=float)
    if v.shape not in ((), static.shape):
        raise ValueError(f"depth map: velocity_m_per_s has shape {v.shape}: allowed a number or the camera's "
                         f"{static.shape}")
    if _still(v):
        return static
    depth = jnp.asarray(depth_m, dtype=float)
    return _over_instants(_timing(camera), substeps, static, lambda t: depth_returns(
        camera.params, camera.settings, depth + v * t, reflectivity, radial=radial))


def per_phase_returns(returns) -> Returns:
    """One :class:`tofjax.Returns` per phase image (a renderer's, at each phase image's instant) as
    one pixel's returns, each tagged with its phase image; the truth and the background the first's."""
    returns = list(returns)
    if not returns or not all(isinstance(r, Returns) for r in returns):
        raise TypeError("a scene given per phase image is a list of tofjax.Returns, one for each phase image")
    shapes = {r.path_m.shape for r in returns}
    if len(shapes) != 1 or any(r.phase_image is not None for r in returns) or len({r.source for r in returns}) != 1:
        raise ValueError(f"the per-phase-image returns have shapes {sorted(shapes)}: allowed one shape (rows, cols, "
                         "returns) for every phase image, each a static scene's returns")
    parts = jax.tree_util.tree_map(lambda *x: jnp.stack(x), *returns)
    return _stacked(parts, len(returns), 1, returns[0])
