"""``tofjax render``: full frames of a scene (docs/model.md, "Full frames").

Writes into ``--out DIR``: ``frame.npz`` (every image, and the kept frames), PNG colour maps with
colour bars, 16-bit ``depth_mm.png`` and ``amplitude.png``, ``points.ply`` (the good pixels' point cloud) and a
self-contained ``report.html``.
"""

from __future__ import annotations

import math
import time
from pathlib import Path

from ._framescene import check_size, load_npz_scene, parse_scene


def register(subparsers) -> None:
    from .cli import add_output_options  # loaded already: cli loads this command's entry point

    p = subparsers.add_parser(
        "render", help="render full frames of a scene: depth, noise image, amplitude, point cloud",
        description="Monte Carlo frames of every pixel of the camera looking at a scene, with the analytic "
                    "noise image beside them. --scene is a built-in scene, NAME or NAME:key=value,... "
                    "(wall, tilted_plane, step_edge, box_on_floor, sphere, corner), or an NPZ file: a depth map "
                    "(z_m or radial_m, optional reflectivity) or returns (path_m, radiance_per_w: the output "
                    "of a transient renderer, docs/model.md); or --mesh, a triangle mesh cast with Open3D. The "
                    "operating point is the configuration's "
                    "scene.illuminance_lx and scene.integration_time_s; [frame] sets the array's optics and "
                    "fixed pattern.")
    what = p.add_mutually_exclusive_group(required=True)
    what.add_argument("--scene", help="NAME[:key=value,...] or FILE.npz (default parameters: tofjax.scenes)")
    what.add_argument("--mesh", type=Path, metavar="FILE",
                      help="a triangle mesh (.obj, .ply, .stl, .off, .gltf, .glb) in the camera's frame (x right, y "
                           "up, z along the optical axis, m), cast along every sub-pixel ray with Open3D (pip install "
                           '"tofjax[open3d]"; docs/renderers.md)')
    p.add_argument("--mesh-pose", type=_pose, metavar="X,Y,Z,RX,RY,RZ",
                   help="where --mesh goes: turned by RX, then RY, then RZ degrees about the camera's x, y and z axes, "
                        "then moved by X,Y,Z m (default 0,0,0,0,0,0; a negative X needs the form --mesh-pose=-1,0,2,0,0,0)")
    p.add_argument("--reflectivity", type=_reflectivity, metavar="R",
                   help="--mesh's Lambertian reflectivity, 0 to 1 (default: the configuration's scene.reflectivity)")
    p.add_argument("--config", type=Path, help="TOML configuration (default: built-in defaults)")
    p.add_argument("--frames", type=_frame_count, default=100,
                   help=f"Monte Carlo frames (default 100; at most {_max_frames():.0e}, as pixel.iterations)")
    p.add_argument("--keep-frames", type=_non_negative_int, default=1,
                   help="frames to keep whole in frame.npz (default 1; at most --frames)")
    p.add_argument("--raw", action="store_true",
                   help="also write the kept frames' raw phase images into frame.npz: ADC codes and both taps' "
                        "electrons per phase image (layout: docs/model.md, 'Raw phase images')")
    p.add_argument("--seed", type=_non_negative_int, default=0, help="random seed of the frames (default 0)")
    p.add_argument("--fixed-pattern", action="store_true",
                   help="draw the camera's pixel-to-pixel pattern from frame.seed and the [frame] sigmas "
                        "(default: every pixel the mean pixel)")
    p.add_argument("--sun", type=_direction, metavar="DX,DY,DZ",
                   help="the background light's direction of travel (e.g. 0,-1,1: from above, behind the "
                        "camera); default: the configured illuminance on every surface")
    p.add_argument("--out", type=Path, required=True, help="output directory")
    p.add_argument("--check", action="store_true", help="validate everything, print the plan, render nothing")
    p.add_argument("--quiet", action="store_true", help="no progress report")
    add_output_options(p)
    p.set_defaults(run=run)


def _max_frames() -> int:
    """The most frames of one render: ``pixel.iterations``' bound (frames per point)."""
    from ._schema import KEY_BY_DOTTED

    return int(KEY_BY_DOTTED["pixel.iterations"].hi)


def _frame_count(text: str) -> int:
    import argparse

    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not an integer") from None
    if not 1 <= value <= _max_frames():
        raise argparse.ArgumentTypeError(f"{value} is out of range: allowed integer 1 <= value <= {_max_frames()} "
                                         "(as pixel.iterations)")
    return value


def _non_negative_int(text: str) -> int:
    import argparse

    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not an integer") from None
    if value < 0 or value > 2**31 - 1:
        raise argparse.ArgumentTypeError(f"{value} is out of range: allowed integer 0 <= value <= {2**31 - 1}")
    return value


def _direction(text: str):
    import argparse

    parts = text.split(",")
    try:
        values = [float(x) for x in parts]
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not three comma-separated numbers DX,DY,DZ") from None
    if len(values) != 3 or not all(math.isfinite(v) for v in values) or not any(values):
        raise argparse.ArgumentTypeError(f"{text!r} is not a direction: allowed three finite numbers DX,DY,DZ, "
                                         "not all 0")
    return tuple(values)


def _numbers(text: str, count: int, what: str) -> tuple[float, ...]:
    import argparse

    try:
        values = tuple(float(x) for x in text.split(","))
    except ValueError:
        values = ()
    if len(values) != count or not all(math.isfinite(v) for v in values):
        raise argparse.ArgumentTypeError(f"{text!r} is not {what}")
    return values


def _pose(text: str) -> tuple[float, ...]:
    return _numbers(text, 6, "six comma-separated finite numbers X,Y,Z (m),RX,RY,RZ (degrees)")


def _reflectivity(text: str) -> float:
    import argparse

    (value,) = _numbers(text, 1, "a number")
    if not 0.0 <= value <= 1.0:
        raise argparse.ArgumentTypeError(f"{value:g} is out of range: allowed 0 <= value <= 1")
    return value


def _mesh_renderer():
    """:mod:`tofjax.renderers.open3d`, or the one line that says what is missing (exit 2)."""
    from .cli import CommandError
    from .renderers import MissingExtra

    try:
        from .renderers import open3d
    except MissingExtra as err:
        raise CommandError(f"--mesh: {err}", 2) from None
    return open3d


def run(args) -> int:
    from .cli import check_output_dir, on_interrupt, output_dir, untouched_note
    from .progress import Progress, Stages, compiling, reporting

    mesh = args.mesh
    if mesh is None and (args.mesh_pose is not None or args.reflectivity is not None):
        raise ValueError("--mesh-pose and --reflectivity place and colour --mesh: a --scene sets its own")
    if mesh is not None:  # before JAX starts: the file, then Open3D
        if not mesh.is_file():
            raise ValueError(f"--mesh {mesh}: no such file")
        renderer = _mesh_renderer()
        vertices, triangles = renderer.read_mesh(mesh)
        builder, name, kwargs = None, str(mesh), {}
    else:
        builder, name, kwargs = parse_scene(args.scene)
    if args.keep_frames > args.frames:
        raise ValueError(f"--keep-frames = {args.keep_frames} is out of range: allowed 0 <= value <= --frames = "
                         f"{args.frames}")
    if args.raw and args.keep_frames == 0:
        raise ValueError("--raw writes the kept frames' raw phase images: it needs --keep-frames >= 1 (given 0)")
    check_output_dir(args.out, "--out", args)
    import jax

    import tofjax as tj

    from . import frameio

    config = tj.load_config(args.config) if args.config else tj.Config()
    params, settings = config.params, config.frame
    rows, cols = tj.optics.frame_shape(params)
    from ._limits import kept_limit_text
    from ._montecarlo import max_keep_frames

    if len(config.modulation_frequencies_hz) > 1 and args.raw:
        raise ValueError("--raw writes one frequency's raw phase images: illumination_waveform."
                         f"extra_modulation_frequencies_hz = {config.values['illumination_waveform']['extra_modulation_frequencies_hz']}"
                         " makes several (render without --raw, or keep them in Python: tj.simulate(camera, scene, key, "
                         "frames, keep_frames=..., raw=True))")
    from ._timing import summary_lines

    timing = summary_lines(tj.Camera.from_config(config))  # refuses an impossible frame rate before any work
    geometry = builder(**kwargs) if builder is not None else None
    npz_bytes = check_size(name, geometry, settings, (rows, cols), mesh=mesh is not None)
    most = max_keep_frames(rows * cols, params.pixel.n_phases, args.raw)
    if args.keep_frames > most:
        raise ValueError(f"--keep-frames = {args.keep_frames} is out of range for {rows} x {cols} pixels: allowed 0 <= "
                         f"value <= {most} ({kept_limit_text()}; the statistics use every frame)")
    if args.check:
        if geometry is None and mesh is None:  # validate what the run would read
            load_npz_scene(name, params, settings, npz_bytes)
        print(f"plan: {args.frames} frames of {rows} x {cols} pixels ({rows * cols * args.frames * params.pixel.n_phases:.3g}"
              f" phase images) of scene {name}, {settings.subpixel_samples}^2 rays per pixel; into {args.out}")
        return 0
    on_interrupt(untouched_note(args.out))
    t0 = time.perf_counter()
    with Stages("render", enabled=not args.quiet) as stage, compiling(enabled=not args.quiet):
        if mesh is not None:
            stage(f"casting {settings.subpixel_samples}^2 rays per pixel of {rows} x {cols} pixels into {name} "
                  f"({len(triangles)} triangles, Open3D)")
            rho = float(params.scene.reflectivity) if args.reflectivity is None else args.reflectivity
            returns = jax.block_until_ready(renderer.returns(
                tj.Camera(params, settings), renderer.MeshScene([(vertices, triangles)], poses=[args.mesh_pose]),
                reflectivity=rho, sun_direction=args.sun))
        elif geometry is None:
            stage(f"reading {name}")
            returns = load_npz_scene(name, params, settings, npz_bytes)
        else:
            bounce = " and the two-bounce light" if getattr(geometry, "patches", None) is not None else ""
            stage(f"casting {settings.subpixel_samples}^2 rays per pixel of {rows} x {cols} pixels{bounce}")
            returns = jax.block_until_ready(tj.Camera(params, settings).returns(geometry, sun_direction=args.sun))
        pattern = tj.draw_pattern(params, settings, (rows, cols)) if args.fixed_pattern else None
        t1 = time.perf_counter()
        stage(f"{args.frames} Monte Carlo frames")
        # The camera of the configuration: its frequencies, its processing; once, for the frames and the analytic image.
        scene = tj.Camera.from_config(config, pattern=pattern).expose(returns)
        with reporting(Progress(1, f"render: {args.frames} frames", unit="chunk", enabled=not args.quiet)):
            frame = jax.device_get(scene.render(jax.random.key(args.seed), args.frames,
                                                keep_frames=args.keep_frames, raw=args.raw, progress=True))
        t2 = time.perf_counter()
        stage("the analytic noise image")
        predicted = jax.device_get(scene.predict())
        t3 = time.perf_counter()
        stage(f"writing {args.out}")
        arrays = frameio.frame_arrays(frame, predicted)
        if args.raw:
            arrays.update(frameio.raw_arrays(frame, params))
        source = str(args.config) if args.config else "built-in defaults"
        lines = [f"tofjax {tj.__version__}; configuration: {source}; scene {_scene_text(args)}; {rows} x {cols} pixels, "
                 f"{settings.subpixel_samples}^2 rays per pixel, {returns.path_m.shape[-1]} returns per pixel.",
                 f"{args.frames} Monte Carlo frames (seed {args.seed}); fixed pattern: "
                 f"{'drawn from frame.seed = ' + str(settings.seed) if args.fixed_pattern else 'off (the mean pixel)'}.",
                 f"Timing: scene {t1 - t0:.2f} s, frames {t2 - t1:.2f} s, analytic noise image {t3 - t2:.2f} s "
                 "(compilation included).", *timing]
        with output_dir(args.out, "tofjax render", args) as folder:
            written = frameio.write_frame(folder.staging, arrays, f"tofjax render: {name}", lines,
                                          tj.optics.intrinsics(params, settings))
    numbers = frameio.headlines(arrays)
    print(f"{rows} x {cols} pixels, {args.frames} frames in {t2 - t1:.2f} s; " + frameio.headline_text(numbers)
          + f"; {written['points']} points")
    print("\n".join(timing))
    print(f"wrote frame.npz, {len(written['pngs'])} PNGs, depth_mm.png and amplitude.png (16-bit), points.ply, "
          f"intrinsics.json and report.html to {args.out}")
    return 0


def _scene_text(args) -> str:
    """The scene as the report names it."""
    if args.mesh is None:
        return args.scene
    pose = ",".join(f"{x:g}" for x in (args.mesh_pose or (0,) * 6))
    rho = "scene.reflectivity" if args.reflectivity is None else f"{args.reflectivity:g}"
    return f"mesh {args.mesh} (pose {pose}, reflectivity {rho}; Open3D)"
