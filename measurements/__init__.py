"""measurements: record tofjax-sweep files on a linear translation stage (thesis §3.5, §4.4.1).

Devices sit behind three interfaces (:class:`Stage`, :class:`Camera`, :class:`LuxMeter`; typing
protocols) and one registry of the names ``tofjax record`` takes. Drivers: Thorlabs APT stages over
USB (:class:`AptStage` on :class:`FtdiTransport`), pmd Royale cameras (:class:`RoyaleCamera`), a
manual lux meter; virtual stage, camera and lux meter that run a whole campaign on tofjax's model;
and fakes for tests: :class:`FakeAptController` (byte-exact APT controller) and :class:`FakeRoypy`
(the Royale Python API). The command line is ``tofjax record``. Names load on first use
(``tofjax --help`` stays fast).
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING

_EXPORTS = {
    "COUNTS_PER_MM": "_apt", "AptStage": "_apt", "FtdiTransport": "_apt", "StageError": "_interfaces",
    "StageLimitError": "_interfaces",
    "CampaignSettings": "_campaign", "campaign_metadata": "_campaign", "check_resume": "_campaign",
    "point_statistics": "_campaign", "run_campaign": "_campaign",
    "ManualLuxMeter": "_devices", "VirtualCamera": "_devices", "VirtualLuxMeter": "_devices", "VirtualStage": "_devices",
    "Camera": "_interfaces", "CameraError": "_interfaces", "DeviceError": "_interfaces", "Frames": "_interfaces",
    "LuxMeter": "_interfaces", "LuxMeterError": "_interfaces", "Stage": "_interfaces",
    "RoyaleCamera": "_royale",
    "FakeAptController": "_fake_apt", "FakeRoypy": "_fake_roypy",
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
    from ._apt import COUNTS_PER_MM, AptStage, FtdiTransport  # noqa: F401
    from ._campaign import (  # noqa: F401
        CampaignSettings, campaign_metadata, check_resume, point_statistics, run_campaign)
    from ._devices import ManualLuxMeter, VirtualCamera, VirtualLuxMeter, VirtualStage  # noqa: F401
    from ._fake_apt import FakeAptController  # noqa: F401
    from ._fake_roypy import FakeRoypy  # noqa: F401
    from ._interfaces import (  # noqa: F401
        Camera, CameraError, DeviceError, Frames, LuxMeter, LuxMeterError, Stage, StageError, StageLimitError)
    from ._royale import RoyaleCamera  # noqa: F401
