"""The stepped sensor (issue 51 item 4): steps per second of ``tofjax.sensor.ToFSensor`` on this
machine, cases interleaved (medians and ratios, as bench/bench_frame.py).

The simulator's frames: a box on a floor before a wall (tofjax's ``box_on_floor``), the box moved
sideways from step to step, ray-cast beforehand into planar depth buffers (8 of them, used in turn;
not timed: the simulator renders them). Each step is one call of ``sensor.step`` with one buffer,
the whole of what a simulator's loop pays: the buffer checked and moved to JAX, resampled onto the
camera's rays, its returns, one noisy frame with its flags and every output as NumPy arrays.

- ``step``: a buffer at the camera's own intrinsics (normals from the depth), no multipath;
- ``step_multipath``: the same with ``multipath=True`` (two-bounce light from the buffer, the
  sensor's default 128 patches, 8 returns per pixel);
- ``step_resampled``: a buffer of 1.5x the camera's resolution and a wider field (fov 100 x 80
  degrees), resampled onto the camera's rays;
- ``step_moving``: the camera's buffer with ``previous_depth`` (the motion over the phase images:
  16 instants, 16 returns per pixel);
- ``tofjax_sample``: tofjax's own frame of the same buffer, ``PreparedCamera.sample(camera.returns(depth),
  key)`` (the sensor's floor: its step draws the same frame).

Targets (issue 51): 224 x 172 >= 100 steps/s without multipath, >= 30 with it.

Run:  python bench/bench_sensor.py [--repeats 15] [--quick] [--out bench/results/bench_sensor.json]
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
import numpy as np

import tofjax as tj
from tofjax.sensor import ToFSensor

sys.path.insert(0, str(Path(__file__).parent))
from bench import interleaved, ready  # noqa: E402

PITCH = 17.5e-6
BUFFERS = 8


def camera(size: tuple[int, int]) -> tj.Camera:
    rows, cols = size
    p = eqx.tree_at(lambda q: q.camera.optical_area_m, tj.Params(), jnp.array([cols * PITCH, rows * PITCH]))
    return tj.Camera(p, tj.FrameSettings())


def buffers(intrinsics: dict) -> list[np.ndarray]:
    """Planar depth buffers of the box on the floor, the box moved 2 cm sideways per buffer (float32,
    as renderers give them)."""
    from tofjax._sensorbuffers import buffer_rays

    rays = jnp.asarray(buffer_rays({**intrinsics, "dist_coeffs": [0.0] * 5}))
    out = []
    for i in range(BUFFERS):
        scene = tj.scenes.box_on_floor().translated(jnp.array([0.02 * i - 0.08, 0.0, 0.0]))
        hit = scene.cast(rays)
        out.append(np.asarray(hit.t * rays[..., 2], dtype=np.float32))
    return out


def case(size: tuple[int, int], repeats: int) -> dict:
    rows, cols = size
    cam = camera(size)
    sensor = ToFSensor(cam, seed=1)
    own = buffers(sensor.intrinsics)
    wide = {"width": int(1.5 * cols), "height": int(1.5 * rows)}
    wide.update(fx=0.5 * wide["width"] / np.tan(np.radians(50.0)), fy=0.5 * wide["height"] / np.tan(np.radians(40.0)),
                cx=0.5 * (wide["width"] - 1), cy=0.5 * (wide["height"] - 1))
    other = buffers(wide)
    prepared = sensor.prepared
    cases = {
        "step": lambda i: sensor.step(own[i % BUFFERS]),
        "step_multipath": lambda i: sensor.step(own[i % BUFFERS], multipath=True),
        "step_resampled": lambda i: sensor.step(other[i % BUFFERS], intrinsics=wide),
        "step_moving": lambda i: sensor.step(own[i % BUFFERS], previous_depth=own[(i - 1) % BUFFERS]),
        "tofjax_sample": lambda i: np.asarray(ready(prepared.sample(sensor.camera.returns(own[i % BUFFERS]),
                                                                    jax.random.key(i + 3)).radial_m)),
    }
    t = interleaved(cases, repeats)
    return {"seconds": t, "steps_per_s": {k: 1.0 / v for k, v in t.items()},
            "ratios": {"step/tofjax_sample": t["step"] / t["tofjax_sample"],
                       "step_multipath/step": t["step_multipath"] / t["step"],
                       "step_resampled/step": t["step_resampled"] / t["step"],
                       "step_moving/step": t["step_moving"] / t["step"]},
            "multipath_patches": sensor.options["multipath_patches"], "pixels": rows * cols}


def table(r: dict) -> str:
    lines = [f"{'case':<32}{'steps/s':>10}{'ms':>9}  {'ratio':<34}target"]
    targets = {("224x172", "step"): ">= 100", ("224x172", "step_multipath"): ">= 30"}
    ratio_of = {"step": "step/tofjax_sample", "step_multipath": "step_multipath/step",
                "step_resampled": "step_resampled/step", "step_moving": "step_moving/step"}
    for name in ("sensor_224x172", "sensor_640x480"):
        if name not in r:
            continue
        c, size = r[name], name[7:]
        for kind in ("step", "step_multipath", "step_resampled", "step_moving", "tofjax_sample"):
            key = ratio_of.get(kind)
            ratio = f"{c['ratios'][key]:.2f} ({key})" if key else ""
            lines.append(f"{size + ' ' + kind:<32}{c['steps_per_s'][kind]:>10.1f}{1e3 * c['seconds'][kind]:>9.2f}  "
                         f"{ratio:<34}{targets.get((size, kind), '')}")
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=15)
    parser.add_argument("--quick", action="store_true", help="224 x 172 only")
    parser.add_argument("--out", type=Path, default=Path(__file__).parent / "results" / "bench_sensor.json")
    args = parser.parse_args()
    results = {"platform": platform.platform(), "cpu_count": os.cpu_count(), "jax": jax.__version__,
               "numpy": np.__version__, "device": str(jax.devices()[0]), "repeats": args.repeats,
               "load_average": os.getloadavg()}
    results["sensor_224x172"] = case((172, 224), args.repeats)
    if not args.quick:
        results["sensor_640x480"] = case((480, 640), max(5, args.repeats // 2))
    print(table(results))
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(results, indent=2))
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
