"""Frames at the device's floor (issue 35): the table of the issue on whatever devices JAX sees (a
CPU, or a GPU when ``jax.devices()`` lists one), its cases interleaved, medians and per-frame
ratios printed and written as JSON. Never part of CI: run it by hand, on the CPU always and on a
GPU whenever one is lent.

The scene is a wall tilted by 30 degrees at 1.2 m, 3 x 3 rays per pixel (9 returns per pixel), its
returns computed once. Cases (per call; "per frame" divides by the frames of the call):

- ``one``: one noisy frame of the exposed scene per call (``camera.expose(returns).sample(key, 1)``);
- ``one_in_jit``: the same work inside one outer ``jax.jit`` (what one call could cost);
- ``dispatch_floor``: one trivial jitted kernel (``x + 1`` on a scalar): the cost of any call;
- ``batch``: 32 frames per call (``sample(key, 32)``), per frame; ``batch32_float32`` the same of a
  float32 camera (``camera.astype("float32")``, issue 35 item 4: float64 / float32 printed);
- ``noise_image`` and ``noise_image_float32``: the exposed scene's noise image in both precisions;
- ``vmap_keys``: ``jax.vmap`` of ``sample(k, 1)`` over 64 keys in one ``jit``, per frame;
- at 224 x 172 also ``batch64`` and ``vmap64`` (64 frames each way);
- ``noise_images_vmap`` / ``noise_images_map`` / ``noise_images_sharded``: the noise images of 64 walls
  at different distances, the camera prepared outside, by ``jax.vmap``, ``jax.lax.map`` and
  ``tj.parallel.sharded_map`` (per image);
- ``noise_images_readme``: the README's scale-out example as it stood before issue 35
  (``tj.predict(camera, wall(d))`` inside the mapped function: the camera prepared per image) and as
  it stands (``prepared.noise_image(camera.returns(wall(d)))``), per image;
- ``mc_sweep``: the default Monte Carlo sweep, 1000 samples x 2000 frames x 4 phases;
- ``predict_1e6``: ``tj.predict`` of 1e6 operating points.

Run:  python bench/bench_device.py [--repeats 5] [--quick] [--out bench/results/bench_device.json]
(``--quick``: 224 x 172 only and fewer repeats; ``XLA_FLAGS=--xla_force_host_platform_device_count=2``
splits a CPU into two devices for the sharded case.)
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
from pathlib import Path

import equinox as eqx
import jax
import jax.numpy as jnp

import tofjax as tj
from tofjax import scenes

sys.path.insert(0, str(Path(__file__).parent))
from bench import interleaved, ready  # noqa: E402

PITCH = 17.5e-6
WALLS = 64


def camera_of(rows: int, cols: int) -> tj.Camera:
    p = eqx.tree_at(lambda q: q.camera.optical_area_m, tj.Params(), jnp.array([cols * PITCH, rows * PITCH]))
    return tj.Camera(p, tj.FrameSettings())


def frame_cases(rows: int, cols: int, big_batches: bool) -> tuple[dict, dict]:
    """The per-call cases of one array size and the frames (or images) each call makes."""
    cam = camera_of(rows, cols)
    returns = ready(cam.returns(scenes.tilted_plane(1.2, 30.0)))
    exposed = ready(cam.expose(returns))
    one_in_jit = jax.jit(lambda k: exposed.sample(k, 1).radial_m)
    vmap64 = jax.jit(jax.vmap(lambda k: exposed.sample(k, 1).radial_m))
    exposed32 = ready(cam.astype("float32").expose(returns))  # the same scene, frames in float32
    cases = {
        "one": lambda i: ready(exposed.sample(jax.random.key(i + 3), 1).radial_m),
        "one_in_jit": lambda i: ready(one_in_jit(jax.random.key(i + 3))),
        "batch32": lambda i: ready(exposed.sample(jax.random.key(i + 3), 32).radial_m),
        "vmap_keys64": lambda i: ready(vmap64(jax.random.split(jax.random.key(i + 3), 64))),
        "batch32_float32": lambda i: ready(exposed32.sample(jax.random.key(i + 3), 32).radial_m),
        "noise_image": lambda i: ready(exposed.noise_image()),
        "noise_image_float32": lambda i: ready(exposed32.noise_image()),
    }
    per_call = {"one": 1, "one_in_jit": 1, "batch32": 32, "vmap_keys64": 64, "batch32_float32": 32,
                "noise_image": 1, "noise_image_float32": 1}
    if big_batches:
        cases["batch64"] = lambda i: ready(exposed.sample(jax.random.key(i + 3), 64).radial_m)
        per_call["batch64"] = 64
    return cases, per_call


def noise_image_cases() -> tuple[dict, dict]:
    """Noise images of 64 walls of a 224 x 172 camera, the camera prepared outside."""
    cam = camera_of(172, 224)
    prepared = ready(cam.prepare())
    distances = jnp.linspace(0.5, 4.0, WALLS)

    def image(d):
        return prepared.noise_image(cam.returns(scenes.wall(d)))

    by_vmap = jax.jit(jax.vmap(image))
    by_map = jax.jit(lambda ds: jax.lax.map(image, ds))
    readme_before = lambda ds: tj.parallel.sharded_map(lambda d: tj.predict(cam, scenes.wall(d)).depth_std_m, ds)  # noqa: E731
    cases = {
        "noise_images_vmap": lambda i: ready(by_vmap(distances)),
        "noise_images_map": lambda i: ready(by_map(distances)),
        "noise_images_sharded": lambda i: ready(tj.parallel.sharded_map(image, distances)),
        "noise_images_readme_before": lambda i: ready(readme_before(distances[:8])),
    }
    return cases, {"noise_images_vmap": WALLS, "noise_images_map": WALLS, "noise_images_sharded": WALLS,
                   "noise_images_readme_before": 8}


def sweep_cases() -> tuple[dict, dict]:
    params = tj.Params()
    sweep = tj.Config().sweep("distance", samples=1000)
    points = tj.Sweep.linspace("distance", 0.5, 4.5, 1_000_000)
    return ({"mc_sweep_1000x2000": lambda i: ready(tj.simulate(params, sweep, jax.random.key(i), 2000).depth_std_m),
             "predict_1e6": lambda i: ready(tj.predict(params, points).depth_std_m)},
            {"mc_sweep_1000x2000": 1, "predict_1e6": 1})


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--quick", action="store_true", help="224 x 172 only, 3 repeats")
    parser.add_argument("--out", type=Path, default=Path(__file__).parent / "results" / "bench_device.json")
    args = parser.parse_args(argv)
    repeats = 3 if args.quick else args.repeats
    floor = jax.jit(lambda x: x + 1.0)
    zero = jnp.zeros(())
    groups = {"224x172": frame_cases(172, 224, True)}
    if not args.quick:
        groups["640x480"] = frame_cases(480, 640, False)
    groups["noise_images"] = noise_image_cases()
    groups["sweeps"] = sweep_cases()
    groups["floor"] = ({"dispatch_floor": lambda i: ready(floor(zero))}, {"dispatch_floor": 1})
    results = {}
    for group, (cases, per_call) in groups.items():
        times = interleaved(cases, repeats)
        results[group] = {name: {"s_per_call": t, "per_call": per_call[name], "us_per_item": 1e6 * t / per_call[name],
                                 "items_per_s": per_call[name] / t} for name, t in times.items()}
    device = jax.devices()[0]
    print(f"devices: {len(jax.devices())} x {device.device_kind} ({device.platform}); jax {jax.__version__}; "
          f"{platform.processor() or platform.machine()}, {os.cpu_count()} CPUs")
    floor_us = results["floor"]["dispatch_floor"]["us_per_item"]
    print(f"{'case':34s} {'per call':>11s} {'per item':>11s} {'items/s':>10s}  ratio")
    for group, rows in results.items():
        base = {"224x172": "vmap_keys64", "640x480": "vmap_keys64", "noise_images": "noise_images_map"}.get(group)
        for name, r in rows.items():
            if group in ("224x172", "640x480") and name == "one":
                ratio = f"{r['us_per_item'] / rows['one_in_jit']['us_per_item']:.2f}x the outer jit"
            elif name.endswith("_float32"):  # float32 against the same work in float64
                twin = name.removesuffix("_float32")
                ratio = f"float64 / float32 = {rows[twin]['us_per_item'] / r['us_per_item']:.2f}x"
            elif name == "noise_image":
                ratio = ""
            elif base and name != base:
                ratio = f"{r['us_per_item'] / rows[base]['us_per_item']:.2f}x {base}"
            elif name == "dispatch_floor":
                ratio = ""
            else:
                ratio = f"{r['us_per_item'] / floor_us:.0f}x the dispatch floor" if r["per_call"] == 1 else ""
            print(f"{group + ' ' + name:34s} {1e3 * r['s_per_call']:9.3f}ms {r['us_per_item']:9.1f}us "
                  f"{r['items_per_s']:10.1f}  {ratio}")
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps({"device": str(device), "platform": device.platform, "devices": len(jax.devices()),
                                    "jax": jax.__version__, "cpus": os.cpu_count(), "repeats": repeats,
                                    "results": results}, indent=2) + "\n")
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
