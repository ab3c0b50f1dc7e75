"""The expected electrons of each tap in each phase image: what the exposure (:mod:`tofjax._mixer`,
:class:`tofjax._frame.FrameExposure`) hands to the noise, the limit and the readout (Eqs 3.19-3.21)."""

from __future__ import annotations

import equinox as eqx
from jaxtyping import Array, Float


class TapCharges(eqx.Module):
    """Expected electrons of one phase image, before any noise or limit.

    **Fields** (``*b`` is the batch shape of the operating points):
    - ``photo_a``, ``photo_b``: photo-electrons (signal and background) of tap A and B, ``(*b, phases)``;
    - ``dark_a``, ``dark_b``: dark electrons of each tap, ``(*b,)``;
    - ``signal_e``, ``background_e``: active and background photo-electrons of the pixel (both taps).
    """

    photo_a: Float[Array, "*b phases"]
    photo_b: Float[Array, "*b phases"]
    dark_a: Float[Array, "*b"]
    dark_b: Float[Array, "*b"]
    signal_e: Float[Array, "*b"]
    background_e: Float[Array, "*b"]

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
        (:meth:`tofjax._frame.FrameExposure.charges`, which makes them)."""
        return self
