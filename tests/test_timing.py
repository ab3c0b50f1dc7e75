"""Frame timing and the eye-safety estimate (tofjax._timing; docs/model.md "Frame timing and eye
safety"): the timing in closed form, the IEC 60825-1 limits against their published values, the
aperture's share of a uniform cone in closed form, the refusals, and gradients."""

import equinox as eqx
import jax
import numpy as np
import pytest

import tofjax as tj
from tofjax._timing import check_frame_rate, describe


def with_values(**dotted):
    config = tj.Config()
    for key, value in dotted.items():
        config = config.replace(key, value)
    return config


def test_the_frame_in_time_in_closed_form():
    """4 phase images of 2 ms read out in 1 ms each: exposure 4 x 2 + 3 x 1 = 11 ms, at most 1/12 ms;
    at 5 frames/s lit 8 ms of 200 (4 %); the average power is peak x waveform mean x 4 %. Two
    frequencies double the phase images; a frame rate of 0 runs as fast as they allow."""
    camera = tj.Camera.from_config(tj.Config())
    t = camera.timing
    mean = float(tj.waveforms.waveform_mean(camera.params.illumination_waveform))
    assert t.phase_images == 4
    np.testing.assert_allclose([t.exposure_time_s, t.max_frame_rate_hz, t.frame_rate_hz, t.lit_fraction],
                               [11e-3, 1 / 12e-3, 5.0, 0.04], rtol=1e-12)
    np.testing.assert_allclose([t.lit_power_w, t.average_power_w], [1.2 * mean, 1.2 * mean * 0.04], rtol=1e-12)
    dual = tj.Camera(camera.params, frequencies_hz=[80.32e6, 60.24e6]).timing
    assert dual.phase_images == 8
    np.testing.assert_allclose(dual.exposure_time_s, 8 * 2e-3 + 7 * 1e-3, rtol=1e-12)
    fastest = tj.Camera.from_config(with_values(**{"timing.frame_rate_hz": 0.0})).timing
    np.testing.assert_allclose([fastest.frame_rate_hz, fastest.lit_fraction], [1 / 12e-3, 2 / 3], rtol=1e-12)


def test_a_frame_rate_the_phase_images_do_not_fit_is_refused():
    """In Python as on the command line: camera.timing (and so camera.eye_safety) refuses it; 10 000
    frames/s of 4 x 2 ms phase images was a lit fraction of 80."""
    camera = tj.Camera.from_config(with_values(**{"timing.frame_rate_hz": 120.0}))
    with pytest.raises(ValueError, match=r"timing.frame_rate_hz = 120 is out of range: 4 phase images of 2 ms, each "
                                         r"read out in 1 ms, allow at most 83.33 Hz"):
        camera.timing  # noqa: B018 - the property refuses
    fast = tj.Camera.from_config(with_values(**{"timing.frame_rate_hz": 10_000.0, "timing.readout_time_s": 0.0}))
    for what in ("timing", "eye_safety"):
        with pytest.raises(ValueError, match=r"^timing.frame_rate_hz = 10000 is out of range: 4 phase images of 2 ms, "
                                             r"each read out in 0 ms, allow at most 125 Hz \(0 = that\)$"):
            getattr(fast, what)
    check_frame_rate(tj.Camera.from_config(tj.Config()).timing)  # the default fits


@pytest.mark.parametrize("wavelength_nm, limit_mw", [(850, 0.78), (940, 1.18)])
def test_the_class_1_limits_are_the_published_ones(wavelength_nm, limit_mw):
    """IEC 60825-1:2014 class 1, small source, t > T2: 3.9e-4 C4 W with C4 = 10^(0.002 (lambda - 700)):
    0.78 mW at 850 nm and 1.18 mW at 940 nm (to the standard's two digits); one pulse of 2 ms: 7e-4
    t^0.75 C4 J; a pulse of T2 = 10 s meets the power limit x T2."""
    p = eqx.tree_at(lambda q: q.illumination.wavelength_m, tj.Params(), wavelength_nm * 1e-9)
    safety = tj.Camera(p).eye_safety
    c4 = 10 ** (0.002 * (wavelength_nm - 700))
    np.testing.assert_allclose(safety.c4, c4, rtol=1e-12)
    np.testing.assert_allclose(1e3 * safety.average_limit_w, limit_mw, rtol=0.01)
    np.testing.assert_allclose(safety.pulse_limit_j, 7e-4 * 2e-3**0.75 * c4, rtol=1e-12)
    from tofjax._timing import _pulse_limit_j

    np.testing.assert_allclose(_pulse_limit_j(10.0, c4), 10.0 * safety.average_limit_w, rtol=1e-12)


def _cone_share(theta_c, half, n, alpha, steps=400):
    """The share of a round beam (half-angle ``half``, irradiance cos^n on a plane) in the cone of
    half-angle ``alpha`` about the polar angle ``theta_c``: the intensity (1 + tan^2)^((3 - n) / 2) / S
    summed over a midpoint grid of the cone, zero outside the beam."""
    t = np.tan(half)
    m = 1 - n / 2
    s = np.pi * np.log1p(t * t) if m == 0 else np.pi * np.expm1(m * np.log1p(t * t)) / m
    beta, phi = np.meshgrid((np.arange(steps) + 0.5) / steps * alpha, (np.arange(steps) + 0.5) / steps * 2 * np.pi,
                            indexing="ij")
    c, e1 = np.array([np.sin(theta_c), 0, np.cos(theta_c)]), np.array([np.cos(theta_c), 0, -np.sin(theta_c)])
    ring = np.cos(phi)[..., None] * e1 + np.sin(phi)[..., None] * np.cross(c, e1)
    v = np.cos(beta)[..., None] * c + np.sin(beta)[..., None] * ring
    tan2 = (v[..., 0] ** 2 + v[..., 1] ** 2) / v[..., 2] ** 2
    intensity = np.where(tan2 <= t * t, (1 + tan2) ** (1.5 - n / 2) / s, 0.0)
    return np.sum(intensity * np.sin(beta)) * (alpha / steps) * (2 * np.pi / steps)


def test_the_aperture_takes_its_share_of_the_beam_and_never_more_than_all_of_it():
    """With the falloff exponent 3 the illumination's intensity is uniform over its cone (cos^0), so the
    7 mm aperture at 100 mm takes its solid angle's share of the cone's: 2 pi (1 - 100/hypot(100, 3.5))
    / (2 pi (1 - cos(FoV/2))). The thesis' flat spot (0) is brightest at its rim, (1 + tan^2)^1.5 / (pi
    tan^2) per steradian: the aperture collects most just inside it, the cone's integral there, and
    more than wherever else its centre stands (the rim itself: half the cone outside the beam). A beam
    narrower than the aperture's cone is collected whole: a 1-degree beam gave 16x its power (the
    intensity at its brightest direction times the aperture's solid angle), [179, 1] degrees 1446x."""
    params = tj.Params()
    alpha = np.arctan(3.5e-3 / 0.1)
    aperture = 1 - np.cos(alpha)
    half = np.deg2rad(75.0) / 2
    cone = tj.Camera(params, tj.FrameSettings(illumination_falloff_exponent=3.0)).eye_safety
    np.testing.assert_allclose(cone.aperture_fraction, aperture / (1 - np.cos(half)), rtol=1e-10)
    flat = tj.Camera(params).eye_safety
    inside = _cone_share(half - alpha, half, 0.0, alpha)
    np.testing.assert_allclose(flat.aperture_fraction, inside, rtol=1e-4)
    assert all(_cone_share(half - alpha * k, half, 0.0, alpha) < inside for k in (0.0, 0.5, 1.5, 3.0))

    def fraction(fov_deg, n=0.0):
        p = eqx.tree_at(lambda q: q.illumination.fov_deg, params, np.asarray(fov_deg, dtype=float))
        return float(tj.Camera(p, tj.FrameSettings(illumination_falloff_exponent=n)).eye_safety.aperture_fraction)

    assert fraction(1.0) == pytest.approx(1.0, abs=1e-12) and fraction([1.0, 1.0]) == pytest.approx(1.0, abs=1e-12)
    assert fraction([179.0, 1.0]) < 1e-3  # a fan: the aperture sees a sliver of it
    np.testing.assert_allclose(fraction(6.0), _cone_share(np.deg2rad(3.0) - alpha, np.deg2rad(3.0), 0.0, alpha), rtol=1e-4)
    shares = [fraction(fov, n) for n in (0.0, 3.0, 20.0) for fov in (0.5, 4.0, 4.01, 10.0, 75.0, 179.0, [3.0, 60.0],
                                                                      [4.5, 4.5], [60.0, 45.0], [179.0, 179.0])]
    assert max(shares) <= 1.0 + 1e-12 and min(shares) > 0.0
    # Every accessible emission is that share of the power over its time.
    timing = tj.Camera(params).timing
    np.testing.assert_allclose(flat.pulse_j, flat.aperture_fraction * timing.lit_power_w * 2e-3, rtol=1e-12)
    np.testing.assert_allclose(flat.burst_j, 4 * flat.pulse_j, rtol=1e-12)
    np.testing.assert_allclose(flat.average_w, flat.aperture_fraction * timing.average_power_w, rtol=1e-12)


def test_the_summary_lines_and_what_is_not_estimated():
    camera = tj.Camera.from_config(tj.Config())
    frame, safety = describe(camera.params, camera.timing, camera.eye_safety)
    assert frame.startswith("frame: 4 phase images of 2 ms, each read out in 1 ms: exposure 11 ms; 5 frames/s")
    assert "within the limit" in safety and "an estimate against IEC 60825-1:2014 class 1 at 850 nm" in safety
    strong = tj.Camera.from_config(with_values(**{"illumination.peak_power_w": 20.0, "timing.frame_rate_hz": 0.0}))
    assert "ABOVE the limit" in describe(strong.params, strong.timing, strong.eye_safety)[1]
    red = tj.Camera.from_config(with_values(**{"illumination.wavelength_m": 650e-9,
                                               "pixel.photo_responsivity_a_per_w": 0.2}))
    line = describe(red.params, red.timing, red.eye_safety)[1]
    assert line.startswith("eye safety: not estimated: the wavelength 650 nm is outside the 700-1050 nm")


def test_the_ratio_is_linear_in_the_peak_power_and_differentiable():
    """d ratio / d peak power = ratio / peak power (every emission is proportional to it)."""
    params = tj.Params()

    def ratio(p):
        return tj.Camera(p).eye_safety.ratio

    grad = jax.grad(ratio)(params).illumination.peak_power_w
    np.testing.assert_allclose(grad, ratio(params) / 1.2, rtol=1e-12)
