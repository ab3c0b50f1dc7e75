"""The pixel's temporal noise sources and the one noise budget (thesis §2.4.2, §3.2.3, §4.2.12-4.2.14).

Every source is one small class that states

- where it acts: :data:`BEFORE_LIMIT` (on a tap's collected charge, before SBI and saturation) or
  :data:`AFTER_LIMIT` (on the held charge, after them);
- its variance per tap and phase image, in electrons^2 at the integration node, from the expected
  charges (:class:`tofjax._charges.TapCharges`);
- how it is sampled: Gaussian, independent per tap, phase image and frame. Sources acting at one node
  are independent Gaussians, so the Monte Carlo draws their sum once per tap and node.

The chain places the sources of each node as one :class:`Noise` stage, before and after the limit
(:func:`tofjax.chain.build_chain`): a source acts where its stage stands in the chain's tuple. The
:class:`NoiseBudget` is every source, for the noise breakdown (:class:`tofjax.NoiseBreakdown`) and
the closed-form estimates, so a new source is one class here, added to :data:`NOISE_SOURCES`
(docs/model.md, "Adding a noise source").

Electrons are referred to the integration node (conversion gain e / C_int, C_int = C_diode +
C_sample&hold):

- photon shot noise: Poisson, variance = mean, of every photo-electron a tap collects (signal and
  background, including those SBI later compensates) (Eq 2.24);
- dark shot noise: variance = the mean dark electrons, slope t C_int / e per tap (§4.2.14). The
  thesis' "dark slope sigma" is the pixel-to-pixel (fixed-pattern) spread, not temporal noise
  (docs/model.md);
- reset noise: kTC on the integration capacitance, sqrt(k T C_int) / e (Eq 2.22);
- hold noise: kTC of the sample-and-hold switch on C_sample&hold, sqrt(k T / C_sh) volts, i.e.
  C_int sqrt(k T / C_sh) / e electrons, after SBI and saturation (the readout samples the held
  charge);
- readout noise: the rest of the readout chain (source follower, column amplifier, ADC input) as
  one rms number per tap from a data sheet, ``pixel.readout_noise_e`` (0 by default; the thesis
  models none), after SBI and saturation.
"""

from __future__ import annotations

import abc
from typing import TYPE_CHECKING, ClassVar

import equinox as eqx
import jax.numpy as jnp
from jaxtyping import Array, Float

from . import _constants as const
from ._params import Params, PhysicalConstants, Pixel
from ._reduce import mean_last
from ._stages import AbstractStage, Moments, replace

if TYPE_CHECKING:
    from ._charges import TapCharges
    from ._result import NoiseBreakdown

#: A source acting on the collected tap charge, before SBI and saturation.
BEFORE_LIMIT = "before_limit"
#: A source acting on the held tap charge, after SBI and saturation.
AFTER_LIMIT = "after_limit"


def _kelvin(temperature_c: Array) -> Array:
    return temperature_c + const.ZERO_CELSIUS_K


def reset_noise_e(pixel: Pixel, constants: PhysicalConstants) -> Float[Array, ""]:
    """Reset (kTC) noise of one tap, electrons rms: sqrt(k T C_int) / e (Eqs 2.21-2.22)."""
    c = pixel.integration_capacitance_f
    return jnp.sqrt(constants.boltzmann_j_per_k * _kelvin(pixel.temperature_c) * c) / constants.elementary_charge_c


def hold_noise_e(pixel: Pixel, constants: PhysicalConstants) -> Float[Array, ""]:
    """Sample-and-hold (kTC) noise of one tap, in electrons at the integration node, rms."""
    v = jnp.sqrt(constants.boltzmann_j_per_k * _kelvin(pixel.temperature_c) / pixel.c_sample_and_hold_f)
    return v * pixel.integration_capacitance_f / constants.elementary_charge_c


def dark_current_factor(pixel: Pixel, temperature_c: Array | None = None) -> Float[Array, "*b"]:
    """The dark current at the sensor's temperature over that at the dark slopes' reference
    temperature: 2^((T - T_ref) / T_2), the dark current doubling every T_2 ("the dark current can
    double for every 5 °C ... 8 °C temperature increase": A. Theuwissen, Harvest Imaging blog,
    September 2009, harvestimaging.com/blog/?m=200909; docs/model.md, "Noise"). Exactly 1 at the
    reference temperature. ``temperature_c``: the sensor's temperature per operating point (``None``:
    ``pixel.temperature_c``)."""
    t = pixel.temperature_c if temperature_c is None else temperature_c
    return 2.0 ** ((t - pixel.dark_reference_temperature_c) / pixel.dark_doubling_temperature_c)


def dark_electrons(
    pixel: Pixel, integration_time_s: Float[Array, "*b"], constants: PhysicalConstants, slope_v_per_s=None,
    temperature_c: Array | None = None,
) -> Float[Array, "*b"]:
    """Mean dark electrons of one tap: slope t C_int / e (§4.2.14), the slope (the mean's, or a
    pixel's own from the fixed pattern) scaled to the sensor's temperature (:func:`dark_current_factor`;
    ``temperature_c`` per operating point, ``None``: ``pixel.temperature_c``)."""
    slope = pixel.dark_slope_mean_v_per_s if slope_v_per_s is None else slope_v_per_s
    slope = slope * dark_current_factor(pixel, temperature_c)
    return slope * integration_time_s * pixel.integration_capacitance_f / constants.elementary_charge_c


class AbstractNoiseSource(eqx.Module):
    """A temporal noise source: Gaussian, independent per tap, phase image and frame.

    **Class attributes:** ``name`` (the key in :attr:`tofjax.NoiseBreakdown.sources` and the CSV
    column ``noise_<name>_e``), ``node`` (:data:`BEFORE_LIMIT` or :data:`AFTER_LIMIT`), ``read``
    (counted as read noise in the photon transfer curve, §5.5.1; else as photon shot noise).
    """

    name: ClassVar[str]
    node: ClassVar[str]
    read: ClassVar[bool]

    @classmethod
    @abc.abstractmethod
    def from_params(cls, params: Params) -> AbstractNoiseSource:
        """The source with its parameters taken from the camera."""

    @abc.abstractmethod
    def variance_e2(self, charges: TapCharges) -> tuple[Array, Array]:
        """Variances of taps A and B, electrons^2, broadcastable to ``(*b, phases)``."""


class PhotonShotNoise(AbstractNoiseSource):
    """Shot noise of the photo-electrons (signal and background), variance = mean (Eq 2.24)."""

    name: ClassVar[str] = "photon_shot"
    node: ClassVar[str] = BEFORE_LIMIT
    read: ClassVar[bool] = False

    @classmethod
    def from_params(cls, params: Params) -> PhotonShotNoise:
        return cls()

    def variance_e2(self, charges: TapCharges) -> tuple[Array, Array]:
        return charges.photo_a, charges.photo_b


class DarkShotNoise(AbstractNoiseSource):
    """Shot noise of the dark electrons, variance = mean (§2.4.2.4, §4.2.14)."""

    name: ClassVar[str] = "dark_shot"
    node: ClassVar[str] = BEFORE_LIMIT
    read: ClassVar[bool] = True

    @classmethod
    def from_params(cls, params: Params) -> DarkShotNoise:
        return cls()

    def variance_e2(self, charges: TapCharges) -> tuple[Array, Array]:
        return charges.dark_a[..., None], charges.dark_b[..., None]


class AbstractConstantNoise(AbstractNoiseSource):
    """A source of the same rms ``sigma_e`` on each tap, whatever the charges (kTC, readout)."""

    sigma_e: eqx.AbstractVar[Float[Array, ""]]

    def variance_e2(self, charges: TapCharges) -> tuple[Array, Array]:
        return self.sigma_e**2, self.sigma_e**2


class AbstractThermalNoise(AbstractConstantNoise):
    """A kTC source: ``sigma_e`` at the pixel's temperature ``temperature_k``; its variance k T C / e^2
    is proportional to the absolute temperature, so at operating points of their own temperature
    (:attr:`tofjax._charges.TapCharges.temperature_c`, a temperature sweep) it scales by T / T_pixel
    (exactly 1 at the pixel's own)."""

    temperature_k: eqx.AbstractVar[Float[Array, ""]]

    def variance_e2(self, charges: TapCharges) -> tuple[Array, Array]:
        var = self.sigma_e**2
        if charges.temperature_c is not None:
            var = var * (_kelvin(charges.temperature_c) / self.temperature_k)[..., None]
        return var, var


class ResetNoise(AbstractThermalNoise):
    """kTC noise of the reset on the integration capacitance (Eqs 2.21-2.22)."""

    name: ClassVar[str] = "reset"
    node: ClassVar[str] = BEFORE_LIMIT
    read: ClassVar[bool] = True
    sigma_e: Float[Array, ""]
    temperature_k: Float[Array, ""]

    @classmethod
    def from_params(cls, params: Params) -> ResetNoise:
        return cls(reset_noise_e(params.pixel, params.constants), _kelvin(params.pixel.temperature_c))


class HoldNoise(AbstractThermalNoise):
    """kTC noise of the sample-and-hold, on the held charge (§4.2.12)."""

    name: ClassVar[str] = "hold"
    node: ClassVar[str] = AFTER_LIMIT
    read: ClassVar[bool] = True
    sigma_e: Float[Array, ""]
    temperature_k: Float[Array, ""]

    @classmethod
    def from_params(cls, params: Params) -> HoldNoise:
        return cls(hold_noise_e(params.pixel, params.constants), _kelvin(params.pixel.temperature_c))


class ReadoutNoise(AbstractConstantNoise):
    """The readout chain's noise beyond kTC (source follower, column amplifier, ADC input), per tap,
    on the held charge: a data sheet's read noise in electrons (``pixel.readout_noise_e``)."""

    name: ClassVar[str] = "readout"
    node: ClassVar[str] = AFTER_LIMIT
    read: ClassVar[bool] = True
    sigma_e: Float[Array, ""]

    @classmethod
    def from_params(cls, params: Params) -> ReadoutNoise:
        return cls(params.pixel.readout_noise_e)


#: The pixel's noise sources, in the order of the breakdown.
NOISE_SOURCES: tuple[type[AbstractNoiseSource], ...] = (ResetNoise, HoldNoise, PhotonShotNoise, DarkShotNoise,
                                                        ReadoutNoise)


def _variance_e2(sources, charges: TapCharges) -> tuple[Array, Array]:
    """Total variance of taps A and B from ``sources``, ``(*b, phases)``."""
    var_a = var_b = jnp.zeros(charges.photo_a.shape, charges.photo_a.dtype)
    for source in sources:
        a, b = source.variance_e2(charges)
        var_a, var_b = var_a + a, var_b + b
    return var_a, var_b


class Noise(AbstractStage):
    """The noise sources acting at one node, as a stage of the chain: before the limit they add
    their variances to each tap's, after it to the held differential's (Gaussian, independent per
    tap, phase image and frame; the Monte Carlo draws their sum, :mod:`tofjax._frames`).

    **Fields:** ``sources`` (:class:`AbstractNoiseSource` instances), ``enabled`` (``pixel.noise``;
    ``False``: they add nothing)."""

    sources: tuple[AbstractNoiseSource, ...]
    enabled: bool = eqx.field(static=True)

    def variance_e2(self, charges: TapCharges) -> tuple[Array, Array]:
        """Total variance of taps A and B from the stage's sources (0 when disabled), ``(*b, phases)``."""
        return _variance_e2(self.sources if self.enabled else (), charges)

    def moments(self, m: Moments) -> Moments:
        var_a, var_b = self.variance_e2(m.charges)
        if not m.limited:
            return replace(m, var_a=m.var_a + var_a, var_b=m.var_b + var_b)
        return replace(m, var_diff=m.var_diff + var_a + var_b, post_a=m.post_a + var_a, post_b=m.post_b + var_b)


class NoiseBudget(eqx.Module):
    """The noise sources of a camera. ``enabled`` (``pixel.noise``) switches their effect on the
    frames off; the breakdown still reports them."""

    sources: tuple[AbstractNoiseSource, ...]
    enabled: bool = eqx.field(static=True)

    @classmethod
    def from_params(cls, params: Params) -> NoiseBudget:
        return cls(tuple(source.from_params(params) for source in NOISE_SOURCES), params.pixel.noise)

    def variance_e2(self, charges: TapCharges, node: str) -> tuple[Array, Array]:
        """Total variance of taps A and B from the sources at ``node`` (0 when disabled), ``(*b, phases)``."""
        return self.stage(node).variance_e2(charges)

    def stage(self, node: str) -> Noise:
        """The :class:`Noise` stage of the sources at ``node``."""
        return Noise(tuple(source for source in self.sources if source.node == node), self.enabled)

    def breakdown(self, charges: TapCharges, quantization_e: Float[Array, ""]) -> NoiseBreakdown:
        """rms of every source in the differential A - B of one phase image (mean over the phases)."""
        from ._result import NoiseBreakdown

        shape = charges.signal_e.shape
        sources, read, total = {}, jnp.zeros(shape, charges.signal_e.dtype), jnp.zeros(shape, charges.signal_e.dtype)
        for source in self.sources:
            a, b = source.variance_e2(charges)
            var = mean_last(jnp.broadcast_to(a + b, charges.photo_a.shape))
            sources[source.name] = jnp.sqrt(var)
            total = total + var
            if source.read:
                read = read + var
        quant = jnp.broadcast_to(quantization_e, shape)
        return NoiseBreakdown(
            signal_e=charges.signal_e, background_e=charges.background_e, dark_e=charges.dark_e, sources=sources,
            read_e=jnp.sqrt(read), quantization_e=quant, total_e=jnp.sqrt(total + quant**2),
            source_names=tuple(source.name for source in self.sources),
        )
