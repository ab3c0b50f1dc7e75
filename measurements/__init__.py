"""measurements: record tofjax-sweep files on a linear translation stage (thesis §3.5, §4.4.1).

Drivers: Thorlabs APT stages over USB (:class:`AptStage` on :class:`FtdiTransport`), pmd Royale
cameras (:class:`RoyaleCamera`), a manual lux meter; virtual stage, camera and lux meter that run a
whole campaign on tofjax's model; and :class:`FakeAptController`, a byte-exact fake for tests. The
command line is ``tofjax record``. Names load on first use (``tofjax --help`` stays fast).
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING

_EXPORTS = {
    "COUNTS_PER_MM": "_apt", "AptStage": "_apt", "FtdiTransport": "_apt", "StageError": "_apt",
    "StageLimitError": "_apt",
    "CampaignSettings": "_campaign", "campaign_metadata": "_campaign", "point_statistics": "_campaign",
    "run_campaign": "_campaign",
    "CameraError": "_devices", "Frames": "_devices", "ManualLuxMeter": "_devices", "RoyaleCamera": "_devices",
    "VirtualCamera": "_devices", "VirtualLuxMeter": "_devices", "VirtualStage": "_devices",
    "FakeAptController": "_fake_apt",
}
__all__ = sorted(_EXPORTS)


def __getattr__(name: str):
    if name in _EXPORTS:
        value = getattr(importlib.import_module(f".{_EXPORTS[name]}", __name__), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'measurements' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted([*globals(), *_EXPORTS])


if TYPE_CHECKING:  # pragma: no cover
    from ._apt import COUNTS_PER_MM, AptStage, FtdiTransport, StageError, StageLimitError  # noqa: F401
    from ._campaign import CampaignSettings, campaign_metadata, point_statistics, run_campaign  # noqa: F401
    from ._devices import (  # noqa: F401
        CameraError, Frames, ManualLuxMeter, RoyaleCamera, VirtualCamera, VirtualLuxMeter, VirtualStage)
    from ._fake_apt import FakeAptController  # noqa: F401
