"""A robot arm in a room, simulated by MuJoCo, seen by a ToF camera (issue 51; docs/simulators.md).

    python notebooks/robot_simulator.py [--steps 36] [--scale 2] [--out robot_simulator] [--overwrite]

A room's concave corner 5.3 m away, a table and a three-joint arm on it swinging fast, built from
MuJoCo primitives (an MJCF string: no download). MuJoCo advances the arm (position actuators,
``mj_step``) and renders its depth camera (``tofjax.renderers.mujoco``: planar depth and geom ids,
headless through EGL or OSMesa) at each of the camera's phase images (``sensor.instants_s()``);
``tofjax.sensor.ToFSensor`` turns each step's stack of renders into the frame a real camera delivers:
the ``kinect-v2`` preset (512 x 424 pixels, 30 frames/s, three frequencies fused, its depth engine's
calibration and spatial filter), with two-bounce light from the buffers (``multipath=True``) and 2 x
2 rays per pixel (flying pixels at depth edges). The MuJoCo camera renders a wider field than the
ToF camera's (the illumination's, for the two-bounce light; the sensor resamples it onto the ToF
camera's distorted rays) and each geom has a near-infrared reflectivity (``reflectivity_table``).

Writes ``OUT/robot_simulator.gif``: true depth | the ToF camera's depth (black: not delivered) |
its error, one frame per step. The corner and the floor's edges read long (two-bounce light), the
pixels at the arm's and the table's edges fly between the two surfaces, the moving arm's edges read
off (each phase image sees the arm where it stands then: with the Kinect's 4 ms window a pixel
wide; ``--preset ti-opt8241-cdk``, 27 ms of exposure per frame, shows them wider), and the noise grows
with distance. It refuses to replace an existing GIF unless ``--overwrite``. ``--scale k`` divides
the camera's resolution by k (its field and each pixel's electrons kept: the pixel pitch times k,
the fill factor over k^2); the defaults make the GIF in docs/img.

From Python: ``run(steps, out, scale=..., overwrite=...)`` returns the frames and what they show
(:class:`Result`, ``result.summary()``); notebooks/10_robot_simulator.ipynb runs it.
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import sys
import tempfile
from pathlib import Path

import numpy as np

os.environ.setdefault("MUJOCO_GL", "egl")  # headless, before MuJoCo is imported (or MUJOCO_GL=osmesa)

#: The camera: a Kinect v2 (512 x 424 pixels, 30 frames/s, three frequencies fused: 18.7 m unambiguous;
#: its depth engine's calibration and spatial filter).
PRESET = "kinect-v2"
GIF = "robot_simulator.gif"
#: The room (MuJoCo's world frame, z up, metres): two walls meeting at a concave corner at
#: (CORNER_X, CORNER_Y), 4.2 m high, 5.3 m from the camera at CAMERA, which looks at LOOK_AT.
CORNER_X, CORNER_Y, WALL_HEIGHT = 3.6, 3.6, 4.2
CAMERA = np.array([-0.2, -0.1, 1.3])
LOOK_AT = np.array([3.0, 3.1, 1.1])
#: The near-infrared reflectivity of each geom (by name): white walls, a grey floor, a wooden
#: table, a light arm with a dark gripper.
REFLECTIVITY = {"wall_a": 0.7, "wall_b": 0.7, "floor": 0.35, "table_top": 0.5, "leg0": 0.3, "leg1": 0.3, "leg2": 0.3,
                "leg3": 0.3, "base": 0.5, "upper": 0.7, "fore": 0.7, "gripper": 0.15, "crate": 0.6}
#: The MuJoCo camera: its vertical field and aspect (84 x 72 degrees: the ToF camera's 70 x 60 through
#: its lens' distortion, and the illumination's 71 x 60 for the multipath), and its pixels per ToF
#: pixel along each axis (the same focal length in pixels times this).
BUFFER_FOVY_DEG = 72.0
BUFFER_ASPECT = 1.25
BUFFER_OVERSAMPLING = 1.25
#: The arm's motion: each joint a sine (amplitude rad, period s, phase rad, offset rad).
MOTION = {"yaw": (0.9, 1.5, 0.0, 1.6), "shoulder": (0.35, 1.0, 1.0, -0.7), "elbow": (0.45, 1.0, 2.0, 0.8)}


def mjcf() -> str:
    """The scene (module docstring) as MJCF: walls, floor, table, a crate and the arm on the table,
    the ToF camera's depth camera "tof" at CAMERA looking at LOOK_AT."""
    forward = (LOOK_AT - CAMERA) / np.linalg.norm(LOOK_AT - CAMERA)
    right = np.cross(forward, [0.0, 0.0, 1.0])
    right /= np.linalg.norm(right)
    up = np.cross(right, forward)
    xyaxes = " ".join(f"{x:.9f}" for x in (*right, *up))
    h, t = WALL_HEIGHT / 2, 0.05
    actuators = "".join(f'<position name="{j}" joint="{j}" kp="400" kv="40"/>' for j in MOTION)
    return f"""
<mujoco model="tof room">
  <option timestep="0.002" gravity="0 0 -9.81"/>
  <visual><map znear="0.02" zfar="50"/></visual>
  <worldbody>
    <geom name="floor" type="box" size="5 5 {t}" pos="0 0 {-t}"/>
    <geom name="wall_a" type="box" size="4 {t} {h}" pos="{CORNER_X - 4} {CORNER_Y + t} {h}"/>
    <geom name="wall_b" type="box" size="{t} 4 {h}" pos="{CORNER_X + t} {CORNER_Y - 4} {h}"/>
    <geom name="crate" type="box" size="0.25 0.2 0.2" pos="0.3 1.6 0.2" euler="0 0 20"/>
    <body name="table" pos="0.95 1.05 0" euler="0 0 45">
      <geom name="table_top" type="box" size="0.6 0.4 0.025" pos="0 0 0.725"/>
      <geom name="leg0" type="box" size="0.03 0.03 0.35" pos="0.55 0.35 0.35"/>
      <geom name="leg1" type="box" size="0.03 0.03 0.35" pos="-0.55 0.35 0.35"/>
      <geom name="leg2" type="box" size="0.03 0.03 0.35" pos="0.55 -0.35 0.35"/>
      <geom name="leg3" type="box" size="0.03 0.03 0.35" pos="-0.55 -0.35 0.35"/>
      <body name="arm" pos="0.25 0 0.75">
        <geom name="base" type="cylinder" size="0.09 0.06" pos="0 0 0.06" mass="2"/>
        <joint name="yaw" type="hinge" axis="0 0 1" damping="5"/>
        <body name="upper_link" pos="0 0 0.14">
          <joint name="shoulder" type="hinge" axis="0 1 0" damping="5"/>
          <geom name="upper" type="capsule" fromto="0 0 0 0.5 0 0" size="0.05" mass="1.5"/>
          <body name="fore_link" pos="0.5 0 0">
            <joint name="elbow" type="hinge" axis="0 1 0" damping="3"/>
            <geom name="fore" type="capsule" fromto="0 0 0 0.45 0 0" size="0.04" mass="0.8"/>
            <geom name="gripper" type="box" size="0.06 0.07 0.035" pos="0.5 0 0" mass="0.2"/>
          </body>
        </body>
      </body>
    </body>
    <camera name="tof" pos="{CAMERA[0]} {CAMERA[1]} {CAMERA[2]}" xyaxes="{xyaxes}" fovy="{BUFFER_FOVY_DEG}"/>
  </worldbody>
  <actuator>{actuators}</actuator>
</mujoco>"""


def camera(scale: int = 1, preset: str = PRESET):
    """The ``preset``'s camera, its resolution divided by ``scale`` (module docstring)."""
    import tofjax as tj

    config = tj.preset_config(preset)
    if scale != 1:
        pitch = np.asarray(config.values["camera"]["pixel_pitch_m"], dtype=float)
        config = config.replace("camera.pixel_pitch_m", (pitch * scale).tolist())
        config = config.replace("camera.fill_factor", config.values["camera"]["fill_factor"] / scale**2)
    return tj.Camera.from_config(config)


def targets(t: float) -> np.ndarray:
    """The joints' target angles at time ``t`` (:data:`MOTION`)."""
    return np.array([a * np.sin(2 * np.pi * t / period + phase) + offset
                     for a, period, phase, offset in MOTION.values()])


@dataclasses.dataclass
class Result:
    """What :func:`run` made, arrays ``(steps, rows, cols)`` of the ToF camera's pixels.

    - ``true_depth_m``: the truth, planar depth (Z) of what each pixel's centre ray meets (inf: nothing);
    - ``depth_m``: the camera's delivered depth (REP 118: Z, NaN where not delivered);
    - ``corner``: the pixels that see the walls within 0.5 m of the corner line, above the table;
    - ``flying``: delivered pixels at a depth edge (the truth spans more than 0.25 m in its 3 x 3
      neighbourhood) whose depth lies between the edge's two surfaces (8 cm inside either);
    - ``moving``: pixels whose truth changed by more than 1 mm since the previous step (a surface
      moving, an edge passing);
    - ``wrapped``: pixels beyond the camera's unambiguity range;
    - ``gif``: the written GIF (``None`` without ``out``); ``stamps_s`` the frames' times;
      ``unambiguity_range_m``; ``preset``.
    """

    true_depth_m: np.ndarray
    depth_m: np.ndarray
    corner: np.ndarray
    flying: np.ndarray
    moving: np.ndarray
    wrapped: np.ndarray
    stamps_s: np.ndarray
    unambiguity_range_m: float
    preset: str
    gif: Path | None

    def summary(self) -> str:
        """What the frames show, in a few lines (what the GIF should make visible)."""
        error = self.depth_m - self.true_depth_m
        good = np.isfinite(self.depth_m)
        ok = good & ~self.wrapped
        corner = error[self.corner & ok]
        moving = np.abs(error[self.moving & ok & ~self.flying])
        still = np.abs(error[~self.moving & ok & ~self.flying & ~self.corner])
        noise = [1e3 * self.noise_m(ok & (self.true_depth_m < 2.5)), 1e3 * self.noise_m(ok & (self.true_depth_m > 4.5))]
        lines = [
            f"{len(self.depth_m)} frames, {100 * good.mean():.0f} % of the pixels delivered, "
            f"{100 * self.wrapped.mean():.0f} % beyond the {self.unambiguity_range_m:.2f} m unambiguity range",
            f"corner: median error {1e3 * np.median(corner):+.1f} mm over {corner.size} pixel readings (two-bounce light)",
            f"flying pixels at depth edges: {int(self.flying.sum())} readings between the two surfaces",
            f"moving surfaces: median |error| {1e3 * np.median(moving):.1f} mm over {moving.size} readings, "
            f"still ones {1e3 * np.median(still):.1f} mm" if moving.size else "moving surfaces: none",
            f"noise (frame to frame, still pixels): {noise[0]:.0f} mm nearer than 2.5 m, {noise[1]:.0f} mm beyond 4.5 m",
        ]
        return "\n".join(lines)

    def noise_m(self, mask: np.ndarray) -> float:
        """The depth noise of the pixels ``mask`` holds: the spread of consecutive frames' difference
        (1.4826 x its median absolute deviation, robust to the odd wrong unwrapping) over sqrt 2,
        where the pixel is delivered in both and its truth stayed (NaN: fewer than 10 such)."""
        d, t = self.depth_m, self.true_depth_m
        with np.errstate(invalid="ignore"):  # inf - inf where a pixel sees nothing
            stayed = np.abs(t[1:] - t[:-1]) < 1e-6
        both = mask[1:] & mask[:-1] & stayed & ~self.flying[1:] & ~self.flying[:-1]
        diff = (d[1:] - d[:-1])[both]
        if diff.size < 10:
            return float("nan")
        return float(1.4826 * np.median(np.abs(diff - np.median(diff))) / np.sqrt(2.0))


def _neighbourhood(a: np.ndarray, reduce) -> np.ndarray:
    """``reduce`` (np.fmin or np.fmax) over each pixel's 3 x 3 neighbourhood."""
    padded = np.pad(a, 1, mode="edge")
    rows, cols = a.shape
    out = a.copy()
    for dr in range(3):
        for dc in range(3):
            out = reduce(out, padded[dr:dr + rows, dc:dc + cols])
    return out


def run(steps: int = 36, out: str | os.PathLike | None = None, *, scale: int = 2, overwrite: bool = False,
        seed: int = 0, multipath: bool = True, subpixel_samples: int = 2, preset: str = PRESET,
        quiet: bool = True) -> Result:
    """Simulate ``steps`` frames (module docstring) of the ``preset``'s camera; with ``out``, write the
    GIF there (refusing an existing one unless ``overwrite``)."""
    import mujoco

    from tofjax.renderers import mujoco as tmj
    from tofjax.sensor import ToFSensor

    gif = None if out is None else Path(out) / GIF
    if gif is not None and gif.exists() and not overwrite:
        raise FileExistsError(f"{gif} exists: give --overwrite (overwrite=True) to replace it")
    model = mujoco.MjModel.from_xml_string(mjcf())
    data = mujoco.MjData(model)
    table = {model.geom(name).id: rho for name, rho in REFLECTIVITY.items()}
    cam = camera(scale, preset)
    sensor = ToFSensor(cam, seed=seed, subpixel_samples=subpixel_samples)
    intr = sensor.intrinsics
    height = int(round(2.0 * BUFFER_OVERSAMPLING * intr["fy"] * np.tan(np.radians(BUFFER_FOVY_DEG) / 2.0)))
    width = int(round(BUFFER_ASPECT * height))
    period = sensor.frame_period_s
    # The buffers of a step: the scene at each of the camera's phase images (instants_s: times from the
    # frame's stamp); MuJoCo steps finely enough to stand at each of them (to 0.1 ms).
    instants = sensor.instants_s(1)
    model.opt.timestep = 2e-4
    data.qpos[:] = targets(0.0)
    data.ctrl[:] = targets(0.0)
    mujoco.mj_forward(model, data)

    def advance(t):  # the simulator's step: the arm follows its targets until time t
        while data.time < t - 0.5 * model.opt.timestep:
            data.ctrl[:] = targets(data.time)
            mujoco.mj_step(model, data)

    ray_z = np.asarray(sensor.rays.centre[..., 2])
    directions = np.asarray(sensor.rays.centre)
    cam_id = model.camera("tof").id
    frames, truths, stamps, worlds = [], [], [], []
    with tmj.DepthCamera(model, "tof", width=width, height=height) as view:
        for step in range(steps):
            stamp = -instants[0] + step * period
            renders = []
            for t in stamp + instants:
                advance(t)
                renders.append(view.render(data))
            frame = sensor.step(np.stack([r.depth_m for r in renders]), intrinsics=renders[0].intrinsics,
                                depth_type=renders[0].depth_type, segmentation=np.stack([r.segmentation for r in renders]),
                                reflectivity_table=table, time_s=stamp, multipath=multipath)
            frames.append(frame.depth_m)
            truths.append(frame.true_depth_m.astype(float))
            stamps.append(frame.stamp_s)
            # each pixel's surface in the world: the camera's pose (MuJoCo's camera looks along -z)
            local = frame.true_radial_m.astype(float)[..., None] * directions * np.array([1.0, 1.0, -1.0])
            worlds.append(local @ data.cam_xmat[cam_id].reshape(3, 3).T + data.cam_xpos[cam_id])
            if not quiet:
                print(f"step {step + 1}/{steps}: t = {stamp:.3f} s", file=sys.stderr)
    depth = np.stack(frames).astype(float)
    truth = np.stack(truths)
    world = np.stack(worlds)
    on_wall = (np.abs(world[..., 1] - CORNER_Y) < 1e-3) | (np.abs(world[..., 0] - CORNER_X) < 1e-3)
    near_corner = np.hypot(world[..., 0] - CORNER_X, world[..., 1] - CORNER_Y) < 0.5
    corner = on_wall & near_corner & (world[..., 2] > 0.9) & (world[..., 2] < WALL_HEIGHT - 0.2)
    lo = np.stack([_neighbourhood(np.where(np.isfinite(t), t, np.nan), np.fmin) for t in truth])
    hi = np.stack([_neighbourhood(np.where(np.isfinite(t), t, np.nan), np.fmax) for t in truth])
    flying = np.isfinite(depth) & (hi - lo > 0.25) & (depth > lo + 0.08) & (depth < hi - 0.08)
    with np.errstate(invalid="ignore"):  # inf - inf where a pixel sees nothing
        change = np.abs(np.diff(truth, axis=0, prepend=truth[:1]))
    moving = np.isfinite(truth) & ~(change <= 1e-3)
    unambiguity = _unambiguity_range_m(sensor)
    wrapped = np.isfinite(truth) & (truth / ray_z > unambiguity)
    result = Result(truth, depth, corner, flying, moving, wrapped, np.asarray(stamps), unambiguity, preset, None)
    if gif is not None:
        result.gif = _write_gif(result, gif, overwrite)
    return result


def _unambiguity_range_m(sensor) -> float:
    """The camera's unambiguity range, m (several frequencies: their extended range)."""
    from tofjax._multifrequency import extended_range_m

    if sensor.camera.multifrequency:
        return float(extended_range_m(sensor.camera.frequencies_hz))
    return float(sensor.prepared.chain.unambiguity_range_m)


#: The GIF's panels: title, colour map, range.
PANELS = (("true depth Z (MuJoCo) [m]", "turbo", (0.5, 6.0)), ("ToF depth Z ({preset}) [m]", "turbo", (0.5, 6.0)),
          ("ToF - true [m]", "RdBu_r", (-0.03, 0.03)))


def _write_gif(result: Result, path: Path, overwrite: bool) -> Path:
    """The GIF (module docstring), one frame per step, written to a temporary name beside ``path`` and
    renamed into place."""
    import matplotlib as mpl
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure
    from PIL import Image

    path.parent.mkdir(parents=True, exist_ok=True)
    rows, cols = result.depth_m.shape[1:]
    zoom = max(1.0, 150.0 / rows)  # the panels' pixels per camera pixel (small cameras enlarged)
    pw, ph, gap, top, bottom = cols * zoom, rows * zoom, 6.0, 14.0, 24.0  # in the GIF's pixels
    W, H = 3 * pw + 4 * gap, ph + top + bottom
    fig = Figure(figsize=(W / 100, H / 100), dpi=100)
    canvas = FigureCanvasAgg(fig)
    axes = [fig.add_axes(((gap + i * (pw + gap)) / W, bottom / H, pw / W, ph / H)) for i in range(3)]
    artists = []
    for ax, (title, cmap, (lo, hi)) in zip(axes, PANELS, strict=True):
        colours = mpl.colormaps[cmap].with_extremes(bad="black")
        artists.append(ax.imshow(np.zeros((rows, cols)), cmap=colours, vmin=lo, vmax=hi, interpolation="nearest"))
        ax.set_title(f"{title.format(preset=result.preset)}: {lo:g} to {hi:g}", fontsize=6.5, pad=2)
        ax.set_axis_off()
    caption = fig.text(gap / W, 2.0 / H, "", fontsize=6, va="bottom", linespacing=1.1)
    images = []
    for k in range(len(result.depth_m)):
        for artist, image in zip(artists, (result.true_depth_m[k], result.depth_m[k], result.depth_m[k] - result.true_depth_m[k]), strict=True):
            artist.set_data(np.where(np.isfinite(image), image, np.nan))
        caption.set_text(f"t = {result.stamps_s[k]:.3f} s, slowed down; black: not delivered. The corner reads long "
                         "(two-bounce light), edges fly,\nthe moving arm reads off, the noise grows with distance")
        canvas.draw()
        rgb = np.asarray(canvas.buffer_rgba())[..., :3]
        images.append(Image.fromarray(rgb).quantize(colors=64, method=Image.Quantize.MEDIANCUT,
                                                     dither=Image.Dither.NONE))
    if path.exists() and not overwrite:
        raise FileExistsError(f"{path} exists: give --overwrite (overwrite=True) to replace it")
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.partial-", dir=path.parent)
    os.close(fd)
    try:
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)  # as an ordinary new file (mkstemp's is private)
        images[0].save(tmp, format="GIF", save_all=True, append_images=images[1:], duration=120, loop=0,
                       optimize=True)
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)
    return path


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--steps", type=int, default=36, help="frames to simulate (default 36: 1.2 s at 30 frames/s)")
    parser.add_argument("--out", default="robot_simulator", help="folder for robot_simulator.gif")
    parser.add_argument("--scale", type=int, default=2, help="divide the camera's resolution by this (default 2: the "
                        "GIF in docs/img; 1: the camera's own)")
    parser.add_argument("--seed", type=int, default=0, help="the sensor's seed (its fixed pattern and noise)")
    parser.add_argument("--preset", default=PRESET, help=f"the camera, a preset of tofjax (default {PRESET})")
    parser.add_argument("--no-multipath", action="store_true", help="without two-bounce light")
    parser.add_argument("--overwrite", action="store_true", help="replace an existing GIF")
    args = parser.parse_args(argv)
    if args.steps < 1 or args.scale < 1:
        parser.error("--steps and --scale: allowed integers >= 1")
    gif = Path(args.out) / GIF
    if gif.exists() and not args.overwrite:
        parser.error(f"{gif} exists: give --overwrite to replace it")
    import tofjax as tj

    if args.preset not in tj.PRESETS:
        parser.error(f"--preset {args.preset!r}: allowed {', '.join(tj.PRESETS)}")

    tj.enable_compilation_cache()
    result = run(args.steps, args.out, scale=args.scale, overwrite=args.overwrite, seed=args.seed,
                 multipath=not args.no_multipath, preset=args.preset, quiet=False)
    print(result.summary())
    print(f"wrote {result.gif}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
