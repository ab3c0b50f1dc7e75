"""Full frames (issue 13): tofjax against a NumPy implementation of the same per-pixel chain and the
random-number floor, on this machine, in one run (cases interleaved, medians and ratios).

The scene is a wall tilted by 30 degrees at 1.2 m on the axis, 3 x 3 rays per pixel (9 returns per
pixel); its returns are computed once (not timed: a scene is rendered many times). Timed per call,
on both sides: the exposure of every pixel from its returns (the tabulated correlation of each
return, the phasor sum), then the noisy frames (noise, SBI, ADC, demodulation). The camera's own
constants (the correlation table, each pixel's etendue and conversion to electrons) are computed once
on both sides, as NumPy's ``NumpyFrame`` always did: a camera streaming a changing scene.

- ``one``: one noisy frame per call, the scene exposed in the same call (``camera.prepare()`` once,
  then its ``sample(returns, key, 1)``: the exposure and the frame's distance, amplitude and
  validity; NumPy: the same, one frame);
- ``sample_frame``: the same through ``camera.prepare().sample(returns, key, 1)`` in every call, which
  prepares the camera in every call too (no NumPy counterpart);
- ``moving_scene``: the scene ray-cast in every call too (``camera.returns`` of the plane, then the
  camera's ``sample``): a built-in scene that moves (no NumPy counterpart);
- ``render_one``: one frame through ``tj.simulate(camera, returns, key, 1, keep_frames=1)``, which also computes the
  per-pixel statistics of its frames (no NumPy counterpart);
- ``prepared``: one noisy frame per call of a scene exposed once (``camera.expose(returns)`` once, then
  ``.sample(key, 1)``: the frame only; NumPy: the expected charges once, then one frame per call):
  a live view or a stream of frames of a static scene;
- ``batch``: 32 noisy frames per call, all kept (``tj.simulate(camera, returns, key, 32, keep_frames=32)``; NumPy:
  the exposure once and 32 frames in one vectorised draw);
- ``floor``: only the normals each side draws for those 32 frames (tofjax: one Philox normal per
  phase image; NumPy: 4 PCG64 normals per phase image);
- ``analytic``: the analytic frame (``tj.predict(camera, returns)``: every field, the noise image among them),
  images per second; ``analytic_prepared``: the chain's share of it, after the exposure
  (``camera.expose(returns).predict()``);
- ``noise_image``: only the noise image (``camera.prepare().noise_image(returns)``: the camera, the exposure and the depth
  standard deviation, nothing else); ``noise_image_camera``: of a prepared camera
  (``PreparedCamera.noise_image(returns)``: the exposure and the chain); ``noise_image_depth_map``:
  the same for a depth map of the same plane (one return per pixel, ``camera.returns(depth_map)``);
  ``noise_image_prepared``: after the exposure (``PreparedFrame.noise_image()``), one call after another
  case, and ``noise_image_stream``: 10 such calls in a row (a stream of noise images, caches warm).

Targets (issue 13): 224 x 172 >= 100 frames/s and >= 2x NumPy; 640 x 480 >= 25 frames/s; the
analytic noise image of 224 x 172 >= 1000 images/s.

Run:  python bench/bench_frame.py [--repeats 7] [--quick] [--out bench/results/bench_frame.json]
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
from tofjax import scenes
from tofjax._random import key_words, normals
from tofjax._waveforms import waveform_mean

sys.path.insert(0, str(Path(__file__).parent))
from bench import interleaved, ready  # noqa: E402
from numpy_baseline import Baseline  # noqa: E402

BATCH = 32
#: Noise images in a row in the stream case (each timed case otherwise runs once per repeat, caches cold).
STREAM = 10
PITCH = 17.5e-6


class NumpyFrame:
    """The per-pixel chain in NumPy for a frame's returns: per-camera constants once (the baseline's
    noise and ADC, tofjax's etendue map and lamp integral, as the baseline takes its lamp integral)."""

    def __init__(self, params, settings, returns):
        self.base = Baseline(params)
        self.base.table()
        rays = tj.optics.frame_rays(params, settings, 1)
        etendue = np.asarray(tj.optics.pixel_etendue_m2_sr(params, settings, rays)).ravel()
        ill, k, pix, scene = params.illumination, params.constants, params.pixel, params.scene
        e_photon = float(k.planck_j_s * k.speed_of_light_m_per_s / ill.wavelength_m)
        qe = float(pix.photo_responsivity_a_per_w) * e_photon / float(k.elementary_charge_c)
        t = float(scene.integration_time_s)
        emitted = float(ill.peak_power_w * waveform_mean(params.illumination_waveform))
        self.per_radiance = (emitted * etendue * t / e_photon * qe)[:, None]  # electrons per unit radiance/W
        photon_irr = float(tj.optics.background_photon_irradiance(scene.background, scene.illuminance_lx, ill.wavelength_m,
                                                           scene.filter_half_width_m, k))
        self.background = photon_irr / np.pi * etendue * t * qe  # x ambient reflectivity
        self.dark = self.base.dark_per_s * t
        self.f_over_c = float(params.illumination_waveform.modulation_frequency_hz / k.speed_of_light_m_per_s)
        k_ret = returns.path_m.shape[-1]
        self.path = np.asarray(returns.path_m).reshape(-1, k_ret)
        self.radiance = np.asarray(returns.radiance_per_w).reshape(-1, k_ret)
        self.ambient = np.asarray(returns.ambient_reflectivity).ravel()
        self.shape = returns.shape

    def expected(self):
        b = self.base
        per_return = self.radiance * self.per_radiance  # (pixels, k)
        delays, values = b.table()
        delay = (self.path * self.f_over_c) % 1.0
        frac = np.stack([np.interp(delay, delays, values[:, j]) for j in range(b.n_phases)], axis=-1)
        signal = per_return.sum(axis=1)
        modulated = b.contrast * np.einsum("pk,pkj->pj", per_return, frac)
        equal = (0.5 * (1.0 - b.contrast) * signal + 0.5 * self.ambient * self.background + self.dark)[:, None]
        return modulated + equal, b.contrast * signal[:, None] - modulated + equal

    def frames(self, rng, n_frames: int, expected=None):
        n_a, n_b = self.expected() if expected is None else expected
        codes, valid = self.base._frames(rng, n_a, n_b, n_frames)
        phase, amp = self.base._demodulate(codes)
        depth = np.where(valid, np.mod(phase, 2 * np.pi) * (self.base.d_u / (2 * np.pi)), np.nan)
        return depth.reshape(self.shape + (n_frames,))


def case(size: tuple[int, int], repeats: int, with_numpy: bool = True) -> dict:
    rows, cols = size
    p = eqx.tree_at(lambda q: q.camera.optical_area_m, tj.Params(), jnp.array([cols * PITCH, rows * PITCH]))
    s = tj.FrameSettings()
    cam = tj.Camera(p, s)
    plane = scenes.tilted_plane(1.2, 30.0)
    returns = ready(cam.returns(plane))
    depth_map = ready(cam.returns(returns.radial_m, reflectivity=0.5, radial=True))
    n_px = rows * cols
    camera = ready(cam.prepare())
    prepared = ready(cam.expose(returns))
    words = key_words(jax.random.key(5))
    floor_jax = jax.jit(lambda f0: jnp.sum(normals(words, f0 + jnp.arange(BATCH, dtype=jnp.uint32)[None, :],
                                                   jnp.arange(n_px, dtype=jnp.uint32)[:, None], 0, 4)))
    cases = {
        "tofjax_one": lambda i: ready(camera.sample(returns, jax.random.key(i + 3), 1).radial_m),
        "tofjax_sample_frame": lambda i: ready(cam.prepare().sample(returns, jax.random.key(i + 3), 1).radial_m),
        "tofjax_moving_scene": lambda i: ready(camera.sample(cam.returns(plane), jax.random.key(i + 3), 1).radial_m),
        "tofjax_render_one": lambda i: ready(tj.simulate(cam, returns, jax.random.key(i + 3), 1, keep_frames=1)
                                             .result.depth_m),
        "tofjax_batch": lambda i: ready(tj.simulate(cam, returns, jax.random.key(i + 3), BATCH, keep_frames=BATCH).result.depth_m),
        "tofjax_prepared": lambda i: ready(prepared.sample(jax.random.key(i + 3), 1).radial_m),
        "tofjax_analytic": lambda i: ready(tj.predict(cam, returns).depth_std_m),
        "tofjax_analytic_prepared": lambda i: ready(prepared.predict().depth_std_m),
        "tofjax_noise_image": lambda i: ready(cam.prepare().noise_image(returns)),
        "tofjax_noise_image_camera": lambda i: ready(camera.noise_image(returns)),
        "tofjax_noise_image_depth_map": lambda i: ready(camera.noise_image(depth_map)),
        "tofjax_noise_image_prepared": lambda i: ready(prepared.noise_image()),
        "tofjax_noise_image_stream": lambda i: [ready(prepared.noise_image()) for _ in range(STREAM)],
        "floor_tofjax_normals": lambda i: ready(floor_jax(jnp.uint32(BATCH * (i + 2)))),
    }
    if with_numpy:
        npf = NumpyFrame(p, s, returns)
        rng = np.random.default_rng(2)
        cases["numpy_one"] = lambda i: npf.frames(rng, 1)
        expected = npf.expected()
        cases["numpy_prepared"] = lambda i: npf.frames(rng, 1, expected)
        cases["numpy_batch"] = lambda i: npf.frames(rng, BATCH)
        cases["floor_numpy_normals"] = lambda i: rng.standard_normal((4, n_px, BATCH, 4))
    t = interleaved(cases, repeats)
    out = {"seconds": t, "frames_per_s": {"tofjax_one": 1 / t["tofjax_one"], "tofjax_sample_frame": 1 / t["tofjax_sample_frame"],
                                          "tofjax_moving_scene": 1 / t["tofjax_moving_scene"],
                                          "tofjax_render_one": 1 / t["tofjax_render_one"],
                                          "tofjax_prepared": 1 / t["tofjax_prepared"],
                                          "tofjax_batch": BATCH / t["tofjax_batch"]},
           "analytic_images_per_s": 1 / t["tofjax_analytic"],
           "analytic_prepared_images_per_s": 1 / t["tofjax_analytic_prepared"],
           "noise_image_per_s": 1 / t["tofjax_noise_image"],
           "noise_image_camera_per_s": 1 / t["tofjax_noise_image_camera"],
           "noise_image_depth_map_per_s": 1 / t["tofjax_noise_image_depth_map"],
           "noise_image_prepared_per_s": 1 / t["tofjax_noise_image_prepared"],
           "noise_image_stream_per_s": STREAM / t["tofjax_noise_image_stream"],
           "ratios": {"tofjax_batch/floor_tofjax_normals": t["tofjax_batch"] / t["floor_tofjax_normals"]}}
    if with_numpy:
        out["frames_per_s"].update(numpy_one=1 / t["numpy_one"], numpy_prepared=1 / t["numpy_prepared"],
                                   numpy_batch=BATCH / t["numpy_batch"])
        out["ratios"].update({"numpy_one/tofjax_one": t["numpy_one"] / t["tofjax_one"],
                              "numpy_prepared/tofjax_prepared": t["numpy_prepared"] / t["tofjax_prepared"],
                              "numpy_batch/tofjax_batch": t["numpy_batch"] / t["tofjax_batch"],
                              "numpy_batch/floor_numpy_normals": t["numpy_batch"] / t["floor_numpy_normals"]})
        mc = tj.simulate(cam, returns, jax.random.key(0), BATCH, keep_frames=BATCH)
        d_np = npf.frames(np.random.default_rng(0), BATCH)
        std_tj = np.asarray(jnp.nanstd(jnp.moveaxis(mc.frames_radial_m, 0, -1), axis=-1))
        out["noise_image_median_ratio_numpy/tofjax"] = float(np.nanmedian(np.nanstd(d_np, axis=-1) / std_tj))
    return out


def table(r: dict) -> str:
    lines = [f"{'case':<50}{'tofjax':>16}{'NumPy':>14}{'ratio':>10}  target"]
    for name, target in (("frame_224x172", (">= 100 fps, >= 2x", ">= 1000/s")), ("frame_640x480", (">= 25 fps", ""))):
        if name not in r:
            continue
        c, size = r[name], name[6:]
        fps = c["frames_per_s"]
        labels = {"one": "1 per call", "sample_frame": "1 per call, camera too", "moving_scene": "1 per call, ray-cast too",
                  "render_one": "1 per call, with statistics", "prepared": "1 per call, scene prepared",
                  "batch": f"{BATCH} per call"}
        for kind in ("one", "sample_frame", "moving_scene", "render_one", "prepared", "batch"):
            ratio = c["ratios"].get(f"numpy_{kind}/tofjax_{kind}")
            lines.append(f"{size + ' noisy frames, ' + labels[kind]:<50}"
                         f"{fps[f'tofjax_{kind}']:>12.0f} fps{fps.get(f'numpy_{kind}', float('nan')):>10.0f} fps"
                         f"{(f'{ratio:.1f}x' if ratio else '-'):>10}  {target[0] if kind == 'one' else ''}")
        lines.append(f"{size + ' analytic noise image':<50}{c['analytic_images_per_s']:>9.0f} images/s{'':>14}{'':>10}  "
                     f"{target[1]}")
        lines.append(f"{size + ' analytic, exposure prepared':<50}{c['analytic_prepared_images_per_s']:>9.0f} images/s")
        lines.append(f"{size + ' noise image only, camera prepared':<50}{c['noise_image_camera_per_s']:>9.0f} images/s"
                     f"{'':>24}  {target[1]}")
        lines.append(f"{size + ' noise image only, camera too':<50}{c['noise_image_per_s']:>9.0f} images/s")
        lines.append(f"{size + ' noise image only, depth map, camera prepared':<50}"
                     f"{c['noise_image_depth_map_per_s']:>9.0f} images/s")
        lines.append(f"{size + ' noise image only, exposure prepared':<50}{c['noise_image_prepared_per_s']:>9.0f} images/s"
                     f"{'':>24}  {target[1]}")
        lines.append(f"{size + f' the same, {STREAM} in a row (a stream)':<50}{c['noise_image_stream_per_s']:>9.0f} images/s")
        lines.append(f"{size + ' batch / its normals (floor)':<50}{c['ratios']['tofjax_batch/floor_tofjax_normals']:>15.1f}x"
                     + (f"{c['ratios']['numpy_batch/floor_numpy_normals']:>13.1f}x" if 'numpy_batch/floor_numpy_normals'
                        in c['ratios'] else ""))
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--repeats", type=int, default=7)
    parser.add_argument("--quick", action="store_true", help="224 x 172 only")
    parser.add_argument("--out", type=Path, default=Path(__file__).parent / "results" / "bench_frame.json")
    args = parser.parse_args()
    results = {"platform": platform.platform(), "cpu_count": os.cpu_count(), "jax": jax.__version__,
               "numpy": np.__version__, "device": str(jax.devices()[0]), "repeats": args.repeats, "batch": BATCH}
    results["frame_224x172"] = case((172, 224), args.repeats)
    if not args.quick:
        results["frame_640x480"] = case((480, 640), max(3, args.repeats // 2))
    print(table(results))
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(results, indent=2))
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
