"""Frames at the device's floor (issue 35): the table of the issue on whatever devices JAX sees (a
CPU, or a GPU when ``jax.devices()`` lists one), its cases interleaved, medians and per-frame
ratios printed and written as JSON. Never part of CI: run it by hand, on the CPU always and on a
GPU whenever one is lent.

The scene is a wall tilted by 30 degrees at 1.2 m, 3 x 3 rays per pixel (9 returns per pixel), its
returns computed once. The calls' keys are made before the timing (:data:`KEYS`). Every frame case
returns and waits for whole :class:`tofjax.NoisyFrames` (radial distance, amplitude, validity), the
outer-``jit`` and ``vmap`` ones included, so that each does the same work. Cases (per call; "per
frame" divides by the frames of the call):

- ``one``: one noisy frame of the exposed scene per call (``camera.expose(returns).sample(key, 1)``);
- ``one_in_jit``: the same work inside one outer ``jax.jit`` that takes the exposure as its argument
  (what one call could cost: a caller's loop body); ``one_in_jit_closed``: the same with the exposure
  closed over, its arrays constants of the program (XLA then folds the camera's parameters into it:
  another program, not the same work); ``one_stream``: ``STREAM`` such calls in a row, per frame (a
  live view; a single call after other cases runs with the device's caches and clocks as they left it);
- ``dispatch_floor``: one trivial jitted kernel (``x + 1`` on a scalar): the cost of any call;
- ``batch``: 32 frames per call (``sample(key, 32)``), per frame; ``batch32_float32`` the same of a
  float32 camera (``camera.astype("float32")``, issue 35 item 4: float64 / float32 printed);
- ``noise_image`` and ``noise_image_float32``: the exposed scene's noise image in both precisions;
- ``vmap_keys``: ``jax.vmap`` of ``sample(k, 1)`` over 64 keys in one ``jit``, per frame;
- at 224 x 172 also ``batch64`` and ``vmap64`` (64 frames each way); on a GPU also ``batch128`` and
  ``batch256`` at both sizes;
- ``noise_images_vmap`` / ``noise_images_map`` / ``noise_images_sharded``: the noise images of 64 walls
  at different distances, the camera prepared outside, by ``jax.vmap``, ``jax.lax.map`` and
  ``tj.parallel.sharded_map`` (per image);
- ``noise_images_vmap_float32``: the same by ``jax.vmap`` of a float32 camera; on a GPU also 256 walls
  per call (``noise_images_vmap256``, and of the float32 camera);
- ``noise_images_readme``: the README's scale-out example as it stood before issue 35
  (``tj.predict(camera, wall(d))`` inside the mapped function: the camera prepared per image) and as
  it stands (``prepared.noise_image(camera.returns(wall(d)))``), per image;
- ``mc_sweep``: the default Monte Carlo sweep, 1000 samples x 2000 frames x 4 phases;
- ``predict_1e6``: ``tj.predict`` of 1e6 operating points;
- with ``--chunks``, at 640 x 480: ``sample(key, 32)`` and ``sample(key, 64)`` with the frames drawn
  in chunks of 2^21 (a CPU's: one frame), 2^24, 2^26 and 2^27 phase images, per frame, and each
  program's peak temporary memory per phase image (what ``tofjax._executor.chunk_elements`` sizes an
  accelerator's chunks by).

``--trace DIR`` also writes a Perfetto trace (``jax.profiler``) of three calls each of one frame at
640 x 480, 32 frames at 640 x 480, the 224 x 172 noise image and the 64 walls' noise images by
``vmap``: the kernels each runs and their times (``bench/trace_summary.py`` reads them).

Run:  python bench/bench_device.py [--repeats 5] [--quick] [--chunks] [--trace DIR] [--out bench/results/bench_device.json]
(``--quick``: 224 x 172 only and fewer repeats; ``XLA_FLAGS=--xla_force_host_platform_device_count=2``
splits a CPU into two devices for the sharded case.)
"""

from __future__ import annotations

import argparse
import functools
import json
import os
import platform
import sys
from pathlib import Path

import equinox as eqx
import jax
import jax.numpy as jnp

import tofjax as tj
from tofjax import _executor, scenes

sys.path.insert(0, str(Path(__file__).parent))
from bench import interleaved, ready  # noqa: E402

PITCH = 17.5e-6
WALLS = 64
#: The keys of the calls, made before any timing (a new key is a program of its own: 0.3 ms on an
#: H200, as much as a frame): ``KEYS[i + 1]`` for repeat ``i`` (-1 warms up), ``SPLIT64`` 64 keys each.
KEYS: list = []
SPLIT64: list = []
#: Calls in a row of the ``one_stream`` case (a live view: one frame per call, call after call).
STREAM = 10


def make_keys(repeats: int) -> None:
    """Fill :data:`KEYS` and :data:`SPLIT64` for ``repeats`` repeats and the warm-up."""
    KEYS[:] = [ready(jax.random.key(i + 3)) for i in range(repeats + 1)]
    SPLIT64[:] = [ready(jax.random.split(k, 64)) for k in KEYS]


def camera_of(rows: int, cols: int) -> tj.Camera:
    p = eqx.tree_at(lambda q: q.camera.optical_area_m, tj.Params(), jnp.array([cols * PITCH, rows * PITCH]))
    return tj.Camera(p, tj.FrameSettings())


def frame_cases(rows: int, cols: int, big_batches: bool) -> tuple[dict, dict]:
    """The per-call cases of one array size and the frames (or images) each call makes."""
    cam = camera_of(rows, cols)
    returns = ready(cam.returns(scenes.tilted_plane(1.2, 30.0)))
    exposed = ready(cam.expose(returns))
    # Every case returns the whole NoisyFrames (radial distance, amplitude, validity) and waits for it:
    # an outer jit that returns the radial distance alone lets XLA drop the amplitude and the validity,
    # less work than the public call does (224 x 172 on the CPU: 1.3x faster, not a smaller overhead).
    one_in_jit = jax.jit(lambda e, k: e.sample(k, 1))
    one_in_jit_closed = jax.jit(lambda k: exposed.sample(k, 1))
    vmap64 = jax.jit(jax.vmap(lambda k: exposed.sample(k, 1)))
    exposed32 = ready(cam.astype("float32").expose(returns))  # the same scene, frames in float32
    cases = {
        "one": lambda i: ready(exposed.sample(KEYS[i + 1], 1)),
        "one_in_jit": lambda i: ready(one_in_jit(exposed, KEYS[i + 1])),
        "one_in_jit_closed": lambda i: ready(one_in_jit_closed(KEYS[i + 1])),
        "one_stream": lambda i: [ready(exposed.sample(KEYS[(i + 1 + j) % len(KEYS)], 1)) for j in range(STREAM)],
        "batch32": lambda i: ready(exposed.sample(KEYS[i + 1], 32)),
        "vmap_keys64": lambda i: ready(vmap64(SPLIT64[i + 1])),
        "batch32_float32": lambda i: ready(exposed32.sample(KEYS[i + 1], 32)),
        "noise_image": lambda i: ready(exposed.noise_image()),
        "noise_image_float32": lambda i: ready(exposed32.noise_image()),
    }
    per_call = {"one": 1, "one_in_jit": 1, "one_in_jit_closed": 1, "one_stream": STREAM, "batch32": 32,
                "vmap_keys64": 64, "batch32_float32": 32,
                "noise_image": 1, "noise_image_float32": 1}
    if big_batches:
        cases["batch64"] = lambda i: ready(exposed.sample(KEYS[i + 1], 64))
        per_call["batch64"] = 64
    if jax.devices()[0].platform != "cpu":  # the batch target on a GPU (4 s a call on a 2-core CPU)
        for n in (128, 256):
            cases[f"batch{n}"] = functools.partial(lambda n, i: ready(exposed.sample(KEYS[i + 1], n)), n)
            per_call[f"batch{n}"] = n
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
    cam32 = cam.astype("float32")
    prepared32 = ready(cam32.prepare())
    by_vmap32 = jax.jit(jax.vmap(lambda d: prepared32.noise_image(cam32.returns(scenes.wall(d)))))
    distances32 = distances.astype(jnp.float32)
    readme_before = lambda ds: tj.parallel.sharded_map(lambda d: tj.predict(cam, scenes.wall(d)).depth_std_m, ds)  # noqa: E731
    cases = {
        "noise_images_vmap": lambda i: ready(by_vmap(distances)),
        "noise_images_map": lambda i: ready(by_map(distances)),
        "noise_images_vmap_float32": lambda i: ready(by_vmap32(distances32)),
        "noise_images_sharded": lambda i: ready(tj.parallel.sharded_map(image, distances)),
        "noise_images_readme_before": lambda i: ready(readme_before(distances[:8])),
    }
    per_call = {"noise_images_vmap": WALLS, "noise_images_map": WALLS, "noise_images_sharded": WALLS,
                "noise_images_vmap_float32": WALLS, "noise_images_readme_before": 8}
    if jax.devices()[0].platform != "cpu":  # 256 scenes per call: the batch's fixed cost shared further
        many = jnp.linspace(0.5, 4.0, 4 * WALLS)
        many32 = many.astype(jnp.float32)
        cases["noise_images_vmap256"] = lambda i: ready(by_vmap(many))
        cases["noise_images_vmap256_float32"] = lambda i: ready(by_vmap32(many32))
        per_call["noise_images_vmap256"] = per_call["noise_images_vmap256_float32"] = 4 * WALLS
    return cases, per_call


def sampled_in_chunks(exposed, frames: int, elements: int):
    """``exposed.sample(key, frames).radial_m`` as one program of its own whose frames are drawn in
    chunks of ``elements`` phase images (the chunk is fixed when the program is traced)."""
    from tofjax import _frame

    def radial(e, key):
        saved = _frame.frame_chunk_elements
        _frame.frame_chunk_elements = lambda: elements
        try:
            return _frame._sample_prepared.__wrapped__(e.chain, e.prepared.consts, key, frames, e.shape).radial_m
        finally:
            _frame.frame_chunk_elements = saved

    return eqx.filter_jit(radial)


def chunk_cases(rows: int, cols: int) -> tuple[dict, dict, dict]:
    """``sample(key, 32 | 64)`` in chunks of 2^21 .. 2^27 phase images, and each program's peak
    temporary bytes per phase image."""
    cam = camera_of(rows, cols)
    exposed = ready(cam.expose(ready(cam.returns(scenes.tilted_plane(1.2, 30.0)))))
    cases, per_call, memory = {}, {}, {}
    for frames in (32, 64):
        for log2 in (21, 24, 26, 27):
            name = f"sample{frames}_chunks_2^{log2}"
            fn = sampled_in_chunks(exposed, frames, 1 << log2)
            cases[name] = functools.partial(lambda fn, i: ready(fn(exposed, KEYS[i + 1])), fn)
            per_call[name] = frames
            if log2 < 26:  # the large chunks only, near what an accelerator takes (2^27 on an H100, 2^28 on an H200)
                continue
            try:
                analysis = fn.lower(exposed, jax.random.key(0)).compile().compiled.memory_analysis()
                memory[name] = analysis.temp_size_in_bytes / (frames * rows * cols * cam.params.pixel.n_phases)
            except Exception as error:  # noqa: BLE001 - the bench reports what it could not read
                memory[name] = f"{type(error).__name__}: {error}"
    return cases, per_call, memory


def write_traces(folder: Path) -> None:
    """Perfetto traces of three calls each of the heavy cases (module docstring)."""
    big = camera_of(480, 640)
    exposed = ready(big.expose(ready(big.returns(scenes.tilted_plane(1.2, 30.0)))))
    small = camera_of(172, 224)
    exposed_small = ready(small.expose(ready(small.returns(scenes.tilted_plane(1.2, 30.0)))))
    prepared = ready(small.prepare())
    by_vmap = jax.jit(jax.vmap(lambda d: prepared.noise_image(small.returns(scenes.wall(d)))))
    distances = jnp.linspace(0.5, 4.0, WALLS)
    cases = {"one_640x480": lambda i: ready(exposed.sample(KEYS[i + 1], 1)),
             "batch32_640x480": lambda i: ready(exposed.sample(KEYS[i + 1], 32)),
             "noise_image_224x172": lambda i: ready(exposed_small.noise_image()),
             "noise_images_vmap64": lambda i: ready(by_vmap(distances))}
    for name, fn in cases.items():
        fn(0)
        with jax.profiler.trace(str(folder / name), create_perfetto_trace=True):
            for i in range(3):
                fn(i + 1)


def sweep_cases() -> tuple[dict, dict]:
    params = tj.Params()
    sweep = tj.Config().sweep("distance", samples=1000)
    points = tj.Sweep.linspace("distance", 0.5, 4.5, 1_000_000)
    return ({"mc_sweep_1000x2000": lambda i: ready(tj.simulate(params, sweep, jax.random.key(i), 2000).depth_std_m),
             "predict_1e6": lambda i: ready(tj.predict(params, points).depth_std_m)},
            {"mc_sweep_1000x2000": 1, "predict_1e6": 1})


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--quick", action="store_true", help="224 x 172 only, 3 repeats")
    parser.add_argument("--chunks", action="store_true", help="640 x 480 batches in chunks of 2^21 .. 2^27")
    parser.add_argument("--trace", type=Path, help="write Perfetto traces of the heavy cases into this folder")
    parser.add_argument("--out", type=Path, default=Path(__file__).parent / "results" / "bench_device.json")
    args = parser.parse_args(argv)
    print(f"devices: {jax.devices()}; frame chunks of {_executor.frame_chunk_elements()} phase images", flush=True)
    repeats = 3 if args.quick else args.repeats
    make_keys(max(repeats, 4))  # write_traces' calls use the first four
    floor = jax.jit(lambda x: x + 1.0)
    zero = jnp.zeros(())
    groups = {"224x172": frame_cases(172, 224, True)}
    if not args.quick:
        groups["640x480"] = frame_cases(480, 640, False)
    groups["noise_images"] = noise_image_cases()
    chunk_memory = {}
    if args.chunks:
        cases, per_call, chunk_memory = chunk_cases(480, 640)
        groups["640x480 chunks"] = (cases, per_call)
    groups["sweeps"] = sweep_cases()
    groups["floor"] = ({"dispatch_floor": lambda i: ready(floor(zero))}, {"dispatch_floor": 1})
    results = {}
    for group, (cases, per_call) in groups.items():
        times = interleaved(cases, repeats)
        results[group] = {name: {"s_per_call": t, "per_call": per_call[name], "us_per_item": 1e6 * t / per_call[name],
                                 "items_per_s": per_call[name] / t} for name, t in times.items()}
        print(f"{group}: " + ", ".join(f"{name} {1e6 * t / per_call[name]:.1f} us" for name, t in times.items()),
              flush=True)  # as it goes: a run stopped at its limit keeps what it measured
    for name, per_element in chunk_memory.items():
        results["640x480 chunks"][name]["temp_bytes_per_phase_image"] = per_element
    if args.trace:
        write_traces(args.trace)
    device = jax.devices()[0]
    print(f"devices: {len(jax.devices())} x {device.device_kind} ({device.platform}); jax {jax.__version__}; "
          f"{platform.processor() or platform.machine()}, {os.cpu_count()} CPUs")
    floor_us = results["floor"]["dispatch_floor"]["us_per_item"]
    print(f"{'case':34s} {'per call':>11s} {'per item':>11s} {'items/s':>10s}  ratio")
    for group, rows in results.items():
        base = {"224x172": "vmap_keys64", "640x480": "vmap_keys64", "noise_images": "noise_images_map",
                "640x480 chunks": "sample32_chunks_2^21"}.get(group)
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
            if "temp_bytes_per_phase_image" in r:
                per = r["temp_bytes_per_phase_image"]
                ratio += f"; temp {per:.0f} B/phase image" if isinstance(per, float) else f"; {per}"
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
