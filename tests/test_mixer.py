"""The exposure: the 2-tap mixer's split of the photo-electrons (thesis §3.2.2, Eqs 3.19-3.21) and
the expected tap charges of an operating point (tofjax/_mixer.py)."""

import equinox as eqx
import jax.numpy as jnp
import numpy as np
import pytest
from helpers import split_between_taps

import tofjax
from tofjax._chain import build_chain
from tofjax._correlation import correlation


def _params(ref="pulse", ref_duty=0.5, ill="pulse", ill_duty=0.5, n=4):
    return tofjax.Params(
        pixel=tofjax.Pixel(n_phases=n),
        illumination_waveform=tofjax.IlluminationWaveform(shape=ill, duty_cycle=ill_duty),
        reference_waveform=tofjax.ReferenceWaveform(shape=ref, duty_cycle=ref_duty),
    )


def _photo(p, distance_m, active, background):
    delay = 2.0 * float(p.illumination_waveform.modulation_frequency_hz) * distance_m / 299_792_458.0
    fraction = correlation(p.illumination_waveform, p.reference_waveform, p.pixel.n_phases)(jnp.asarray(delay))
    return split_between_taps(fraction, p.pixel.demodulation_contrast, jnp.asarray(active), jnp.asarray(background))


@pytest.mark.parametrize("n", [2, 3, 4, 5])
def test_two_tap_pixel_conserves_charge(n):
    p = _params("gauss_extended", 0.5, "gauss_extended", 0.25, n)
    contrast = float(p.pixel.demodulation_contrast)
    a, b = _photo(p, 1.3, 1e4, 3e3)
    np.testing.assert_allclose(a + b, 1e4 + 3e3, rtol=1e-12)
    # Above the equally distributed share ((1 - K) / 2 of the active electrons plus half the
    # background) each tap holds between none and all of the K-modulated electrons.
    equal = 0.5 * (1 - contrast) * 1e4 + 1.5e3
    assert np.all(a >= equal - 1e-6) and np.all(a <= equal + contrast * 1e4 + 1e-6)


def test_contrast_scales_the_differential():
    p = _params()
    a1, b1 = _photo(p, 0.7, 1e4, 0.0)
    p2 = eqx.tree_at(lambda q: q.pixel.demodulation_contrast, p, jnp.asarray(0.21))
    a2, b2 = _photo(p2, 0.7, 1e4, 0.0)
    np.testing.assert_allclose(a2 - b2, 0.5 * (a1 - b1), rtol=1e-12)


def test_expose_splits_background_and_adds_dark_per_tap():
    """The background goes half to each tap, whatever the phase; each tap gets its own dark charge."""
    p = tofjax.Params(scene=tofjax.Scene(illuminance_lx=500.0))
    chain = build_chain(p)
    d = jnp.array([0.8, 2.3])
    q = chain.expose(d, jnp.full(2, 500.0), jnp.full(2, 2e-3), dark_slopes_v_per_s=(1.0, 3.0))
    dark = np.array([1.0, 3.0]) * 2e-3 * 14e-15 / 1.602176634e-19
    np.testing.assert_allclose([q.dark_a[0], q.dark_b[0]], dark, rtol=1e-12)
    np.testing.assert_allclose(q.a - q.b, q.photo_a - q.photo_b + (dark[0] - dark[1]), rtol=1e-9)
    np.testing.assert_allclose(np.asarray(q.photo_a + q.photo_b),
                               np.broadcast_to(np.asarray(q.signal_e + q.background_e)[:, None], (2, 4)), rtol=1e-12)
    no_light = chain.expose(d, jnp.full(2, 500.0), jnp.full(2, 2e-3))
    assert float(no_light.background_e[0]) > 0.1 * float(no_light.signal_e[0])


def test_the_exposure_written_out_is_the_same_exposure_with_the_same_gradient():
    """``Exposure.written_out`` (a product with the identity, so that XLA on a CPU writes the
    modulated sum once): every phase image's value in its own place, exactly, for 5 phases (an
    axis that is not a power of two) and a 2-D batch, and the same gradient through it."""
    import jax

    chain = build_chain(_params("gauss_extended", 0.5, "gauss_extended", 0.25, 5))
    d = jnp.linspace(0.4, 4.2, 6).reshape(2, 3)
    exposure = chain.exposure(d, jnp.full((2, 3), 300.0), jnp.full((2, 3), 1e-3))
    written = exposure.written_out()
    assert written.modulated_e.shape == (2, 3, 5)
    np.testing.assert_array_equal(written.modulated_e, exposure.modulated_e)
    np.testing.assert_array_equal(written.charges().a, exposure.charges().a)

    def tap_a(distance, write):
        e = chain.exposure(distance, jnp.full(3, 300.0), jnp.full(3, 1e-3))
        return jnp.sum((e.written_out() if write else e).charges().a * jnp.arange(5.0)[None, :])

    g = [jax.grad(tap_a)(d[0], write) for write in (True, False)]
    np.testing.assert_allclose(g[0], g[1], rtol=1e-13)
    assert np.all(np.abs(np.asarray(g[1])) > 0)
