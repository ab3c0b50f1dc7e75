"""One registry of the devices ``tofjax record`` can drive, by the names its options take.

Each entry is (one-line description, factory). A factory receives the :class:`DeviceContext` (and
the camera factory also the stage and the lux meter, which a virtual camera reads) and returns an
object satisfying :class:`measurements._interfaces.Stage`, ``Camera`` or ``LuxMeter``. Stages are
also reached by URL: ``ftdi://...`` opens a Thorlabs APT controller over USB.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from typing import Any


@dataclasses.dataclass(frozen=True)
class DeviceContext:
    """What the factories may need: the camera model configuration (``tofjax.Config``), the ROI, the
    stage's travel and encoder scale, the nominal operating point, the seed and the Royale use case."""

    config: Any
    roi: tuple[int, int]
    travel_m: tuple[float, float]
    counts_per_mm: float
    distance_m: float
    illuminance_lx: float
    seed: int
    distance_offset_m: float
    use_case: str | None


def _virtual_stage(ctx: DeviceContext):
    from ._devices import VirtualStage

    return VirtualStage(ctx.distance_m - ctx.distance_offset_m, ctx.travel_m)


def _fake_stage(ctx: DeviceContext):
    from ._apt import AptStage
    from ._fake_apt import FakeAptController

    # The fake controller stands in for a stage in a demonstration or a test: it moves at 1e10
    # counts/s (the real driver, bytes and all, without waiting for a 50 mm/s stage).
    return AptStage(FakeAptController(velocity_counts_per_s=1e10), counts_per_mm=ctx.counts_per_mm,
                    travel_m=ctx.travel_m)


def _ftdi_stage(url: str, ctx: DeviceContext):
    from ._apt import AptStage, FtdiTransport

    return AptStage(FtdiTransport(url), counts_per_mm=ctx.counts_per_mm, travel_m=ctx.travel_m)


def _virtual_camera(ctx: DeviceContext, stage, lux):
    from ._devices import VirtualCamera

    return VirtualCamera(ctx.config.params, stage, lux, ctx.roi, ctx.seed, ctx.distance_offset_m)


def _royale_camera(ctx: DeviceContext, stage, lux):
    from ._royale import RoyaleCamera

    return RoyaleCamera(ctx.roi, ctx.use_case,
                        modulation_frequency_hz=ctx.config.values["illumination_waveform"]["modulation_frequency_hz"])


def _virtual_lux(ctx: DeviceContext):
    from ._devices import VirtualLuxMeter

    return VirtualLuxMeter(ctx.illuminance_lx)


def _manual_lux(ctx: DeviceContext):
    from ._devices import ManualLuxMeter

    return ManualLuxMeter()


STAGES: dict[str, tuple[str, Callable]] = {
    "virtual": ("moves instantly (a virtual campaign)", _virtual_stage),
    "fake": ("the APT driver over the byte-exact fake controller", _fake_stage),
}
#: Stage URLs: scheme -> (description, factory(url, ctx)).
STAGE_URLS: dict[str, tuple[str, Callable]] = {
    "ftdi://": ("a Thorlabs APT controller over USB, e.g. ftdi://0x0403:0xfaf0/1", _ftdi_stage),
}
CAMERAS: dict[str, tuple[str, Callable]] = {
    "virtual": ("tofjax's Monte Carlo at the stage's position", _virtual_camera),
    "royale": ("a pmd Royale camera through roypy", _royale_camera),
}
LUX_METERS: dict[str, tuple[str, Callable]] = {
    "virtual": ("returns the set value (--lux-value, or the swept illuminance)", _virtual_lux),
    "manual": ("asks the operator to type the reading", _manual_lux),
}


def stage_allowed_text() -> str:
    return ", ".join(STAGES) + " or a URL " + ", ".join(f"{s}..." for s in STAGE_URLS)


def is_stage_name(name: str) -> bool:
    return name in STAGES or any(name.startswith(s) and len(name) > len(s) for s in STAGE_URLS)


def make_stage(name: str, ctx: DeviceContext):
    if name in STAGES:
        return STAGES[name][1](ctx)
    scheme = next(s for s in STAGE_URLS if name.startswith(s))
    return STAGE_URLS[scheme][1](name, ctx)


def make_camera(name: str, ctx: DeviceContext, stage, lux):
    return CAMERAS[name][1](ctx, stage, lux)


def make_lux_meter(name: str, ctx: DeviceContext):
    return LUX_METERS[name][1](ctx)
