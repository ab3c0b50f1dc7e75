"""The baseline tofjax is held against: an honest, vectorised NumPy implementation of the thesis'
algorithm for one camera (chapter 3-4), written the way a careful NumPy user would port it.

Per call, once: the waveforms sampled on a time grid (``grid`` points per period), the optical and
background constants (the lamp-spectrum integral is taken from tofjax, it is not per sample), the
noise sigmas and the ADC's DNL edges.

Per sample (thesis §3.2.2, "time-grid mixing"): the illumination delayed by the round trip is
interpolated on the grid and multiplied by the reference of each phase step; the trapezoid rule
(a mean, on a periodic grid) gives tap A's fraction. The tabulated variant (:meth:`Baseline.table`)
does that once for ``grid`` delays and interpolates linearly per sample, as one would for frames.

Per frame and phase image, 4 normals from ``numpy.random.default_rng`` (PCG64): shot + reset noise
of tap A and of tap B, the SBI (or saturation), hold noise of A and of B; the ADC (offset, gain,
INL, DNL edges, rails), the 4-phase demodulation and the statistics of the valid frames (circular
mean, standard deviation of the wrapped phase deviations). Work is chunked over samples so that
memory stays bounded; ``threads=2`` runs two halves of the samples in two threads (NumPy releases
the GIL in its array loops and random fills), each with its own generator.
"""

from __future__ import annotations

import math
from concurrent.futures import ThreadPoolExecutor

import numpy as np

import tofjax as tj

_GOLDEN = 0.5 * (math.sqrt(5.0) - 1.0)


def _f(x) -> float:
    return float(np.asarray(x))


class Baseline:
    """The NumPy port for one camera ``params`` (:class:`tofjax.Params`)."""

    def __init__(self, params, grid: int = 4096):
        ill, cam, pix, scene, k = params.illumination, params.camera, params.pixel, params.scene, params.constants
        self.n_phases = int(pix.n_phases)
        self.sbi = bool(pix.sbi)
        self.grid = grid
        self.f_mod = _f(params.illumination_waveform.modulation_frequency_hz)
        self.c = _f(k.speed_of_light_m_per_s)
        self.d_u = self.c / (2.0 * self.f_mod)
        # Waveforms on the time grid (one period), and the phase-shifted references.
        t = np.arange(grid) / grid
        self.illum = np.asarray(tj.waveforms.waveform(params.illumination_waveform, t))
        steps = np.arange(self.n_phases) / self.n_phases
        self.refs = np.stack([np.asarray(tj.waveforms.waveform(params.reference_waveform, (t - s) % 1.0))
                              for s in steps])  # (phases, grid)
        self.t = t
        # Optical path (Eqs 3.1-3.18): the distance cancels in the collection gain.
        tan_half = lambda fov: np.tan(np.deg2rad(np.asarray(fov)) / 2.0)  # noqa: E731
        fov = np.asarray(ill.fov_deg)
        spot_per_d2 = math.pi * _f(tan_half(fov)) ** 2 if fov.shape == () else 4.0 * float(np.prod(tan_half(fov)))
        pitch = np.asarray(cam.pixel_pitch_m)
        gain_m2 = (_f(scene.reflectivity) * pitch[0] * pitch[1] * _f(cam.fill_factor) * _f(cam.k_lens)
                   / (4.0 * _f(cam.f_number) ** 2))
        e_photon = _f(k.planck_j_s) * self.c / _f(ill.wavelength_m)
        qe = _f(pix.photo_responsivity_a_per_w) * e_photon / _f(k.elementary_charge_c)
        mean_power = float(np.mean(self.illum))
        self.active_per_s_m2 = _f(ill.peak_power_w) / spot_per_d2 * gain_m2 * mean_power / e_photon * qe  # x t / d^2
        photon_irr_per_lx = _f(tj.optics.background_photon_irradiance(scene.background, 1.0, ill.wavelength_m,
                                                                 scene.filter_half_width_m, k))
        self.background_per_s_lx = photon_irr_per_lx * gain_m2 * qe  # x t x lux
        self.contrast = _f(pix.demodulation_contrast)
        c_int, e = _f(pix.integration_capacitance_f), _f(k.elementary_charge_c)
        self.per_volt = c_int / e
        kt = _f(k.boltzmann_j_per_k) * (_f(pix.temperature_c) + 273.15)
        self.sd_reset = math.sqrt(kt * c_int) / e
        self.sd_hold = math.sqrt(kt / _f(pix.c_sample_and_hold_f)) * c_int / e
        self.sd_read = _f(pix.readout_noise_e)
        self.dark_per_s = _f(pix.dark_slope_mean_v_per_s) * self.per_volt
        self.full_well = (_f(pix.v_reset_v) - _f(pix.v_saturated_v)) * self.per_volt
        adc = params.adc
        self.bits = int(adc.resolution_bits)
        self.top = 2.0**self.bits - 1.0
        self.mid = 2.0 ** (self.bits - 1)
        self.per_lsb = 1.0 / (self.per_volt * _f(adc.lsb_v)) * (1.0 + _f(adc.gain_error_percent_fsr) / 100.0)
        self.offset = _f(adc.offset_error_lsb)
        self.inl = _f(adc.integral_nonlinearity_lsb)
        codes = np.arange(1.0, self.top + 1.0)
        self.edges = codes - 0.5 + 0.5 * _f(adc.differential_nonlinearity_lsb) * np.sin(2.0 * np.pi * _GOLDEN * codes)
        # Edge of code c at index c (c = 0 and c = top + 1 never pass: -inf... +inf guards).
        self._edge_of = np.concatenate([[np.inf], self.edges, [np.inf]])
        theta = 2.0 * np.pi * steps
        self.cos, self.sin = np.round(np.cos(theta), 15), np.round(np.sin(theta), 15)
        self.amp_scale = 1.0 if self.n_phases == 2 else 2.0 / self.n_phases
        self._table = None

    # -- expected charges ------------------------------------------------------------------------
    def fraction_a(self, distance_m: np.ndarray, chunk: int = 256) -> np.ndarray:
        """Tap A's correlation fraction per sample and phase, by time-grid mixing, (samples, phases)."""
        delay = (distance_m.ravel() / self.d_u) % 1.0  # round trip in periods: 2 f d / c = d / d_u
        out = np.empty((delay.size, self.n_phases))
        tp = np.append(self.t, 1.0)
        ip = np.append(self.illum, self.illum[0])
        for s in range(0, delay.size, chunk):
            shifted = np.interp((self.t[None, :] - delay[s:s + chunk, None]) % 1.0, tp, ip)  # (chunk, grid)
            # Trapezoid rule over one period of a periodic product: the mean of the grid values.
            out[s:s + chunk] = shifted @ self.refs.T / self.grid
        return out / np.mean(self.illum)

    def table(self) -> tuple[np.ndarray, np.ndarray]:
        """Tap A's fraction at ``grid`` delays over one period, computed once (the frame variant)."""
        if self._table is None:
            delays = np.arange(self.grid + 1) / self.grid
            self._table = (delays, self.fraction_a(delays * self.d_u))
        return self._table

    def fraction_a_table(self, distance_m: np.ndarray) -> np.ndarray:
        delays, values = self.table()
        delay = (distance_m.ravel() / self.d_u) % 1.0
        return np.stack([np.interp(delay, delays, values[:, j]) for j in range(self.n_phases)], axis=-1)

    def expected(self, distance_m, illuminance_lx, integration_time_s, tabulated: bool = False):
        """Expected electrons of tap A and B, (samples, phases), photo plus dark."""
        d = np.asarray(distance_m, dtype=float).ravel()
        lux = np.broadcast_to(np.asarray(illuminance_lx, dtype=float), d.shape)
        t = np.broadcast_to(np.asarray(integration_time_s, dtype=float), d.shape)
        frac = self.fraction_a_table(d) if tabulated else self.fraction_a(d)
        active = self.active_per_s_m2 * t / d**2
        background = self.background_per_s_lx * t * lux
        modulated = (self.contrast * active)[:, None]
        equal = (0.5 * (1.0 - self.contrast) * active + 0.5 * background + self.dark_per_s * t)[:, None]
        return modulated * frac + equal, modulated * (1.0 - frac) + equal

    # -- frames ----------------------------------------------------------------------------------
    def _frames(self, rng, n_a, n_b, frames: int):
        """Codes (samples, frames, phases) and frame validity (samples, frames)."""
        shape = (n_a.shape[0], frames, n_a.shape[1])
        z = rng.standard_normal((4,) + shape)
        a = n_a[:, None, :] + np.sqrt(n_a[:, None, :] + self.sd_reset**2) * z[0]
        b = n_b[:, None, :] + np.sqrt(n_b[:, None, :] + self.sd_reset**2) * z[1]
        if self.sbi:
            saturated = np.abs(a - b) >= self.full_well
            removed = np.maximum(np.maximum(a, b) - self.full_well, 0.0)
            a, b = np.maximum(a - removed, 0.0), np.maximum(b - removed, 0.0)
        else:
            saturated = np.maximum(a, b) >= self.full_well
            a, b = np.minimum(a, self.full_well), np.minimum(b, self.full_well)
        sd_after = math.sqrt(self.sd_hold**2 + self.sd_read**2)
        diff = a - b + sd_after * (z[2] - z[3])
        x = diff * self.per_lsb + self.offset
        u = self.mid + x + self.inl * (1.0 - (x / self.mid) ** 2)
        # The code: floor(u), plus one where u passed the next edge (|DNL| < 1, so only that edge).
        base = np.clip(np.floor(u), -1.0, self.top)
        codes = np.clip(base, 0.0, self.top) + (u >= self._edge_of[(base + 1.0).astype(np.intp)])
        adc_saturated = (u < self.edges[0]) | (u >= self.edges[-1])
        valid = ~np.any(saturated | adc_saturated, axis=-1)
        return codes, valid

    def _demodulate(self, codes):
        v = codes - self.mid
        re, im = v @ self.cos, v @ self.sin
        return np.arctan2(im, re), self.amp_scale * np.hypot(re, im)

    def _statistics(self, rng, n_a, n_b, frames: int, chunk_elements: int):
        per_sample = frames * self.n_phases * 4
        chunk = max(1, chunk_elements // per_sample)
        out = np.full((n_a.shape[0], 4), np.nan)
        for s in range(0, n_a.shape[0], chunk):
            codes, valid = self._frames(rng, n_a[s:s + chunk], n_b[s:s + chunk], frames)
            phase, amp = self._demodulate(codes)
            n = valid.sum(axis=1)
            z = np.where(valid, np.exp(1j * phase), 0.0).sum(axis=1)
            mean = np.angle(z)
            dev = np.where(valid, np.angle(np.exp(1j * (phase - mean[:, None]))), 0.0)
            with np.errstate(invalid="ignore", divide="ignore"):
                std = np.sqrt((dev**2).sum(axis=1) / (n - 1) - dev.sum(axis=1) ** 2 / (n * (n - 1)))
                amp_mean = np.where(valid, amp, 0.0).sum(axis=1) / n
                amp_std = np.sqrt(np.where(valid, (amp - amp_mean[:, None]) ** 2, 0.0).sum(axis=1) / (n - 1))
            ok = n >= 2
            out[s:s + chunk] = np.where(ok[:, None], np.stack([np.mod(mean, 2 * np.pi), std, amp_mean, amp_std], -1),
                                        np.nan)
        return out

    def simulate(self, seed: int, distance_m, illuminance_lx, integration_time_s, frames: int,
                 threads: int = 1, chunk_elements: int = 1 << 21) -> dict[str, np.ndarray]:
        """The Monte Carlo sweep: depth mean/std (m), amplitude mean/std (LSB) per sample."""
        n_a, n_b = self.expected(distance_m, illuminance_lx, integration_time_s)
        rngs = [np.random.default_rng(s) for s in np.random.SeedSequence(seed).spawn(threads)]
        parts = np.array_split(np.arange(n_a.shape[0]), threads)
        if threads == 1:
            stats = self._statistics(rngs[0], n_a, n_b, frames, chunk_elements)
        else:
            with ThreadPoolExecutor(threads) as pool:
                stats = np.concatenate(list(pool.map(
                    lambda i: self._statistics(rngs[i], n_a[parts[i]], n_b[parts[i]], frames, chunk_elements),
                    range(threads))))
        to_m = self.d_u / (2.0 * np.pi)
        return {"depth_mean_m": stats[:, 0] * to_m, "depth_std_m": stats[:, 1] * to_m,
                "amplitude_mean_lsb": stats[:, 2], "amplitude_std_lsb": stats[:, 3]}

    def frame(self, rng, distance_m, illuminance_lx, integration_time_s) -> tuple[np.ndarray, np.ndarray]:
        """One noisy frame of a scene (tabulated correlation): depth (m) and amplitude (LSB) per
        pixel, NaN where the pixel or the ADC saturated; the shape of ``distance_m``."""
        n_a, n_b = self.expected(distance_m, illuminance_lx, integration_time_s, tabulated=True)
        codes, valid = self._frames(rng, n_a, n_b, 1)
        phase, amp = self._demodulate(codes[:, 0])
        depth = np.where(valid[:, 0], np.mod(phase, 2 * np.pi) * (self.d_u / (2 * np.pi)), np.nan)
        shape = np.shape(distance_m)
        return depth.reshape(shape), np.where(valid[:, 0], amp, np.nan).reshape(shape)

    def expected_charges(self, distance_m, illuminance_lx, integration_time_s):
        """Only the expected tap charges (tabulated correlation): the floor for ``predict``."""
        return self.expected(distance_m, illuminance_lx, integration_time_s, tabulated=True)
