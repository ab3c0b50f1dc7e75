"""What a pixel collects in each phase image (:class:`Exposure`) and the expected electrons of each tap
that it splits into (:class:`TapCharges`, Eqs 3.19-3.21): what the exposure hands to the noise, the
limit and the readout."""

from __future__ import annotations

import equinox as eqx
import jax.numpy as jnp
from jax import lax
from jaxtyping import Array, Float


class TapCharges(eqx.Module):
    """Expected electrons of one phase image, before any noise or limit.

    **Fields** (``*b`` is the batch shape of the operating points):
    - ``photo_a``, ``photo_b``: photo-electrons (signal and background) of tap A and B, ``(*b, phases)``;
    - ``dark_a``, ``dark_b``: dark electrons of each tap, ``(*b,)``;
    - ``signal_e``, ``background_e``: active and background photo-electrons of the pixel (both taps);
    - ``temperature_c``: the sensor's temperature at each operating point, ``(*b,)`` (a temperature
      sweep: the kTC noise sources read it), or ``None``: the pixel's ``temperature_c``.
    """

    photo_a: Float[Array, "*b phases"]
    photo_b: Float[Array, "*b phases"]
    dark_a: Float[Array, "*b"]
    dark_b: Float[Array, "*b"]
    signal_e: Float[Array, "*b"]
    background_e: Float[Array, "*b"]
    temperature_c: Float[Array, "*b"] | None = None

    @property
    def a(self) -> Float[Array, "*b phases"]:
        """All electrons of tap A: photo plus dark."""
        return self.photo_a + self.dark_a[..., None]

    @property
    def b(self) -> Float[Array, "*b phases"]:
        """All electrons of tap B: photo plus dark."""
        return self.photo_b + self.dark_b[..., None]

    @property
    def dark_e(self) -> Float[Array, "*b"]:
        """Dark electrons of both taps."""
        return self.dark_a + self.dark_b

    def charges(self) -> TapCharges:
        """Themselves: what reads tap charges takes these or a frame's exposure
        (:meth:`Exposure.charges`, which makes them)."""
        return self


def written_out(x: Float[Array, "*b n"]) -> Float[Array, "*b n"]:
    """``x`` (its last axis short), written to memory inside a larger program: its product with the
    identity, exact for finite values. XLA on a CPU does not fuse a dot into its consumers, and it
    removes ``lax.optimization_barrier`` before fusion. Both taps, and inside one program every
    consumer of theirs, read the exposure's modulated sum; XLA otherwise evaluated its table lookups
    once per consumer, or wrote out every point's gathered table rows (docs/model.md, "Performance",
    measurements 14 and 29)."""
    return jnp.einsum("...j,jk->...k", x, jnp.eye(x.shape[-1], dtype=x.dtype), precision=lax.Precision.HIGHEST)


class Exposure(eqx.Module):
    """What a pixel collected in each phase image, before the taps split it (Eqs 3.19-3.21), for any
    batch of pixels or operating points (a frame: ``(rows, cols)`` leading axes; a sweep: its
    shape). :meth:`charges` is the one tap split: it makes the taps' :class:`TapCharges` elementwise.
    The centre pixel's sweeps (:func:`tofjax._mixer.expose`) and the frames
    (:meth:`tofjax.PreparedCamera.expose`) both make one.

    The frame's programs and ``predict``'s hand this on rather than the tap charges: both taps read
    the modulated sum, and XLA on a CPU does not duplicate its table lookups into two consumers; it
    materialises every return's gathered table row instead (nine 38528 x 16 arrays for 224 x 172
    pixels; docs/model.md, "Performance", measurements 10 and 26). Materialised once, as this
    program's output, it is read by both.

    **Fields** (a frame's shapes): ``modulated_e`` ``(rows, cols, phases)``: K sum_r N_r a_j(delay_r), the modulated
    electrons tap A collects (K the demodulation contrast, N_r the active electrons of return r);
    ``signal_e``: sum_r N_r; ``background_e``; ``contrast``: K; ``tap_asymmetry``: e, tap A
    collecting 1 + e and tap B 1 - e of the photo charge; ``dark_a_e``, ``dark_b_e``.
    """

    modulated_e: Float[Array, "rows cols phases"]
    signal_e: Float[Array, "rows cols"]
    background_e: Float[Array, "rows cols"]
    contrast: Float[Array, ""]
    tap_asymmetry: Float[Array, "rows cols"] | Float[Array, ""]
    dark_a_e: Float[Array, "rows cols"]
    dark_b_e: Float[Array, "rows cols"]

    def written_out(self) -> Exposure:
        """The exposure with its modulated sum written out (:func:`written_out`), for a program that
        reads its charges in many places."""
        return eqx.tree_at(lambda e: e.modulated_e, self, written_out(self.modulated_e))

    def charges(self, temperature_c: Float[Array, "*b"] | None = None) -> TapCharges:
        """The taps' expected electrons (``temperature_c``: the sensor's, per point, for
        :attr:`TapCharges.temperature_c`): K N a_j plus half of (1 - K) N and of the background to
        tap A, the rest of K N plus the same halves to tap B (Eqs 3.19-3.21), scaled by 1 +- e. A
        moving scene's ``signal_e`` has a phase axis (each phase image its own light); its charges'
        ``signal_e`` is then the mean over the phase images."""
        m = self.modulated_e
        per_phase = jnp.ndim(self.signal_e) == m.ndim
        signal = self.signal_e if per_phase else self.signal_e[..., None]
        equal = 0.5 * (1.0 - self.contrast) * signal + 0.5 * self.background_e[..., None]
        e = jnp.asarray(self.tap_asymmetry)
        e = e if e.ndim == 0 else e[..., None]  # one for every pixel, or each pixel's own
        photo_a = (m + equal) * (1.0 + e)
        photo_b = (self.contrast * signal - m + equal) * (1.0 - e)
        mean_signal = jnp.mean(self.signal_e, axis=-1) if per_phase else self.signal_e
        return TapCharges(photo_a, photo_b, self.dark_a_e, self.dark_b_e, mean_signal, self.background_e, temperature_c)
