"""Background light: illuminance in lux to in-band photon irradiance (thesis §3.1.2, §4.2.4).

The lamp spectrum E(lambda) (known up to a scale) is normalised so that its luminous value
K_m int V(lambda) E(lambda) dlambda equals the illuminance E_v on the target (Eqs 3.3-3.4). The
part that reaches the detector is integrated over the rectangular band-pass filter
[lambda - w, lambda + w] (w = 0: no filter), and only up to the silicon cut-off, because photons
beyond the band gap generate no electrons. Each wavelength is converted to photons with its own
photon energy h c / lambda (the thesis uses the illumination wavelength for all of them; the two
agree for a narrow filter). See docs/model.md, "Background light".

Spectra (files in ``tofjax/data`` with their provenance):
- sunlight: ASTM G173-03 global tilt (thesis Table 4.3 footnote);
- halogen: Planck radiator at 3200 K (tungsten-halogen lamps run at 3000-3200 K; 3200 K is the
  photographic/studio standard);
- incandescent: Planck radiator at 2856 K (CIE standard illuminant A);
- fluorescent: CIE FL2 (cool white), tabulated 380-780 nm;
- led: CIE LED-B3 (phosphor-converted white LED, about 4100 K, CIE 015:2018), tabulated 380-780 nm
  and continued beyond 780 nm by the exponential decay of its last 40 nm (the phosphor's red tail;
  a white LED emits no line in the near infrared, so at 850 nm this tail is all there is).

A mixture of sources (``scene.extra_backgrounds``) adds the photon irradiances of the sources,
each normalised to its own illuminance (:func:`tofjax._mixer.expose`).

**The sensor's spectral response** (``pixel.collection_depth_m``; docs/model.md, "Background
light"). The quantum efficiency is known at the illumination's wavelength (from the responsivity);
elsewhere a photon counts with the relative response of a silicon photodiode that collects what is
absorbed within the depth d,

    q(lambda) = (1 - exp(-alpha(lambda) d)) / (1 - exp(-alpha(lambda_0) d)),

alpha the absorption coefficient of crystalline silicon at 300 K (M. A. Green, Sol. Energy Mater.
Sol. Cells 92, 1305 (2008), ``data/silicon_green2008.csv``). d = 0 is the thesis' flat response
(q = 1 up to the cut-off), which an infinitely deep photodiode approaches.
"""

from __future__ import annotations

import functools

import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from . import _constants as const
from ._params import PhysicalConstants
from ._tables import read_table, silicon_absorption_per_m  # noqa: F401 (silicon_absorption_per_m: public here)

HALOGEN_TEMPERATURE_K = 3200.0
INCANDESCENT_TEMPERATURE_K = 2856.0
#: Second radiation constant c2 = h c / k (CIE 15:2004 defines illuminant A with c2 = 1.4388e-2 m K).
_C2_M_K = const.PLANCK_J_S * const.SPEED_OF_LIGHT_M_PER_S / const.BOLTZMANN_J_PER_K
#: Common wavelength grid, m: 280-4000 nm in 0.5 nm steps (the ASTM G173 span).
_GRID_M = np.arange(280.0, 4000.0 + 0.25, 0.5) * 1e-9


def _planck(wavelength_m: np.ndarray, temperature_k: float) -> np.ndarray:
    """Relative spectral radiance of a black body (scale irrelevant: normalised to lux later)."""
    x = wavelength_m * 1e6
    return x**-5.0 / np.expm1(_C2_M_K / (wavelength_m * temperature_k))


def _on_grid(wavelength_m: np.ndarray, values: np.ndarray) -> np.ndarray:
    return np.interp(_GRID_M, wavelength_m, values, left=0.0, right=0.0)


@functools.cache
def spectrum(background: str) -> tuple[np.ndarray, np.ndarray]:
    """The relative spectral irradiance of a background lamp on the common grid (m, arbitrary)."""
    if background == "sunlight":
        return _GRID_M, _on_grid(*read_table("astm_g173_global_tilt.csv"))
    if background == "fluorescent":
        return _GRID_M, _on_grid(*read_table("cie_fl2.csv"))
    if background == "led":
        return _GRID_M, _exponential_tail(*read_table("cie_led_b3.csv"))
    if background == "halogen":
        return _GRID_M, _planck(_GRID_M, HALOGEN_TEMPERATURE_K)
    if background == "incandescent":
        return _GRID_M, _planck(_GRID_M, INCANDESCENT_TEMPERATURE_K)
    raise ValueError(f"scene.background = {background!r} is not allowed: expected one of "
                     '"sunlight", "halogen", "incandescent", "fluorescent", "led"')


@functools.cache
def photopic_v() -> tuple[np.ndarray, np.ndarray]:
    """CIE 1924 photopic V(lambda) on the common grid."""
    return _GRID_M, _on_grid(*read_table("cie_1924_photopic_v.csv"))


#: The grid's points up to the first beyond silicon's cut-off (the detected part of every spectrum).
_DETECTED = int(np.searchsorted(_GRID_M, const.SILICON_CUTOFF_M)) + 1
#: Tabulated wavelengths whose log-linear fit continues a table beyond its last value.
_TAIL_FIT_M = 40e-9


def _exponential_tail(wavelength_m: np.ndarray, values: np.ndarray) -> np.ndarray:
    """A table on the common grid, continued beyond its last wavelength by the exponential decay
    fitted (least squares in log) to its last 40 nm."""
    fit = wavelength_m >= wavelength_m[-1] - _TAIL_FIT_M
    slope, intercept = np.polyfit(wavelength_m[fit], np.log(values[fit]), 1)
    out = _on_grid(wavelength_m, values)
    beyond = _GRID_M > wavelength_m[-1]
    out[beyond] = np.exp(intercept + slope * _GRID_M[beyond]) if slope < 0 else 0.0
    return out


def _cumtrapz(y: np.ndarray, x: np.ndarray) -> np.ndarray:
    return np.concatenate([[0.0], np.cumsum(0.5 * (y[1:] + y[:-1]) * np.diff(x))])


@functools.cache
def _tables(background: str) -> tuple[float, np.ndarray, np.ndarray, np.ndarray]:
    """(int V E dlambda, cumulative int E lambda dlambda, cumulative int E dlambda, E lambda), the last
    three cut at the silicon band gap, for the normalised-later spectrum E."""
    grid, e = spectrum(background)
    _, v = photopic_v()
    luminous = float(np.trapezoid(v * e, grid))
    detected = np.where(grid <= const.SILICON_CUTOFF_M, e, 0.0)
    return luminous, _cumtrapz(detected * grid, grid), _cumtrapz(detected, grid), detected * grid


def relative_response(wavelength_m: Float[Array, "*w"], reference_m: Float[Array, ""], depth_m: Float[Array, ""]
                      ) -> Float[Array, "*w"]:
    """q(lambda) of a silicon photodiode of collection depth ``depth_m`` > 0, 1 at ``reference_m``
    (module docstring); alpha interpolated in log between the table's points, 0 beyond it."""
    table_m, alpha = silicon_absorption_per_m()
    log_alpha = jnp.asarray(np.log(alpha))

    def absorbed(x):
        a = jnp.where((x >= table_m[0]) & (x <= table_m[-1]), jnp.exp(jnp.interp(x, table_m, log_alpha)), 0.0)
        return -jnp.expm1(-a * depth_m)

    return absorbed(wavelength_m) / absorbed(reference_m)


def _band(wavelength_m: Array, filter_half_width_m: Array) -> tuple[Array, Array]:
    has_filter = filter_half_width_m > 0.0
    lo = jnp.where(has_filter, wavelength_m - filter_half_width_m, _GRID_M[0])
    hi = jnp.where(has_filter, wavelength_m + filter_half_width_m, _GRID_M[-1])
    return lo, hi


def background_photon_irradiance(
    background: str,
    illuminance_lx: Float[Array, "*b"],
    wavelength_m: Float[Array, ""],
    filter_half_width_m: Float[Array, ""],
    constants: PhysicalConstants,
    collection_depth_m: Float[Array, ""] = 0.0,
) -> Float[Array, "*b"]:
    """Detectable in-band background photon irradiance on the target, photons / (s m^2), each photon
    weighted by the sensor's relative spectral response (1 at the illumination's wavelength).

    **Arguments:**
    - ``background``: lamp name (sunlight, halogen, incandescent, fluorescent, led).
    - ``illuminance_lx``: illuminance on the target, lx.
    - ``wavelength_m``, ``filter_half_width_m``: the band-pass filter (half width 0 = no filter).
    - ``constants``: physical constants (K_m, h, c).
    - ``collection_depth_m``: the silicon photodiode's collection depth (``pixel.collection_depth_m``,
      module docstring); 0: a flat response, the thesis'.
    """
    luminous, cum_photon, _, density = _tables(background)
    lo, hi = _band(wavelength_m, filter_half_width_m)
    flat = jnp.interp(hi, _GRID_M, cum_photon) - jnp.interp(lo, _GRID_M, cum_photon)
    in_band = flat
    if not (isinstance(collection_depth_m, (int, float)) and collection_depth_m == 0.0):
        deep = collection_depth_m > 0.0  # 0 (even traced) is the flat response, exactly
        grid = _GRID_M[: _DETECTED]  # nothing is detected beyond the cut-off: a quarter of the grid
        weights = relative_response(jnp.asarray(grid), wavelength_m, jnp.where(deep, collection_depth_m, 1.0))
        y = density[: _DETECTED] * weights
        cum = jnp.concatenate([jnp.zeros(1), jnp.cumsum(0.5 * (y[1:] + y[:-1]) * np.diff(grid))])
        in_band = jnp.where(deep, jnp.interp(hi, grid, cum, right=cum[-1]) - jnp.interp(lo, grid, cum, right=cum[-1]),
                            flat)
    scale = illuminance_lx / (constants.luminous_efficacy_lm_per_w * luminous)  # Eq 3.4
    return scale * in_band / (constants.planck_j_s * constants.speed_of_light_m_per_s)


def background_irradiance_w_per_m2(
    background: str,
    illuminance_lx: Float[Array, "*b"],
    wavelength_m: Float[Array, ""],
    filter_half_width_m: Float[Array, ""],
    constants: PhysicalConstants,
) -> Float[Array, "*b"]:
    """Detectable in-band background irradiance on the target, W/m^2 (E_eBackground, Eq 3.4)."""
    luminous, _, cum_power, _ = _tables(background)
    lo, hi = _band(wavelength_m, filter_half_width_m)
    in_band = jnp.interp(hi, _GRID_M, cum_power) - jnp.interp(lo, _GRID_M, cum_power)
    return illuminance_lx / (constants.luminous_efficacy_lm_per_w * luminous) * in_band
