"""Result pytrees of :func:`tofjax.predict` and :func:`tofjax.simulate`."""

from __future__ import annotations

import equinox as eqx
from jaxtyping import Array, Bool, Float


class NoiseBreakdown(eqx.Module):
    """Electron counts of one phase image (both taps) and the rms noise of each source in the
    differential A - B, per sweep sample (the photon transfer curve, Figs 5.12, 5.14, 5.17).

    - ``signal_e``: photo-electrons from the illumination.
    - ``background_e``: photo-electrons from the background light.
    - ``dark_e``: dark electrons.
    - ``reset_e``, ``hold_e``: kTC noise of the reset and of the sample-and-hold.
    - ``photon_shot_e``: shot noise of the signal and background electrons.
    - ``dark_shot_e``: shot noise of the dark electrons.
    - ``read_e``: reset, hold and dark shot noise in quadrature (§5.5.1).
    - ``quantization_e``: rms quantisation error (q / sqrt(12) for an ideal ADC, more with DNL)
      referred to electrons (0 without ADC).
    - ``total_e``: read, photon shot and quantisation noise in quadrature.
    """

    signal_e: Float[Array, " samples"]
    background_e: Float[Array, " samples"]
    dark_e: Float[Array, " samples"]
    reset_e: Float[Array, " samples"]
    hold_e: Float[Array, " samples"]
    photon_shot_e: Float[Array, " samples"]
    dark_shot_e: Float[Array, " samples"]
    read_e: Float[Array, " samples"]
    quantization_e: Float[Array, " samples"]
    total_e: Float[Array, " samples"]


class Result(eqx.Module):
    """Everything a sweep produced. Leading axis: sweep samples; ``frames`` = Monte Carlo
    iterations; ``phases`` = phase images.

    The expected (noise-free) chain: ``tap_a_e``/``tap_b_e`` electrons each tap holds after SBI
    and saturation, ``tap_a_v``/``tap_b_v`` their voltages, ``differential_v`` = V_B - V_A,
    ``code_mean`` the expected raw code. Per frame (Monte Carlo only, else ``None``): raw
    ``codes``, ``phase_rad``, wrapped ``depth_m``, ``depth_unwrapped_m`` (along the sweep),
    ``amplitude_lsb`` and ``valid``. Statistics: depth mean (wrapped and unwrapped) and standard
    deviation (circular), amplitude mean and standard deviation (LSB), SNR (Eq 5.1), and the
    fractions of frames that are valid, pixel-saturated, ADC-saturated and had SBI engaged, and
    ``full_well_fraction``: the expected charge of the fullest tap (before SBI and saturation) over
    the full well, the headroom to SBI/saturation (> 1: SBI engaged or saturated).

    In the hard mode, statistics of samples without two valid frames (analytic: whose expected
    signal saturates) are NaN and flagged by ``valid_fraction``; never reported as 0 m.
    """

    method: str = eqx.field(static=True)
    sweep_variable: str = eqx.field(static=True)
    n_frames: int = eqx.field(static=True)
    sweep_values: Float[Array, " samples"]
    distance_m: Float[Array, " samples"]
    illuminance_lx: Float[Array, " samples"]
    integration_time_s: Float[Array, " samples"]
    unambiguity_range_m: Float[Array, ""]
    tap_a_e: Float[Array, "samples phases"]
    tap_b_e: Float[Array, "samples phases"]
    tap_a_v: Float[Array, "samples phases"]
    tap_b_v: Float[Array, "samples phases"]
    differential_v: Float[Array, "samples phases"]
    code_mean: Float[Array, "samples phases"]
    codes: Float[Array, "samples frames phases"] | None
    phase_rad: Float[Array, "samples frames"] | None
    depth_m: Float[Array, "samples frames"] | None
    depth_unwrapped_m: Float[Array, "samples frames"] | None
    amplitude_lsb: Float[Array, "samples frames"] | None
    valid: Bool[Array, "samples frames"] | None
    depth_mean_m: Float[Array, " samples"]
    depth_unwrapped_mean_m: Float[Array, " samples"]
    depth_std_m: Float[Array, " samples"]
    amplitude_mean_lsb: Float[Array, " samples"]
    amplitude_std_lsb: Float[Array, " samples"]
    intensity_e: Float[Array, " samples"]
    snr_db: Float[Array, " samples"]
    noise: NoiseBreakdown
    valid_fraction: Float[Array, " samples"]
    pixel_saturated_fraction: Float[Array, " samples"]
    adc_saturated_fraction: Float[Array, " samples"]
    sbi_active_fraction: Float[Array, " samples"]
    full_well_fraction: Float[Array, " samples"]

    @property
    def relative_depth_std(self) -> Float[Array, " samples"]:
        """Depth standard deviation over the true distance (Figs 5.11b, 5.13, 5.16b)."""
        return self.depth_std_m / self.distance_m
