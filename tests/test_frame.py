"""Full frames (tofjax._frame, _scene, _returns, _pattern; docs/model.md "Full frames"): the pixel on
the axis is the centre-pixel model, the closed forms of the optics across the array, phasor sums of
returns, flying pixels from sub-pixel coverage, the fixed pattern's statistics, gradients through the
scene, NPZ/PLY round trips, the render command and sharding over devices.

One small camera (31 x 21 pixels: odd, so a pixel sits on the axis) for every model evaluation."""

import contextlib
import dataclasses
import json
import os
import re
import subprocess
import sys
import textwrap
from pathlib import Path

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

import tofjax as tj
from tofjax import frameio, scenes
from tofjax.cli import main
from tofjax._flags import (FLAG_LOW_AMPLITUDE, FLAG_LOW_SIGNAL, FLAG_MIXED, FLAG_NO_RETURN, FLAG_OUTSIDE_ILLUMINATION,
                           FLAG_SATURATED, FLAG_WRAPPED)
from tofjax._frame import frame_charges, _frame_chain
from tofjax._pattern import mean_pattern

from helpers import COLS, PITCH, ROWS, opencv_project, small, to_opencv

_INF = float("inf")
CENTRE = (ROWS // 2, COLS // 2)


@pytest.fixture(scope="module")
def params():
    return small()


@pytest.fixture(scope="module")
def one_ray():
    return tj.FrameSettings(subpixel_samples=1)


def charges(params, settings, returns, pattern=None):
    pattern = mean_pattern(params, returns.shape) if pattern is None else pattern
    return frame_charges(_frame_chain(params, None, 10**6, pattern), settings, returns, pattern)


def test_the_pixel_on_the_axis_is_the_centre_pixel_model(params, one_ray):
    """Same electrons, same noise: every expected quantity of the axis pixel of a wall at d equals
    tj.predict at distance d (the thesis' centre pixel), to rounding."""
    d = 1.3
    frame = tj.predict(tj.Camera(params, one_ray), scenes.wall(d, 0.9))
    centre = tj.predict(params, tj.Sweep("distance", [d]))
    r = frame.result
    for name in ("tap_a_e", "tap_b_e", "code_mean", "depth_mean_m", "depth_std_m", "amplitude_mean_lsb",
                 "amplitude_std_lsb", "intensity_e"):
        np.testing.assert_allclose(np.asarray(getattr(r, name))[CENTRE], np.asarray(getattr(centre, name))[0],
                                   rtol=1e-12, err_msg=name)
    np.testing.assert_allclose(r.noise.total_e[CENTRE], centre.noise.total_e[0], rtol=1e-12)
    np.testing.assert_allclose(frame.radial_true_m[CENTRE], d, rtol=1e-15)
    assert int(frame.flags[CENTRE]) == 0


def test_monte_carlo_frames_match_the_analytic_noise_image(params, one_ray):
    """The Monte Carlo std over 300 frames against the analytic noise image, pixel by pixel: the
    ratio's spread is what 300 frames allow (relative std error 1/sqrt(2 * 299) = 4.1 %)."""
    returns = tj.Camera(params, one_ray).returns(scenes.wall(1.3, 0.9))
    mc = tj.simulate(tj.Camera(params, one_ray), returns, jax.random.key(1), 300, keep_frames=2)
    an = tj.predict(tj.Camera(params, one_ray), returns)
    ratio = np.asarray(mc.depth_std_m / an.depth_std_m)
    assert abs(np.mean(ratio) - 1.0) < 3 * 0.041 / np.sqrt(ratio.size) + 0.005  # the mean of 651 ratios
    assert 0.03 < np.std(ratio) < 0.055
    assert mc.frames_radial_m.shape == (2, ROWS, COLS)
    np.testing.assert_allclose(mc.radial_m, an.radial_m, atol=4 * float(np.max(an.depth_std_m)) / np.sqrt(300))
    # A prepared scene renders the same frames (frame k of a key is frame k, however many are drawn:
    # the same draws, to the last bit's rounding, as each program is fused on its own) and the same
    # noise image.
    prepared = tj.Camera(params, one_ray).expose(returns)
    np.testing.assert_allclose(prepared.render(jax.random.key(1), 2, keep_frames=2).frames_radial_m,
                               mc.frames_radial_m, rtol=1e-15, atol=0)
    np.testing.assert_allclose(prepared.predict().depth_std_m, an.depth_std_m, rtol=1e-12)
    # With progress the chunks run from the host (tofjax._executor.drive_blocks): the same frames and statistics.
    loud = prepared.render(jax.random.key(1), 300, keep_frames=2, progress=True)
    np.testing.assert_allclose(loud.frames_radial_m, mc.frames_radial_m, rtol=1e-15, atol=0)
    np.testing.assert_allclose(loud.depth_std_m, mc.depth_std_m, rtol=1e-13)
    # The noise image alone (a program that computes nothing else) is the analytic frame's (to the
    # last bits: XLA fuses the smaller program differently), also inside a jit of the user's, and
    # with the exposure (a prepared camera's noise_image).
    np.testing.assert_allclose(prepared.noise_image(), prepared.predict().depth_std_m, rtol=1e-13)
    np.testing.assert_allclose(jax.jit(lambda f: f.noise_image())(prepared), an.depth_std_m, rtol=1e-12)
    np.testing.assert_allclose(tj.Camera(params, one_ray).prepare().noise_image(returns), an.depth_std_m, rtol=1e-12)
    sampled = prepared.sample(jax.random.key(1), 2)
    kept = mc.result.valid.transpose(2, 0, 1)
    np.testing.assert_array_equal(sampled.valid, kept)
    np.testing.assert_allclose(sampled.radial_m, np.where(kept, mc.frames_radial_m, np.nan), rtol=1e-15, atol=0)
    np.testing.assert_allclose(sampled.amplitude_lsb, mc.result.amplitude_lsb.transpose(2, 0, 1), rtol=1e-15, atol=0)
    # Exposed in the same call (a prepared camera's sample), and vmapped over scenes inside a jit of the user's:
    # the same frames.
    direct = tj.Camera(params, one_ray).prepare().sample(returns, jax.random.key(1), 2)
    batch = jax.jit(jax.vmap(lambda d: tj.Camera(params, one_ray).prepare().sample(tj.Camera(params, one_ray).returns(scenes.wall(d, 0.9)), jax.random.key(1), 2)))(jnp.array([1.3, 1.3]))
    for frames in (direct, *(jax.tree_util.tree_map(lambda x, i=i: x[i], batch) for i in range(2))):
        np.testing.assert_array_equal(frames.valid, sampled.valid)
        np.testing.assert_allclose(frames.radial_m, sampled.radial_m, rtol=1e-14, atol=0)
        np.testing.assert_allclose(frames.amplitude_lsb, sampled.amplitude_lsb, rtol=1e-14, atol=0)


def test_a_prepared_camera_is_the_verbs_on_every_scene(params, one_ray):
    """camera.prepare() once, then scene after scene: the same frames, noise image, analytic frame and
    render as the functions of (params, settings, returns), which prepare the camera on every call;
    also inside a jit of the user's, vmapped over scenes (the camera closed over), and with the
    camera prepared inside a gradient (d noise / d integration time against finite differences)."""
    pattern = tj.draw_pattern(params, tj.FrameSettings(prnu_sigma=0.02, phase_offset_sigma_rad=0.01), (ROWS, COLS))
    camera = tj.Camera(params, one_ray, pattern=pattern).prepare()
    assert camera.shape == (ROWS, COLS)
    walls = [tj.Camera(params, one_ray).returns(scenes.tilted_plane(d, 20.0)) for d in (1.1, 1.6)]
    for returns in walls:
        key = jax.random.key(4)
        np.testing.assert_array_equal(camera.sample(returns, key, 2).radial_m,
                                      tj.Camera(params, one_ray, pattern=pattern).prepare().sample(returns, key, 2).radial_m)
        np.testing.assert_array_equal(camera.noise_image(returns), tj.Camera(params, one_ray, pattern=pattern).prepare().noise_image(returns))
        a, b = camera.predict(returns), tj.predict(tj.Camera(params, one_ray, pattern=pattern), returns)
        for name in ("radial_m", "depth_std_m", "amplitude_lsb", "intensity_e", "flags", "z_m"):
            np.testing.assert_array_equal(getattr(a, name), getattr(b, name), err_msg=name)
        np.testing.assert_array_equal(camera.render(returns, key, 3).depth_std_m,
                                      tj.simulate(tj.Camera(params, one_ray, pattern=pattern), returns, key, 3).depth_std_m)
    distances = jnp.array([1.1, 1.6])
    batch = jax.jit(jax.vmap(lambda d: camera.noise_image(tj.Camera(params, one_ray).returns(scenes.tilted_plane(d, 20.0)))))
    np.testing.assert_allclose(batch(distances), np.stack([camera.noise_image(r) for r in walls]), rtol=1e-12)

    returns = walls[0]

    def noise(t):
        p = eqx.tree_at(lambda q: q.scene.integration_time_s, params, t)
        return tj.Camera(p, one_ray, pattern=pattern).prepare().noise_image(returns)[CENTRE]

    t0 = float(params.scene.integration_time_s)
    g, h = float(jax.grad(noise)(t0)), 1e-4 * t0
    fd = (float(noise(t0 + h)) - float(noise(t0 - h))) / (2 * h)
    assert g < 0.0 and abs(g - fd) <= 1e-5 * abs(fd), (g, fd)
    # Refused in one line, before any work.
    with pytest.raises(TypeError, match=r"^returns must be tofjax.Returns, got NoneType$"):
        camera.noise_image(None)
    narrower = eqx.tree_at(lambda q: q.camera.optical_area_m, params, jnp.array([(COLS - 2) * PITCH, ROWS * PITCH]))
    other = tj.Camera(narrower, one_ray).returns(scenes.wall(1.0))
    with pytest.raises(ValueError, match=rf"^the returns have {ROWS} x {COLS - 2} pixels, the camera {ROWS} x {COLS} "):
        camera.sample(other, jax.random.key(0))
    with pytest.raises(TypeError, match=r"^Camera: pattern must be a tofjax.PixelPattern or None, got float$"):
        tj.Camera(params, one_ray, pattern=0.5).prepare()


def test_rays_meet_the_nearest_surface_of_a_numpy_ray_caster():
    """2000 random rays from the lens centre into a box, a clipped plane and a sphere: the nearest
    hit's distance and its normal (facing the ray) as a ray caster written out per primitive in NumPy
    (slabs for the box, the quadratic for the sphere); of two equally near surfaces, the first. The
    front and top faces of the box on their own: the closed-form distances and normals."""
    from tofjax._scene import Box, Plane, SceneGeometry, Sphere

    box = Box((-0.25, -1.0, 1.8), (0.25, -0.5, 2.3), 0.5)
    plane = Plane((0.0, 0.0, 2.0), (0.2, 0.1, 1.0), 0.9, lo=(-0.6, -_INF, -_INF), hi=(_INF, 0.4, _INF))
    ball = Sphere((0.3, 0.2, 1.6), 0.35, 0.7)
    geometry = SceneGeometry((box, plane, ball))
    d = np.random.default_rng(7).normal([0.0, -0.2, 1.0], [0.35, 0.35, 0.05], (2000, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    hit = geometry.cast(jnp.asarray(d))

    t_box, n_box = np.full(len(d), np.inf), np.zeros_like(d)
    with np.errstate(divide="ignore"):
        t_lo, t_hi = np.array(box.lo) / d, np.array(box.hi) / d
    near, far = np.minimum(t_lo, t_hi), np.maximum(t_lo, t_hi)
    t_in, t_out = near.max(axis=1), far.min(axis=1)
    ok = (t_in <= t_out) & (t_in > 0)
    t_box[ok] = t_in[ok]
    n_box[np.arange(len(d)), near.argmax(axis=1)] = 1.0
    n = np.array([0.2, 0.1, 1.0]) / np.linalg.norm([0.2, 0.1, 1.0])
    t_plane = (np.array([0.0, 0.0, 2.0]) @ n) / (d @ n)
    p = t_plane[:, None] * d
    t_plane = np.where((t_plane > 0) & (p[:, 0] >= -0.6) & (p[:, 1] <= 0.4), t_plane, np.inf)
    c, r = np.array([0.3, 0.2, 1.6]), 0.35
    b = d @ c
    disc = b * b - (c @ c - r * r)
    t_ball = np.where(disc > 0, b - np.sqrt(np.maximum(disc, 0)), np.inf)
    n_ball = (t_ball[:, None] * d - c) / r
    ts = np.stack([t_box, t_plane, t_ball])
    best = ts.argmin(axis=0)
    normals = np.stack([n_box, np.broadcast_to(n, d.shape), n_ball])[best, np.arange(len(d))]
    normals *= np.where(np.sum(normals * d, axis=1, keepdims=True) > 0, -1.0, 1.0)
    t = ts.min(axis=0)
    found = np.isfinite(t)
    assert all(np.sum(found & (best == k)) > 100 for k in range(3)) and not np.all(found)  # every primitive, and misses
    np.testing.assert_allclose(hit.t, t, rtol=1e-12)
    np.testing.assert_allclose(np.asarray(hit.normal)[found], normals[found], rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(hit.reflectivity, np.array([0.5, 0.9, 0.7])[best])

    front, top = np.array([0.0, -0.75, 1.8]), np.array([0.0, -0.5, 2.05])  # face centres of the box
    faces = SceneGeometry((box,)).cast(jnp.asarray(np.stack([front, top]) / np.linalg.norm([front, top], axis=1)[:, None]))
    np.testing.assert_allclose(faces.t, np.linalg.norm([front, top], axis=1), rtol=1e-14)
    np.testing.assert_allclose(faces.normal, [[0.0, 0.0, -1.0], [0.0, 1.0, 0.0]], atol=1e-15)
    # Two surfaces at the same distance: the first primitive's.
    twins = SceneGeometry((Plane((0.0, 0.0, 1.0), (0.0, 0.0, 1.0), 0.3), Plane((0.0, 0.0, 1.0), (0.0, 0.0, 1.0), 0.8)))
    assert float(twins.cast(jnp.array([[0.0, 0.0, 1.0]])).reflectivity[0]) == 0.3
    # A primitive is a subclass of AbstractPrimitive (its own intersect), nothing else.
    with pytest.raises(TypeError, match=r"primitives\[1\] is a dict, not a primitive \(tofjax.scenes.Plane"):
        SceneGeometry((box, {"intersect": None}))


def test_the_pixel_field_in_closed_form_is_the_rays(params):
    """cos of the field angle, image height and unit direction per pixel without the rays' norm:
    the rays' numbers (the same formula written out; to rounding), unit length, (0, 0, 1) on the axis."""
    from tofjax._scene import pixel_directions, pixel_field

    settings = tj.FrameSettings(subpixel_samples=1)
    rays = tj.optics.frame_rays(params, settings)
    field = pixel_field(params.camera, (ROWS, COLS))
    direction = np.asarray(pixel_directions(params.camera, (ROWS, COLS)))
    np.testing.assert_allclose(field.cos_field_angle, rays.cos_field_angle, rtol=1e-15)
    np.testing.assert_allclose(field.image_height, rays.image_height, rtol=1e-15)
    np.testing.assert_allclose(direction, np.asarray(rays.samples)[:, :, 0], rtol=1e-15, atol=1e-17)
    np.testing.assert_allclose(np.linalg.norm(direction, axis=-1), 1.0, rtol=1e-15)
    np.testing.assert_array_equal(direction[CENTRE], [0.0, 0.0, 1.0])
    # The corner pixel's field angle from the geometry alone: its centre lies (cols - 1) / 2 and (rows - 1) / 2
    # pitches off the axis, at the focal length f behind the lens centre.
    f = float(tj.optics.lens(params.camera).focal_length_m)
    x, y = (COLS - 1) / 2 * PITCH, (ROWS - 1) / 2 * PITCH
    assert float(field.cos_field_angle[0, 0]) == pytest.approx(f / np.sqrt(x * x + y * y + f * f), rel=1e-15)


def test_frames_sampled_in_several_chunks_are_the_kept_frames(params, one_ray, monkeypatch):
    """More frames than a chunk holds: ``sample`` draws them chunk by chunk (here 3 chunks of 2 for 5
    frames), and frame k is still frame k of the key (the frames ``render`` keeps, drawn at once)."""
    from tofjax import _frame

    prepared = tj.Camera(params, one_ray).expose(scenes.wall(1.3, 0.9))
    monkeypatch.setattr(_frame, "frame_chunk_elements", lambda: 2 * ROWS * COLS * params.pixel.n_phases)
    sampled = prepared.sample(jax.random.key(1), 5)
    kept = prepared.render(jax.random.key(1), 5, keep_frames=5, raw=True)
    valid = kept.result.valid.transpose(2, 0, 1)
    np.testing.assert_array_equal(sampled.valid, valid)
    np.testing.assert_allclose(sampled.radial_m, np.where(valid, kept.frames_radial_m, np.nan), rtol=1e-15, atol=0)
    np.testing.assert_allclose(sampled.amplitude_lsb, kept.result.amplitude_lsb.transpose(2, 0, 1), rtol=1e-15, atol=0)
    # With their raw phase images (codes and both taps, (frames, phases, rows, cols)): the same frames,
    # and the raw images render keeps.
    raw = prepared.sample(jax.random.key(1), 5, raw=True)
    np.testing.assert_array_equal(raw.radial_m, sampled.radial_m)
    assert sampled.codes is None and raw.codes.shape == raw.tap_a_e.shape == (5, params.pixel.n_phases, ROWS, COLS)
    np.testing.assert_array_equal(raw.codes, kept.result.codes.transpose(2, 3, 0, 1))
    # The taps as read (held charge plus each tap's drawn noise) to 1e-8: the two programs differ
    # (render's also computes the result's headroom) and XLA's CPU backend then computes tap B's
    # reading differently by up to 6e-9 of it (2e-5 e-; the cause is not isolated: an optimisation
    # barrier around the headroom's inputs does not change it); the codes and distances above are equal.
    for tap, kept_tap in ((raw.tap_a_e, kept.result.frames_tap_a_e), (raw.tap_b_e, kept.result.frames_tap_b_e)):
        np.testing.assert_allclose(tap, kept_tap.transpose(2, 3, 0, 1), rtol=1e-8)
    # A prepared camera's sample in several chunks (the frames' constants made once from the exposure, then the
    # chunks drawn from them; one chunk makes them as it draws): the same frames.
    direct = tj.Camera(params, one_ray).prepare().sample(tj.Camera(params, one_ray).returns(scenes.wall(1.3, 0.9)), jax.random.key(1), 5)
    np.testing.assert_array_equal(direct.valid, valid)
    np.testing.assert_allclose(direct.radial_m, sampled.radial_m, rtol=1e-14, atol=0)
    # Refused before any work, in one line naming the value.
    with pytest.raises(ValueError, match=r"^frames = 0 is out of range: allowed integer >= 1$"):
        tj.Camera(params, one_ray).prepare().sample(tj.Camera(params, one_ray).returns(scenes.wall(1.3, 0.9)), jax.random.key(1), 0)
    with pytest.raises(TypeError, match=r"^returns must be tofjax.Returns, got NoneType$"):
        tj.Camera(params, one_ray).prepare().sample(None, jax.random.key(1))


def test_a_flat_wall_falls_off_as_profile_times_cos4_times_incidence(params):
    """Signal across a wall at d, against the closed form: on-plane irradiance cos^n(phi) / (S_n d^2)
    (the profile, with the wall's incidence and range folded in), times cos^4(phi) of the lens, with
    S_n = pi ((1 + T^2)^(1 - n/2) - 1) / (1 - n/2) for a circular FoV of half-angle tan T. Pixels
    outside the illumination's cone get nothing."""
    n = 2.5
    p = eqx.tree_at(lambda q: q.illumination.fov_deg, params, jnp.asarray(20.0))
    s = tj.FrameSettings(subpixel_samples=1, illumination_falloff_exponent=n)
    frame = tj.predict(tj.Camera(p, s), scenes.wall(1.5, 0.9))  # within the unambiguity range: good pixels
    signal = np.asarray(frame.result.noise.signal_e)
    flat = tj.FrameSettings(subpixel_samples=1)
    axis = float(tj.predict(tj.Camera(p, flat), scenes.wall(1.5, 0.9)).result.noise.signal_e[CENTRE])
    cos_phi = np.asarray(frame.direction)[..., 2]
    t = np.tan(np.deg2rad(10.0))
    s_n = np.pi * ((1 + t * t) ** (1 - n / 2) - 1) / (1 - n / 2)
    s_0 = np.pi * t * t
    inside = (1 / cos_phi**2 - 1) <= t * t
    expected = axis * (s_0 / s_n) * cos_phi ** (n + 4)
    assert 20 < inside.sum() < inside.size - 20  # both kinds of pixel are tested
    np.testing.assert_allclose(signal[inside], expected[inside], rtol=1e-12)
    assert np.all(signal[~inside] == 0.0)


def test_incidence_angle_and_baseline(params, one_ray):
    """A wall tilted by a: the axis pixel's signal is cos(a) of the untilted wall's (Lambert at the
    same range). A baseline b moves the illumination: the axis pixel's path is d + sqrt(d^2 + b^2)."""
    flat = tj.predict(tj.Camera(params, one_ray), scenes.wall(1.5))
    tilted = tj.predict(tj.Camera(params, one_ray), scenes.tilted_plane(1.5, 40.0))
    np.testing.assert_allclose(tilted.result.noise.signal_e[CENTRE], np.cos(np.deg2rad(40.0))
                               * flat.result.noise.signal_e[CENTRE], rtol=1e-12)
    b = tj.FrameSettings(subpixel_samples=1, baseline_m=(0.3, 0.0))
    returns = tj.Camera(params, b).returns(scenes.wall(1.5))
    np.testing.assert_allclose(returns.path_m[CENTRE][0], 1.5 + np.hypot(1.5, 0.3), rtol=1e-14)


def test_two_returns_are_the_phasor_sum(params, one_ray):
    """Charges are linear in the returns: without background and dark signal, the differential
    phasor of a pixel with two returns is the sum of the returns' phasors."""
    p = eqx.tree_at(lambda q: (q.scene.illuminance_lx, q.pixel.dark_slope_mean_v_per_s), params, (0.0, 0.0))
    shape = (ROWS, COLS)
    radial = jnp.full(shape, 1.0)
    one = lambda path, rad: tj.Returns(jnp.full(shape + (1,), path), jnp.full(shape + (1,), rad),  # noqa: E731
                                       jnp.zeros(shape), radial)
    a, b = one(2.0, 0.1), one(3.1, 0.04)
    both = a + b
    theta = np.asarray(tj.waveforms.phase_steps(p.pixel.n_phases))

    def phasor(r):
        c = charges(p, one_ray, r)
        return np.sum((np.asarray(c.photo_a) - np.asarray(c.photo_b)) * np.exp(1j * theta), axis=-1)

    np.testing.assert_allclose(phasor(both), phasor(a) + phasor(b), rtol=1e-12)
    assert both.path_m.shape == shape + (2,)


def test_a_step_edge_gives_the_flying_pixels_the_subpixel_coverage_predicts(params):
    """A board at 1 m left of x = e in front of a wall at 1.6 m, 4 x 4 rays per pixel. The coverage
    (the fraction of a pixel's rays that meet the board) is computed here from the rays alone; the
    pixels whose expected distance matches neither surface's (more than 3 mm from both, each
    surface's own frame taken as its truth, so that the wiggling error cancels) are exactly those
    with 0 < coverage < 1, and they read between the two."""
    s = tj.FrameSettings(subpixel_samples=4)
    f = float(tj.optics.lens(params.camera).focal_length_m)
    e = 1.0 * (3.3 * PITCH / f)  # the edge crosses column 15 + 3.3 at a third of the sub-pixel pitch
    step = tj.predict(tj.Camera(params, s), scenes.step_edge(1.0, 1.6, e))
    near = tj.predict(tj.Camera(params, s), scenes.wall(1.0))
    far = tj.predict(tj.Camera(params, s), scenes.wall(1.6))
    rays = np.asarray(tj.optics.frame_rays(params, s).samples)
    coverage = np.mean(rays[..., 0] / rays[..., 2] * 1.0 <= e, axis=-1)
    m, mn, mf = (np.asarray(x.radial_m) for x in (step, near, far))
    flying = (np.abs(m - mn) > 3e-3) & (np.abs(m - mf) > 3e-3)
    mixed = (coverage > 0) & (coverage < 1)
    assert mixed.sum() == ROWS  # one column straddles the edge
    np.testing.assert_array_equal(flying, mixed)
    assert np.all((m[mixed] > mn[mixed]) & (m[mixed] < mf[mixed]))


def test_two_bounce_light_of_a_corner(params, one_ray):
    """A concave corner (apex at 1.5 m, inside the unambiguity range): the two-bounce returns are
    longer than the direct path, scale with the reflectivity squared (the direct ones with the
    reflectivity), and make the walls read long (multipath), more near the apex than at the edges.
    The apex column itself lies in both walls' planes, where the other wall is seen edge-on: no
    two-bounce light."""
    bright = tj.Camera(params, one_ray).returns(scenes.corner(1.5, patches_per_side=8, reflectivity=0.8), bins=8)
    dim = tj.Camera(params, one_ray).returns(scenes.corner(1.5, patches_per_side=8, reflectivity=0.4), bins=8)
    direct, indirect = np.asarray(bright.radiance_per_w[..., 0]), np.asarray(bright.radiance_per_w[..., 1:])
    np.testing.assert_allclose(np.asarray(dim.radiance_per_w[..., 0]), 0.5 * direct, rtol=1e-12)
    np.testing.assert_allclose(np.asarray(dim.radiance_per_w[..., 1:]), 0.25 * indirect, rtol=1e-12)
    lit = indirect > 0
    off_apex = np.arange(COLS) != COLS // 2
    assert lit.any(axis=-1)[:, off_apex].all()
    assert np.max(indirect[:, COLS // 2]) < 1e-9 * np.max(indirect)
    assert np.all(np.asarray(bright.path_m[..., 1:])[lit] > np.broadcast_to(np.asarray(bright.path_m[..., :1]),
                                                                            lit.shape)[lit])
    frame = tj.predict(tj.Camera(params, one_ray), bright)
    plain = tj.predict(tj.Camera(params, one_ray), tj.Returns(bright.path_m[..., :1], bright.radiance_per_w[..., :1], bright.ambient_reflectivity, bright.radial_m))
    bias = np.asarray(frame.radial_m - plain.radial_m)
    assert np.all(bias[:, off_apex] > 0)
    assert np.max(bias[:, 10:21]) > 3 * np.max(bias[:, [0, -1]])


def test_fixed_pattern_statistics_and_reproducibility(default_params):
    """Over a 172 x 224 camera the spatial sigmas are the configured ones (std error of a std over
    38528 pixels: 0.36 %); the same seed gives the same camera, another seed another."""
    s = tj.FrameSettings(prnu_sigma=0.05, phase_offset_sigma_rad=0.02, tap_asymmetry_sigma=0.03,
                         threshold_sigma=0.04, seed=7)
    shape = (172, 224)
    pat = tj.draw_pattern(default_params, s, shape)
    for x, sigma, mean in ((pat.gain, 0.05, 1.0), (pat.phase_offset_rad, 0.02, 0.0), (pat.tap_asymmetry, 0.03, 0.0),
                           (pat.full_well_scale, 0.04, 1.0)):
        x = np.asarray(x)
        assert abs(np.std(x) / sigma - 1) < 0.02
        assert abs(np.mean(x) - mean) < 4 * sigma / np.sqrt(x.size)
    slopes = np.concatenate([np.ravel(pat.dark_slope_a_v_per_s), np.ravel(pat.dark_slope_b_v_per_s)])
    assert abs(np.std(slopes) / float(default_params.pixel.dark_slope_sigma_v_per_s) - 1) < 0.02
    again = tj.draw_pattern(default_params, s, shape)
    assert all(np.array_equal(a, b) for a, b in zip(jax.tree_util.tree_leaves(pat), jax.tree_util.tree_leaves(again), strict=True))
    other = tj.draw_pattern(default_params, dataclasses.replace(s, seed=8), shape)
    assert not np.array_equal(pat.gain, other.gain)


def test_fixed_pattern_effects_reach_the_frame(params, one_ray):
    """A pixel's phase offset phi reads as a return whose path is longer by phi c / (2 pi f); PRNU
    scales the signal pixel by pixel; a pixel with a lower full well is nearer to it."""
    returns = tj.Camera(params, one_ray).returns(scenes.wall(1.2))
    shape = (ROWS, COLS)
    offset = tj.draw_pattern(params, tj.FrameSettings(prnu_sigma=0.0, phase_offset_sigma_rad=0.05), shape)
    drawn = tj.predict(tj.Camera(params, one_ray, pattern=offset), returns)
    extra = np.asarray(offset.phase_offset_rad) * float(params.unambiguity_range_m) / np.pi  # phi c / (2 pi f)
    longer = tj.Returns(returns.path_m + extra[..., None], returns.radiance_per_w, returns.ambient_reflectivity,
                        returns.radial_m)
    np.testing.assert_allclose(drawn.radial_m, tj.predict(tj.Camera(params, one_ray), longer).radial_m, rtol=1e-9)
    assert np.std(extra) > 0.005
    mean = tj.predict(tj.Camera(params, one_ray), returns)
    for settings in (tj.FrameSettings(prnu_sigma=0.1), tj.FrameSettings(prnu_sigma=0.0, threshold_sigma=0.1)):
        pat = tj.draw_pattern(params, settings, shape)
        drawn = tj.predict(tj.Camera(params, one_ray, pattern=pat), returns)
        np.testing.assert_allclose(drawn.result.noise.signal_e, pat.gain * mean.result.noise.signal_e, rtol=1e-12)
    only_wells = eqx.tree_at(lambda q: q.full_well_scale, mean_pattern(params, shape), pat.full_well_scale)
    drawn = tj.predict(tj.Camera(params, one_ray, pattern=only_wells), returns)
    np.testing.assert_allclose(drawn.result.full_well_fraction * pat.full_well_scale, mean.result.full_well_fraction,
                               rtol=1e-12)
    assert np.std(np.asarray(pat.full_well_scale)) > 0.05


def test_gradients_through_the_scene_match_finite_differences(params, one_ray):
    """d(depth error)/d(wall distance) and d(depth noise)/d(reflectivity) of the axis pixel."""
    def error(d):
        f = tj.predict(tj.Camera(params, one_ray), scenes.wall(d, 0.9))
        return f.radial_m[CENTRE] - d

    def noise(rho):
        f = tj.predict(tj.Camera(params, one_ray), scenes.wall(1.3, rho))
        return f.depth_std_m[CENTRE]

    for fn, x0 in ((error, 1.3), (noise, 0.6)):
        g = float(jax.grad(fn)(x0))
        h = 1e-5 * x0
        fd = (float(fn(x0 + h)) - float(fn(x0 - h))) / (2 * h)
        assert np.isfinite(g) and abs(g - fd) <= 1e-5 * abs(fd) + 1e-9, (g, fd)


def test_returns_npz_round_trip_and_refusals(params, tmp_path, one_ray):
    r = tj.Camera(params, one_ray).returns(scenes.sphere(1.0, 0.2, 2.0))
    path = tmp_path / "returns.npz"
    tj.frameio.save_returns(path, r)
    back = tj.frameio.load_returns(path, (ROWS, COLS))
    assert all(np.array_equal(a, b) for a, b in zip(jax.tree_util.tree_leaves(r), jax.tree_util.tree_leaves(back), strict=True))
    with pytest.raises(ValueError, match=r"path_m has 21 x 31 pixels, the camera 5 x 5"):
        tj.frameio.load_returns(path, (5, 5))
    bad = dict(path_m=np.ones((2, 2, 1)), radiance_per_w=-np.ones((2, 2, 1)))
    np.savez(tmp_path / "bad.npz", **bad)
    with pytest.raises(ValueError, match=r"bad.npz: radiance_per_w\[0, 0, 0\] = -1.0 is out of range"):
        tj.frameio.load_returns(tmp_path / "bad.npz")
    np.savez(tmp_path / "none.npz", x=np.ones(2))
    with pytest.raises(ValueError, match="array 'path_m' is missing"):
        tj.frameio.load_returns(tmp_path / "none.npz")


def test_a_depth_map_of_a_wall_is_the_wall(params, one_ray):
    """camera.returns of a depth map of a flat wall's Z depth (or its radial distances) gives the returns of the
    built-in wall: normals from the map's finite differences, paths and radiance; a map of another
    shape is refused naming both shapes."""
    wall = tj.Camera(params, one_ray).returns(scenes.wall(1.3, 0.9))
    for depth, radial in ((np.full((ROWS, COLS), 1.3), False), (np.asarray(wall.radial_m), True)):
        got = tj.Camera(params, one_ray).returns(depth, reflectivity=0.9, radial=radial)
        for name in ("path_m", "radiance_per_w", "ambient_reflectivity", "radial_m"):
            np.testing.assert_allclose(getattr(got, name), getattr(wall, name), rtol=1e-9, err_msg=name)
    with pytest.raises(ValueError, match=r"depth map has shape \(2, 3\), the camera \(21, 31\)"):
        tj.Camera(params, one_ray).returns(np.ones((2, 3)), reflectivity=0.9)


def test_ply_round_trip(tmp_path):
    pts = np.array([[0.0, 1.0, 2.0], [-0.5, 0.25, 3.0]])
    frameio.write_ply(tmp_path / "p.ply", pts, np.array([5.0, 6.0]))
    v = frameio.read_ply(tmp_path / "p.ply")
    np.testing.assert_array_equal(np.stack([v["x"], v["y"], v["z"]], axis=-1), pts.astype(np.float32))
    np.testing.assert_array_equal(v["intensity"], [5.0, 6.0])


CONFIG = f"""
[camera]
optical_area_m = [{COLS * PITCH!r}, {ROWS * PITCH!r}]
[frame]
subpixel_samples = 2
distortion_k1 = -0.2
distortion_p2 = 0.001
"""


def _cli(capsys, *args):
    """``tofjax ARGS`` in this process (its programs are the ones the other tests compiled): the exit
    status, stdout and stderr."""
    capsys.readouterr()
    try:
        code = main(list(args))
    except SystemExit as exc:  # argparse's own errors
        code = exc.code
    out, err = capsys.readouterr()
    return code, out, err


def test_render_command_writes_every_output(tmp_path, capsys):
    cfg = tmp_path / "cam.toml"
    cfg.write_text(CONFIG)
    out = tmp_path / "out"
    code, stdout, stderr = _cli(capsys, "render", "--scene", "box_on_floor:box_m=1.5", "--config", str(cfg),
                                "--frames", "20", "--keep-frames", "2", "--fixed-pattern", "--raw", "--quiet",
                                "--out", str(out))
    assert code == 0, stderr
    assert "21 x 31 pixels, 20 frames" in stdout and "eye safety (an estimate" in stdout
    data = np.load(out / "frame.npz")
    assert data["frames_radial_m"].shape == (2, ROWS, COLS)
    # The raw phase images, decoded in NumPy with the formula of docs/model.md "Raw phase images"
    # (and of raw_convention), are the kept frames: distance to 1e-9 m, amplitude to 1e-12.
    assert data["raw_codes"].shape == data["raw_tap_a_e"].shape == (2, 1, 4, ROWS, COLS)
    assert data["raw_codes"].dtype == np.int32 and data["raw_tap_b_e"].dtype == np.float32
    # docs/model.md's block itself, run where it reads out/frame.npz:
    block = next(b for b in re.findall(r"```python\n(.+?)\n```", (Path(__file__).parents[1] / "docs" / "model.md")
                                       .read_text(), re.S) if 'np.load("out/frame.npz")' in b)
    decoded = {}
    with contextlib.chdir(tmp_path):
        exec(compile(block, "docs/model.md, Raw phase images", "exec"), decoded)
    np.testing.assert_allclose(data["raw_phase_weights"], [np.cos(data["raw_phase_steps_rad"]),
                                                           np.sin(data["raw_phase_steps_rad"])], atol=1e-15)
    du = float(data["unambiguity_range_m"])
    error = np.mod(decoded["radial_m"] - data["frames_radial_m"] + du / 2, du) - du / 2  # a reading at the wrap: either end
    assert np.max(np.abs(error)) < 1e-9
    np.testing.assert_allclose(decoded["amplitude_lsb"], data["frames_amplitude_lsb"], rtol=1e-12)
    assert data["raw_modulation_frequencies_hz"].tolist() == [80.32e6] and "Decoding" in str(data["raw_convention"])
    assert data["predicted_std_m"].shape == (ROWS, COLS)
    delivered = (data["flags"] & tj.schema.CAMERA_FLAGS) == 0  # the camera's own flags decide (issue 50 item 2)
    good = int(np.sum(delivered))
    cloud = frameio.read_ply(out / "points.ply")
    assert len(cloud) == good > 0 and cloud["red"].dtype == np.uint8 and cloud["red"].max() > 0
    np.testing.assert_array_equal(cloud["red"], cloud["blue"])  # grey by amplitude
    # The 16-bit images: Z depth in whole millimetres and amplitude in LSB, 0 where a pixel is not delivered.
    from PIL import Image

    ok = delivered & np.isfinite(data["radial_m"])
    for name, key, scale in (("depth_mm.png", "z_m", 1e3), ("amplitude.png", "amplitude_lsb", 1.0)):
        image = np.asarray(Image.open(out / name))
        assert image.dtype == np.uint16 and image.shape == (ROWS, COLS)
        np.testing.assert_array_equal(image[ok], np.round(data[key][ok] * scale))
        assert np.all(image[~ok] == 0)
    # The intrinsics (OpenCV's convention, in intrinsics.json and frame.npz): every point of the cloud
    # projects onto its pixel (docs/model.md, "Lens distortion and intrinsics"; tests/test_distortion.py).
    cam = json.loads((out / "intrinsics.json").read_text())
    assert cam["dist_coeffs"] == [-0.2, 0.0, 0.0, 0.001, 0.0] and cam["format"] == "tofjax-intrinsics/1"
    np.testing.assert_array_equal(data["camera_matrix"], cam["camera_matrix"])
    np.testing.assert_array_equal(data["dist_coeffs"], cam["dist_coeffs"])
    assert data["image_size"].tolist() == [COLS, ROWS]
    points = np.stack([cloud["x"], cloud["y"], cloud["z"]], -1).astype(float)
    uv = opencv_project(to_opencv(points), cam["camera_matrix"], cam["dist_coeffs"])
    rows, cols = np.nonzero(ok)
    np.testing.assert_allclose(uv, np.stack([cols, rows], -1), atol=1e-3)  # the PLY's float32 coordinates
    # Every array of frame.npz is in docs/model.md's table of its layout.
    documented = (Path(__file__).parents[1] / "docs" / "model.md").read_text()
    assert [key for key in data.files if f"`{key}`" not in documented] == []
    assert {"radial_m.png", "predicted_std_mm.png", "error_mm.png", "report.html"} <= {p.name for p in out.iterdir()}
    # flags.png is categorical: good pixels and wrapped ones (the wall at 3 m) in colours of their own
    # (on the old 0-127 colour scale both were blue), each combination present named in a legend.
    from matplotlib.colors import to_rgb

    classes = frameio.flag_classes(data["flags"])
    labels = [label for _, label, _ in classes]
    assert labels[0].startswith("good (no flag): ") and any(label.startswith("wrapped") for label in labels)
    shown = {tuple(c) for c in np.asarray(Image.open(out / "flags.png").convert("RGB")).reshape(-1, 3)}
    colours = [tuple(round(255 * x) for x in to_rgb(colour)) for _, _, colour in classes]
    assert len(set(colours)) == len(classes) and set(colours) <= shown
    legend = frameio.frame_figure(dict(data)).legends  # the explorer's Frame tab, as render draws it
    assert [t.get_text() for t in legend[0].get_texts()] == labels
    report = (out / "report.html").read_text()
    assert "data:image/png;base64" in report and "frame: 4 phase images of 2 ms" in report


@pytest.mark.parametrize("shape", [(172, 224), (240, 60), (4, 320), (1, 1)])
def test_a_maps_layout_keeps_every_label_inside_and_square_pixels(shape):
    """render's colour maps are laid out by fixed margins (no constrained layout, which drew each figure
    twice): whatever the frame's shape and however many lines the title has, the title, tick labels,
    axis labels and the colour bar's text lie inside the figure, and the map's pixels are square
    (a strip of a few rows is drawn at least 1.5 in high, stretched)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    rng = np.random.default_rng(0)
    image = rng.uniform(-12345.0, 12345.0, shape)
    for name in ("error_mm", "depth_std_mm"):  # a title of two lines, and of one
        title, unit, cmap = frameio.MAPS[name]
        fig = frameio.map_figure(image, title, unit, cmap)
        canvas = FigureCanvasAgg(fig)
        canvas.draw()  # places the axis labels
        renderer = canvas.get_renderer()
        drawn = fig.get_tightbbox(renderer)  # every drawn artist's extent, inches
        width_in, height_in = fig.get_size_inches()
        assert drawn.x0 >= -0.01 and drawn.y0 >= -0.01 and drawn.x1 <= width_in + 0.01 and drawn.y1 <= height_in + 0.01, \
            (shape, name, drawn, (width_in, height_in))
        # The title stands above the map.
        map_box = fig.axes[0].get_window_extent(renderer)
        assert fig.axes[0].title.get_window_extent(renderer).y0 >= map_box.y1
        width, height = map_box.width, map_box.height
        if min(width, height) > frameio.MAP_MIN_IN * fig.dpi + 1:  # not a strip drawn at its least height
            assert width / height == pytest.approx(shape[1] / shape[0], rel=1e-2)
        else:
            assert min(width, height) == pytest.approx(frameio.MAP_MIN_IN * fig.dpi, abs=1.0)


@pytest.mark.parametrize("args, message", [
    (["--scene", "walll"], "--scene 'walll' is not a built-in scene: allowed wall, "),
    (["--scene", "wall:distance_m=-2"], "--scene wall: distance_m = -2 is out of range: allowed 0.01 <= value <= 1000"),
    (["--scene", "wall:size=2"], "--scene wall: 'size' is not a parameter of wall: allowed distance_m, reflectivity"),
    (["--scene", "wall", "--frames", "5", "--keep-frames", "6"], "--keep-frames = 6 is out of range"),
    (["--scene", "missing.npz"], "--scene missing.npz: no such file"),
    (["--scene", "wall", "--sun", "0,0"], "argument --sun: '0,0' is not a direction"),
])
def test_render_refuses_bad_input_in_one_line(tmp_path, capsys, monkeypatch, args, message):
    monkeypatch.chdir(tmp_path)  # "missing.npz" is looked up here
    code, _, stderr = _cli(capsys, "render", *args, "--out", str(tmp_path / "o"), "--check")
    assert code == 2
    errors = [line for line in stderr.splitlines() if line.startswith("tofjax: error:")]
    assert len(errors) == 1 and message in errors[0] and "Traceback" not in stderr


def test_sharded_map_compiles_once_per_function():
    """A second call of sharded_map with the same function and shapes runs the program it built
    (fn traced once; it was traced and compiled again on every call, 1.3 s for 16 frames)."""
    traced = []

    def fn(x):
        traced.append(1)
        return 2.0 * x

    for _ in range(2):
        np.testing.assert_array_equal(tj.parallel.sharded_map(fn, jnp.arange(3.0)), [0.0, 2.0, 4.0])
    assert len(traced) == 1
    # A function that is a new object at every access (a prepared camera's method, tofjax._jit.method)
    # still runs, built per call.
    params, settings = small(), tj.FrameSettings(subpixel_samples=1)
    camera = tj.Camera(params, settings).prepare()
    walls = jax.vmap(lambda d: tj.Camera(params, settings).returns(scenes.wall(d)))(jnp.array([1.0, 1.5]))
    np.testing.assert_allclose(tj.parallel.sharded_map(camera.noise_image, walls)[1],
                               camera.noise_image(tj.Camera(params, settings).returns(scenes.wall(1.5))), rtol=1e-12)


def test_sharded_over_two_cpu_devices_equals_unsharded(tmp_path):
    """Scenes sharded over 2 host devices (XLA_FLAGS=--xla_force_host_platform_device_count=2): the
    same noise images as one device."""
    script = textwrap.dedent(f"""
        import jax, jax.numpy as jnp, numpy as np, equinox as eqx
        import tofjax as tj
        from tofjax import scenes
        assert len(jax.devices()) == 2, jax.devices()
        p = eqx.tree_at(lambda q: q.camera.optical_area_m, tj.Params(), jnp.array([{COLS * PITCH!r}, {ROWS * PITCH!r}]))
        s = tj.FrameSettings(subpixel_samples=1)
        d = jnp.array([0.8, 1.1, 1.7])
        noise = lambda x: tj.predict(tj.Camera(p, s), scenes.wall(x)).depth_std_m
        sharded = tj.parallel.sharded_map(noise, d)
        single = jnp.stack([noise(x) for x in d])
        np.testing.assert_allclose(sharded, single, rtol=1e-12)
        print("ok", sharded.shape, len(sharded.sharding.device_set) if hasattr(sharded, "sharding") else 0)
    """)
    env = {**os.environ, "XLA_FLAGS": os.environ.get("XLA_FLAGS", "") + " --xla_force_host_platform_device_count=2"}
    proc = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, env=env, cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert "ok (3, 21, 31)" in proc.stdout


def _flags(params, settings, geometry, **kwargs):
    frame = tj.predict(tj.Camera(params, settings), geometry)
    return frame, np.asarray(frame.flags)


def test_every_flag_on_a_scene_built_to_trigger_it(params, one_ray):
    """Each bit of tj.schema.FLAGS where the closed form says, and nowhere else; good pixels are unflagged."""
    du = float(params.unambiguity_range_m)
    # Wrapped: a wall at 1.7 m, whose off-axis pixels lie beyond d_u = 1.866 m (radial = z / cos).
    frame, flags = _flags(params, one_ray, scenes.wall(1.7))
    radial = np.asarray(frame.radial_true_m)
    assert radial.min() < du < radial.max()
    np.testing.assert_array_equal(flags, np.where(radial >= du, FLAG_WRAPPED, 0))
    # Mixed: a step whose edge (at the board's 1 m) cuts the pixel column right of the axis, a fifth of
    # a pixel right of its centre (3 x 3 rays): that column only.
    three = tj.FrameSettings(subpixel_samples=3)
    d = np.asarray(tj.optics.frame_rays(params, one_ray).centre)[CENTRE[0]]
    x = d[:, 0] / d[:, 2]
    x_edge = float(x[CENTRE[1] + 1] + 0.2 * (x[CENTRE[1] + 2] - x[CENTRE[1] + 1]))
    frame, flags = _flags(params, three, scenes.step_edge(1.0, 1.4, x_edge))
    columns = np.unique(np.nonzero(flags & 16)[1])
    assert columns.tolist() == [CENTRE[1] + 1] and np.all(flags[:, columns[0]] == FLAG_MIXED)
    assert np.all(np.delete(flags, columns, 1) == 0)
    assert np.all(np.asarray(frame.delivered))  # the truth's diagnostics never remove a pixel
    assert len(frame.points_m()) == flags.size
    # The column is the one whose returns come from both surfaces.
    paths = np.asarray(tj.Camera(params, three).returns(scenes.step_edge(1.0, 1.4, x_edge)).path_m)
    both = np.ptp(paths, axis=-1) > 0.5
    np.testing.assert_array_equal(np.unique(np.nonzero(both)[1]), columns)
    # No return: a wall of reflectivity 0 (no light comes back), and a sphere's surroundings (no surface).
    # A frame without a good pixel says so, and why (it had read plausible numbers in silence).
    with pytest.warns(tj.schema.NoGoodPixelsWarning, match=r"^no good pixel: every pixel is flagged \(100.0 % low "
                      r"signal, 100.0 % no return\); the pixels see no surface the illumination lights$"):
        _, flags = _flags(params, one_ray, scenes.wall(1.0, 0.0))
    assert np.all(flags & FLAG_NO_RETURN) and np.all(flags & FLAG_LOW_SIGNAL)  # and no signal: low signal too
    frame, flags = _flags(params, one_ray, scenes.sphere(1.2, 0.1, 0.9))
    np.testing.assert_array_equal((flags & FLAG_NO_RETURN) != 0, ~np.isfinite(np.asarray(frame.radial_true_m)))
    # Outside the illumination: an illumination cone of 20 degrees (diagonal) in a camera of 75.
    narrow = eqx.tree_at(lambda p: p.illumination.fov_deg, params, jnp.asarray(20.0))
    with pytest.warns(tj.schema.NoGoodPixelsWarning):  # the lit pixels saturate: none is good
        frame, flags = _flags(narrow, one_ray, scenes.wall(1.0))
    angle = np.degrees(np.arccos(np.asarray(frame.direction)[..., 2]))
    np.testing.assert_array_equal((flags & FLAG_OUTSIDE_ILLUMINATION) != 0, angle > 10.0)
    assert np.all(flags[angle > 10.0] & FLAG_NO_RETURN)  # no light comes back from there either
    # Saturated: a wall at 5 cm; low signal and low amplitude from the expected (analytic) values.
    with pytest.warns(tj.schema.NoGoodPixelsWarning, match=r"\(100.0 % saturated, 100.0 % low signal\); the scene "
                                                           r"is too close or too bright"):
        _, flags = _flags(params, one_ray, scenes.wall(0.05))
    assert np.all(flags & FLAG_SATURATED)
    frame, flags = _flags(params, one_ray, scenes.wall(1.5, 0.1))  # a dark wall: the noisy corners flagged
    phase = np.asarray(frame.quality.expected_phase_std_rad)
    np.testing.assert_array_equal((flags & FLAG_LOW_SIGNAL) != 0, phase > 0.3)
    assert 0 < np.sum(phase > 0.3) < phase.size
    amplitude = np.asarray(frame.result.amplitude_mean_lsb)
    threshold = float(np.median(amplitude))
    picky = dataclasses.replace(one_ray, min_amplitude_lsb=jnp.asarray(threshold))
    _, flags = _flags(params, picky, scenes.wall(1.0))
    np.testing.assert_array_equal((flags & FLAG_LOW_AMPLITUDE) != 0, np.asarray(tj.predict(tj.Camera(params, picky), scenes.wall(1.0)).result.amplitude_mean_lsb) < threshold)


def test_monte_carlo_low_signal_comes_from_the_expected_noise_not_two_frames(params, one_ray):
    """Two frames of a black wall agree by chance in some pixels: they are flagged all the same. A pixel
    that receives no light has no valid frame (its phase is noise alone), in the statistics, in the
    noisy frames and in the analytic frame."""
    returns = tj.Camera(params, one_ray).returns(scenes.wall(1.0, 0.0))
    with pytest.warns(tj.schema.NoGoodPixelsWarning, match="^no good pixel: every pixel is flagged"):
        frame = tj.simulate(tj.Camera(params, one_ray), returns, jax.random.key(3), 2)
    assert np.all(np.asarray(frame.flags) & FLAG_LOW_SIGNAL) and np.all(np.asarray(frame.flags) & FLAG_NO_RETURN)
    assert np.all(np.asarray(frame.result.valid_fraction) == 0) and np.all(np.isnan(np.asarray(frame.radial_m)))
    exposed = tj.Camera(params, one_ray).expose(returns)
    assert not np.any(np.asarray(exposed.sample(jax.random.key(4), 2).valid))
    assert np.all(np.asarray(exposed.predict().result.valid_fraction) == 0)
