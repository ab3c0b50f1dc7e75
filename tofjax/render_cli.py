"""``tofjax render``: full frames of a scene (docs/model.md, "Full frames").

Writes into ``--out DIR``: ``frame.npz`` (every image, and the kept frames), PNG colour maps with
colour bars, ``points.ply`` (the good pixels' point cloud) and a self-contained ``report.html``.
"""

from __future__ import annotations

import math
import sys
import time
from pathlib import Path


def register(subparsers) -> None:
    from .cli import positive_int  # loaded already: cli registers this command

    p = subparsers.add_parser(
        "render", help="render full frames of a scene: depth, noise image, amplitude, point cloud",
        description="Monte Carlo frames of every pixel of the camera looking at a scene, with the analytic "
                    "noise image beside them. --scene is a built-in scene, NAME or NAME:key=value,... "
                    "(wall, tilted_plane, step_edge, box_on_floor, sphere, corner), or an NPZ file: a depth map "
                    "(z_m or radial_m, optional reflectivity) or returns (path_m, radiance_per_w: the output "
                    "of a transient renderer, docs/model.md). The operating point is the configuration's "
                    "scene.illuminance_lx and scene.integration_time_s; [frame] sets the array's optics and "
                    "fixed pattern.")
    p.add_argument("--scene", required=True, help="NAME[:key=value,...] or FILE.npz (default parameters: "
                                                  "tofjax.scenes)")
    p.add_argument("--config", type=Path, help="TOML configuration (default: built-in defaults)")
    p.add_argument("--frames", type=positive_int, default=100, help="Monte Carlo frames (default 100)")
    p.add_argument("--keep-frames", type=_non_negative_int, default=1,
                   help="frames to keep whole in frame.npz (default 1; at most --frames)")
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
    p.set_defaults(run=run)


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


def parse_scene(text: str):
    """``NAME`` or ``NAME:key=value,...`` -> (builder, name, keyword arguments), or a path to an NPZ
    file -> (None, path, {}). Raises ``ValueError`` with one line naming the scene, key and range."""
    from ._schema import suggest
    from ._scene import BUILTIN_SCENES

    if text.lower().endswith(".npz"):
        path = Path(text)
        if not path.is_file():
            raise ValueError(f"--scene {text}: no such file")
        return None, text, {}
    name, _, rest = text.partition(":")
    if name not in BUILTIN_SCENES:
        raise ValueError(f"--scene {name!r} is not a built-in scene: allowed {', '.join(BUILTIN_SCENES)} or a "
                         "FILE.npz" + suggest(name, BUILTIN_SCENES))
    builder, ranges = BUILTIN_SCENES[name]
    kwargs = {}
    for item in filter(None, rest.split(",")):
        key, eq, value = item.partition("=")
        key = key.strip()
        if key not in ranges:
            raise ValueError(f"--scene {name}: {key!r} is not a parameter of {name}: allowed "
                             + ", ".join(ranges) + suggest(key, ranges))
        try:
            x = float(value) if eq else float("nan")
        except ValueError:
            x = float("nan")
        lo, hi = ranges[key]
        if not (math.isfinite(x) and lo <= x <= hi):
            raise ValueError(f"--scene {name}: {key} = {value.strip() or '(empty)'!s} is out of range: allowed "
                             f"{lo:g} <= value <= {hi:g}")
        kwargs[key] = x
    return builder, name, kwargs


def _load_npz_scene(path: str, params, settings):
    import numpy as np

    import tofjax as tj

    try:
        with np.load(path, allow_pickle=False) as data:
            names = set(data.files)
            arrays = {k: np.asarray(data[k]) for k in names if k in ("z_m", "radial_m", "reflectivity")}
    except (OSError, ValueError) as err:
        raise ValueError(f"--scene {path}: not a readable NPZ file ({err})") from None
    shape = tj.frame_shape(params)
    if "path_m" in names:
        return tj.load_returns(path, shape)
    key = "z_m" if "z_m" in arrays else "radial_m" if "radial_m" in arrays else None
    if key is None:
        raise ValueError(f"--scene {path}: holds neither returns (path_m, radiance_per_w) nor a depth map (z_m or "
                         f"radial_m); found {', '.join(sorted(names)) or 'nothing'}")
    depth = arrays[key].astype(float)
    rho = arrays.get("reflectivity", np.asarray(float(params.scene.reflectivity))).astype(float)
    if depth.shape != shape:
        raise ValueError(f"--scene {path}: {key} has shape {depth.shape}, the camera {shape} (rows, cols)")
    if rho.shape not in ((), shape) or not np.all(np.isfinite(rho) & (rho >= 0) & (rho <= 1)):
        raise ValueError(f"--scene {path}: reflectivity must be a number or a {shape} map with 0 <= value <= 1")
    return tj.depth_returns(params, settings, depth, rho, radial=key == "radial_m")


def run(args) -> int:
    from .cli import check_output_dir

    builder, name, kwargs = parse_scene(args.scene)  # before JAX starts
    if args.keep_frames > args.frames:
        raise ValueError(f"--keep-frames = {args.keep_frames} is out of range: allowed 0 <= value <= --frames = "
                         f"{args.frames}")
    check_output_dir(args.out, "--out")
    import jax
    import numpy as np

    import tofjax as tj

    from . import frameio

    config = tj.load_config(args.config) if args.config else tj.Config()
    params, settings = config.params, config.frame
    rows, cols = tj.frame_shape(params)
    from ._montecarlo import check_counts

    check_counts(args.frames, args.keep_frames, rows * cols, params.pixel.n_phases)
    if args.check:
        print(f"plan: {args.frames} frames of {rows} x {cols} pixels ({rows * cols * args.frames * params.pixel.n_phases:.3g}"
              f" phase images) of scene {name}, {settings.subpixel_samples}^2 rays per pixel; into {args.out}")
        return 0
    t0 = time.perf_counter()
    if builder is None:
        returns = _load_npz_scene(name, params, settings)
    else:
        returns = tj.scene_returns(params, settings, builder(**kwargs), sun_direction=args.sun)
    pattern = tj.draw_pattern(params, settings, (rows, cols)) if args.fixed_pattern else None
    t1 = time.perf_counter()
    if not args.quiet:
        print(f"rendering {args.frames} frames of {rows} x {cols} pixels ...", file=sys.stderr, flush=True)
    scene = tj.prepare_frame(params, settings, returns, pattern)  # exposed once, for the frames and the analytic image
    frame = jax.device_get(scene.render(jax.random.key(args.seed), args.frames, keep_frames=args.keep_frames,
                                        progress=not args.quiet))
    t2 = time.perf_counter()
    predicted = jax.device_get(scene.predict())
    t3 = time.perf_counter()
    arrays = frameio.frame_arrays(frame, predicted)
    frameio.write_npz(args.out / "frame.npz", arrays)
    pngs = frameio.write_maps(args.out, arrays)
    keep = (arrays["flags"] == 0) & np.isfinite(arrays["radial_m"])
    cloud = arrays["radial_m"][keep][:, None] * arrays["direction"][keep]
    frameio.write_ply(args.out / "points.ply", cloud, arrays["intensity_e"][keep])
    source = str(args.config) if args.config else "built-in defaults"
    lines = [f"tofjax {tj.__version__}; configuration: {source}; scene {args.scene}; {rows} x {cols} pixels, "
             f"{settings.subpixel_samples}^2 rays per pixel, {returns.path_m.shape[-1]} returns per pixel.",
             f"{args.frames} Monte Carlo frames (seed {args.seed}); fixed pattern: "
             f"{'drawn from frame.seed = ' + str(settings.seed) if args.fixed_pattern else 'off (the mean pixel)'}.",
             f"Timing: scene {t1 - t0:.2f} s, frames {t2 - t1:.2f} s, analytic noise image {t3 - t2:.2f} s "
             "(compilation included)."]
    report = frameio.write_report(args.out, arrays, pngs, f"tofjax render: {name}", lines)
    numbers = frameio.headlines(arrays)
    print(f"{rows} x {cols} pixels, {args.frames} frames in {t2 - t1:.2f} s; good pixels "
          f"{100 * numbers['good_fraction']:.1f} %; median depth noise {numbers['median_depth_std_mm']:.3g} mm "
          f"(analytic {numbers.get('median_predicted_std_mm', float('nan')):.3g} mm); median |error| "
          f"{numbers['median_abs_error_mm']:.3g} mm; {len(cloud)} points")
    print(f"wrote frame.npz, {len(pngs)} PNGs, points.ply and {report.name} to {args.out}")
    return 0
