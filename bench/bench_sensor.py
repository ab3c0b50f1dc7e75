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
  key)`` (the sensor's floor: its step draws the same frame);
- ``mujoco_render``: MuJoCo's render of the same scene (the box on a slide joint, moved every step,
  ``mj_forward``), at the camera's intrinsics (``tofjax.renderers.mujoco.DepthCamera``: the
  segmentation and the depth pass, headless through ``MUJOCO_GL``, EGL by default: on a machine
  without a GPU Mesa's llvmpipe);
- ``loop``, ``loop_multipath``: the simulator's whole loop, MuJoCo's render and the sensor's step of
  it (``sensor.step(**render.step_arguments())``), without and with two-bounce light.

Every step after the first runs the compiled program (the cases' traces are counted after their
warm-up: none; tests/test_sensor.py asserts it).

Targets (issue 51): 224 x 172 >= 100 steps/s without multipath, >= 30 with it; 640 x 480 no slower
than MuJoCo's render of the same frame.

Run:  python bench/bench_sensor.py [--repeats 15] [--quick] [--out bench/results/bench_sensor.json] [--overwrite]
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
from pathlib import Path

os.environ.setdefault("MUJOCO_GL", "egl")  # headless, before MuJoCo is imported

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


def mujoco_scene():
    """tofjax's box_on_floor as MuJoCo geoms, the box on a slide joint along x, seen by camera "tof"
    at the origin (MuJoCo's camera looks along -z: tofjax's (x, y, z) is MuJoCo's (x, y, -z))."""
    import mujoco

    h, s, b, wall = 1.0, 0.5, 1.8, 3.0  # tofjax.scenes.box_on_floor's defaults: camera height, box size, distances
    xml = f"""<mujoco><worldbody><camera name="tof" fovy="45"/>
      <geom type="box" size="20 0.05 20" pos="0 {-h - 0.05} -10"/>
      <geom type="box" size="20 20 0.05" pos="0 0 {-wall - 0.05}"/>
      <body pos="0 {-h + s / 2} {-(b + s / 2)}"><joint name="x" type="slide" axis="1 0 0"/>
        <geom type="box" size="{s / 2} {s / 2} {s / 2}"/></body></worldbody></mujoco>"""
    model = mujoco.MjModel.from_xml_string(xml)
    return model, mujoco.MjData(model)


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
    import mujoco

    from tofjax.renderers import mujoco as tmj

    model, data = mujoco_scene()
    view = tmj.DepthCamera(model, "tof", tofjax_camera=cam)

    def render(i):
        data.qpos[0] = 0.02 * (i % BUFFERS) - 0.08
        mujoco.mj_forward(model, data)
        return view.render(data)

    cases.update({
        "mujoco_render": render,
        "loop": lambda i: sensor.step(**render(i).step_arguments()),
        "loop_multipath": lambda i: sensor.step(**render(i).step_arguments(), multipath=True),
    })
    traces = []

    def listen(event, duration, **kwargs):
        if event == "/jax/core/compile/jaxpr_trace_duration":
            traces.append(kwargs.get("fun_name"))

    for fn in cases.values():  # compile every case, then count what the timed steps trace
        fn(-1)
    jax.monitoring.register_event_duration_secs_listener(listen)
    try:
        t = interleaved(cases, repeats)
    finally:
        jax.monitoring.unregister_event_duration_listener(listen)
        view.close()
    return {"seconds": t, "steps_per_s": {k: 1.0 / v for k, v in t.items()},
            "ratios": {"step/tofjax_sample": t["step"] / t["tofjax_sample"],
                       "step_multipath/step": t["step_multipath"] / t["step"],
                       "step_resampled/step": t["step_resampled"] / t["step"],
                       "step_moving/step": t["step_moving"] / t["step"],
                       "step/mujoco_render": t["step"] / t["mujoco_render"],
                       "loop/mujoco_render": t["loop"] / t["mujoco_render"]},
            "traces_after_warm_up": traces,
            "multipath_patches": sensor.options["multipath_patches"], "pixels": rows * cols}


def table(r: dict) -> str:
    lines = [f"{'case':<32}{'steps/s':>10}{'ms':>9}  {'ratio':<34}target"]
    targets = {("224x172", "step"): ">= 100", ("224x172", "step_multipath"): ">= 30"}
    ratio_of = {"step": "step/tofjax_sample", "step_multipath": "step_multipath/step",
                "step_resampled": "step_resampled/step", "step_moving": "step_moving/step",
                "loop": "loop/mujoco_render"}
    targets[("640x480", "step")] = "<= mujoco_render's time"
    for name in ("sensor_224x172", "sensor_640x480"):
        if name not in r:
            continue
        c, size = r[name], name[7:]
        for kind in ("step", "step_multipath", "step_resampled", "step_moving", "tofjax_sample", "mujoco_render",
                     "loop", "loop_multipath"):
            key = ratio_of.get(kind)
            ratio = f"{c['ratios'][key]:.2f} ({key})" if key else ""
            lines.append(f"{size + ' ' + kind:<32}{c['steps_per_s'][kind]:>10.1f}{1e3 * c['seconds'][kind]:>9.2f}  "
                         f"{ratio:<34}{targets.get((size, kind), '')}")
        lines.append(f"{size} traces after the warm-up (a compile): {len(c['traces_after_warm_up'])}")
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--repeats", type=int, default=15)
    parser.add_argument("--quick", action="store_true", help="224 x 172 only")
    parser.add_argument("--out", type=Path, default=Path(__file__).parent / "results" / "bench_sensor.json")
    parser.add_argument("--overwrite", action="store_true", help="replace an existing --out")
    args = parser.parse_args()
    if args.out.exists() and not args.overwrite:
        parser.error(f"{args.out} exists: give --overwrite to replace it")
    results = {"platform": platform.platform(), "cpu_count": os.cpu_count(), "jax": jax.__version__,
               "numpy": np.__version__, "device": str(jax.devices()[0]), "repeats": args.repeats,
               "load_average": os.getloadavg()}
    results["sensor_224x172"] = case((172, 224), args.repeats)
    if not args.quick:
        results["sensor_640x480"] = case((480, 640), max(5, args.repeats // 2))
    print(table(results))
    args.out.parent.mkdir(parents=True, exist_ok=True)
    partial = args.out.with_name(f".{args.out.name}.partial-{os.getpid()}")
    partial.write_text(json.dumps(results, indent=2))
    os.replace(partial, args.out)  # whole or not at all
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
