"""Regenerate the thesis' chapter-5 figures with tofjax (docs/model.md compares them figure by figure).

    python docs/gallery.py [--out docs/gallery] [--iterations 1000]

Each figure uses the defaults (the verification camera of §5.5.1) unless its caption in the thesis
says otherwise; the setup is in each function's docstring.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import jax
import numpy as np
from matplotlib.figure import Figure

import tofjax as tj
from tofjax import plots


def _fig(n=1, size=(11, 4.2)):
    fig = Figure(figsize=size, layout="constrained")
    return fig, [fig.add_subplot(1, n, i + 1) for i in range(n)]


def _params(**sections):
    return tj.Params(**sections)


def fig5_01(it):
    """Fig 5.1: noise of one phase image's differential voltage over integration time (0.05-5 ms),
    1 m, 150 lx halogen so that SBI engages within the range."""
    p = _params(scene=tj.Scene(background="halogen", illuminance_lx=150.0))
    r = tj.predict(p, tj.Sweep.linspace("integration_time", 0.05e-3, 5e-3, 200))
    fig, (ax,) = _fig(1, (6.4, 4.2))
    volts = np.asarray(r.noise.total_e) * 1.602176634e-19 / 14e-15
    ax.plot(np.asarray(r.integration_time_s) * 1e3, volts * 1e3)
    on = np.asarray(r.sbi_active_fraction) > 0
    if on.any():
        ax.axvline(float(r.integration_time_s[np.argmax(on)]) * 1e3, color="r", ls="--", label="SBI engages")
        ax.legend()
    ax.set_xlabel("integration time [ms]")
    ax.set_ylabel("noise voltage of one phase image [mV]")
    return fig


def fig5_02(it):
    """Fig 5.2: tap voltages of the 0 deg image over integration time at 1 m, 3000 lx halogen."""
    p = _params(scene=tj.Scene(background="halogen", illuminance_lx=3000.0))
    return plots.tap_voltages(tj.predict(p, tj.Sweep.linspace("integration_time", 0.05e-3, 5e-3, 200)), p)


def _cc(shape, duty_ill, duty_ref=0.5, order=15):
    p = _params(pixel=tj.Pixel(noise=False), adc=tj.ADC(enabled=False),
                illumination_waveform=tj.IlluminationWaveform(shape=shape, duty_cycle=duty_ill, gauss_order=order),
                reference_waveform=tj.ReferenceWaveform(shape=shape, duty_cycle=duty_ref, gauss_order=order))
    return tj.predict(p, tj.Sweep.linspace("distance", 1.87, 5.0, 400))


def fig5_03(it):
    """Fig 5.3: cross correlation over 1.87-5 m, noise-free: (a) rectangular, (b) gauss-extended, 50 %."""
    fig, axes = _fig(2)
    plots.cross_correlation(_cc("pulse", 0.5), ax=axes[0])
    plots.cross_correlation(_cc("gauss_extended", 0.5), ax=axes[1])
    axes[0].set_title("(a) rectangular")
    axes[1].set_title("(b) gauss-extended, order 15")
    return fig


def fig5_04(it):
    """Fig 5.4: rectangular illumination at (a) 30 % and (b) 20 % duty with a 50 % reference."""
    fig, axes = _fig(2)
    plots.cross_correlation(_cc("pulse", 0.3), ax=axes[0])
    plots.cross_correlation(_cc("pulse", 0.2), ax=axes[1])
    axes[0].set_title("(a) 30 % duty")
    axes[1].set_title("(b) 20 % duty: flat tops overlap")
    return fig


def fig5_05(it):
    """Fig 5.5: wiggling of a rectangular 4-phase measurement, (a) without and (b) with noise."""
    fig, axes = _fig(2)
    sweep = tj.Sweep.linspace("distance", 0.5, 5.0, 300)
    rect = dict(illumination_waveform=tj.IlluminationWaveform(shape="pulse", duty_cycle=0.5),
                reference_waveform=tj.ReferenceWaveform(shape="pulse", duty_cycle=0.5))
    plots.wiggling(tj.predict(_params(pixel=tj.Pixel(noise=False), adc=tj.ADC(enabled=False), **rect), sweep),
                   ax=axes[0])
    plots.wiggling(tj.simulate(_params(**rect), sweep, jax.random.key(5), it), ax=axes[1])
    axes[0].set_title("(a) without noise")
    axes[1].set_title("(b) with noise")
    return fig


def fig5_06(it):
    """Fig 5.6: calculated (a) and unwrapped (b) distance over the real one, 0.1-5 m."""
    r = tj.simulate(tj.Params(), tj.Sweep.linspace("distance", 0.1, 5.0, 400), jax.random.key(6), it)
    fig, axes = _fig(2)
    plots.calculated_vs_real(r, ax=axes[0])
    plots.unwrapped_vs_real(r, ax=axes[1])
    return fig


def fig5_07(it):
    """Fig 5.7: depth noise over distance without ADC; circular statistics have no wrap outliers."""
    p = _params(adc=tj.ADC(enabled=False))
    return plots.depth_noise(tj.simulate(p, tj.Sweep.linspace("distance", 0.3, 5.0, 600), jax.random.key(7), it))


def fig5_09(it):
    """Fig 5.9: unwrapped distance of 20 frames over 0.1-15 m: wrong unwrapping at long range."""
    r = tj.simulate(tj.Params(), tj.Sweep.linspace("distance", 0.1, 15.0, 600), jax.random.key(9), 20)
    return plots.unwrapped_vs_real(r)


def fig5_09_dual(it):
    """§2.2: two frequencies (80.32 and 60.24 MHz) over 0.3-7.4 m, wrong-unwrap fraction."""
    r = tj.simulate(tj.Camera(tj.Params(), frequencies_hz=[80.32e6, 60.24e6]), tj.Sweep.linspace("distance", 0.3, 7.4, 120), jax.random.key(10), it)
    return plots.multifrequency_distance(r)


def fig5_11(it):
    """Fig 5.11: verification sweep over 0.4-4.5 m without background: amplitude, relative noise."""
    p = _params(scene=tj.Scene(illuminance_lx=0.0))
    r = tj.simulate(p, tj.Sweep.linspace("distance", 0.4, 4.5, 200), jax.random.key(11), it)
    fig, axes = _fig(2)
    plots.amplitude(r, ax=axes[0])
    plots.depth_noise(r, relative=True, ax=axes[1])
    return fig


def fig5_12(it):
    """Fig 5.12: PTC and SNR of a distance sweep over 0.1-10 m."""
    r = tj.predict(tj.Params(), tj.Sweep.linspace("distance", 0.1, 10.0, 300))
    fig, axes = _fig(2)
    plots.photon_transfer_curve(r, ax=axes[0])
    plots.snr(r, ax=axes[1])
    return fig


def _lux(it):
    p = _params(scene=tj.Scene(background="halogen"))
    return p, tj.simulate(p, tj.Sweep.linspace("illuminance", 0.0, 5000.0, 120), jax.random.key(13), it)


def fig5_13(it):
    """Fig 5.13: relative depth noise at 1 m over halogen illuminance 0-5 klx, no filter."""
    return plots.depth_noise(_lux(it)[1], relative=True)


def fig5_14(it):
    """Fig 5.14: PTC and SNR of the illuminance sweep."""
    r = _lux(it)[1]
    fig, axes = _fig(2)
    plots.photon_transfer_curve(r, ax=axes[0])
    plots.snr(r, ax=axes[1])
    return fig


def fig5_15(it):
    """Fig 5.15: tap voltages (a) and absolute depth noise (b) over illuminance; SBI engages."""
    p, r = _lux(it)
    fig, axes = _fig(2)
    plots.tap_voltages(r, p, ax=axes[0])
    plots.depth_noise(r, ax=axes[1])
    return fig


def _tint(it):
    p = _params(scene=tj.Scene(illuminance_lx=0.0))
    return tj.simulate(p, tj.Sweep.linspace("integration_time", 0.5e-3, 4e-3, 80), jax.random.key(16), it)


def fig5_16(it):
    """Fig 5.16: amplitude and relative noise at 1 m over integration time 0.5-4 ms."""
    r = _tint(it)
    fig, axes = _fig(2)
    plots.amplitude(r, ax=axes[0])
    plots.depth_noise(r, relative=True, ax=axes[1])
    return fig


def fig5_17(it):
    """Fig 5.17: PTC and SNR of the integration-time sweep."""
    r = _tint(it)
    fig, axes = _fig(2)
    plots.photon_transfer_curve(r, ax=axes[0])
    plots.snr(r, ax=axes[1])
    return fig


def fig5_18(it):
    """Fig 5.18: depth noise with the closed-form estimates at (a) 12.5 % and (b) 25 % duty."""
    fig, axes = _fig(2)
    for ax, duty in zip(axes, (0.125, 0.25), strict=True):
        p = _params(scene=tj.Scene(illuminance_lx=0.0),
                    illumination_waveform=tj.IlluminationWaveform(duty_cycle=duty))
        sweep = tj.Sweep.linspace("distance", 0.5, 4.5, 150)
        plots.depth_noise(tj.simulate(p, sweep, jax.random.key(18), it), ax=ax,
                          estimates={"CW estimate": tj.cw_depth_noise(p, sweep),
                                     "pulsed estimate": tj.pulsed_depth_noise(p, sweep)})
        ax.set_title(f"{100 * duty:g} % duty")
    return fig


FIGURES = {name: fn for name, fn in globals().items() if name.startswith("fig5_")}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--out", type=Path, default=Path(__file__).parent / "gallery")
    parser.add_argument("--iterations", type=int, default=1000)
    parser.add_argument("--only", nargs="*", help="figure names, e.g. fig5_05")
    args = parser.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    for name, fn in FIGURES.items():
        if args.only and name not in args.only:
            continue
        fn(args.iterations).savefig(args.out / f"{name}.png", dpi=100)
        print(f"wrote {args.out / name}.png: {fn.__doc__.splitlines()[0]}")


if __name__ == "__main__":
    main()
