"""measurements: record tofjax-sweep files on a linear translation stage (thesis §3.5, §4.4.1).

Drivers: Thorlabs APT stages over USB (:class:`AptStage` on :class:`FtdiTransport`), pmd Royale
cameras (:class:`RoyaleCamera`), a manual lux meter; virtual stage, camera and lux meter that run a
whole campaign on tofjax's model; and :class:`FakeAptController`, a byte-exact fake for tests. The
command line is ``tofjax record``.
"""

import tofjax as _tofjax  # noqa: F401  (float64 on)

from ._apt import (
    COUNTS_PER_MM as COUNTS_PER_MM,
    AptStage as AptStage,
    FtdiTransport as FtdiTransport,
    StageError as StageError,
    StageLimitError as StageLimitError,
)
from ._campaign import (
    CampaignSettings as CampaignSettings,
    campaign_metadata as campaign_metadata,
    point_statistics as point_statistics,
    run_campaign as run_campaign,
)
from ._devices import (
    CameraError as CameraError,
    Frames as Frames,
    ManualLuxMeter as ManualLuxMeter,
    RoyaleCamera as RoyaleCamera,
    VirtualCamera as VirtualCamera,
    VirtualLuxMeter as VirtualLuxMeter,
    VirtualStage as VirtualStage,
)
from ._fake_apt import FakeAptController as FakeAptController
