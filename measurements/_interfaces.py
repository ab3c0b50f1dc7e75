"""The three device interfaces a recording campaign talks to (docs/measurements.md, "Devices").

Every implementation (virtual, fake, hardware) satisfies one of these protocols, and the
conformance suite in ``tests/test_devices.py`` runs the same checks against each of them. A new
device is a class with these methods plus one entry in :mod:`measurements._registry`.

Failures are the device's error class (:class:`DeviceError` subclasses), never a bare exception:
the command line turns them into one line. Errors that happen while opening a device (absent
hardware, a missing SDK, a bad address) are input problems (exit status 2); errors during a
recording are device failures (exit status 1) and leave every completed row in the file.
"""

from __future__ import annotations

import dataclasses
from typing import Literal, Protocol, runtime_checkable

import numpy as np


class DeviceError(RuntimeError):
    """A device failure: absent hardware, a missing SDK, a timeout, a refused request."""


class CameraError(DeviceError):
    """A camera failure or a missing SDK."""


class StageError(DeviceError):
    """A stage failure: timeout, unexpected reply, lost device, refused move."""


class StageLimitError(StageError, ValueError):
    """A requested position outside the configured travel; nothing moved."""


class LuxMeterError(DeviceError):
    """A lux meter that cannot give a reading (e.g. no operator at the terminal)."""


#: What a camera's amplitude-like output is: the model's amplitude in ADC LSB (comparable with
#: ``tofjax`` and fitted by ``tofjax calibrate``), or a vendor's gray value (an intensity-like
#: quantity of unknown scale, recorded in its own columns and never fitted as an amplitude).
AmplitudeQuantity = Literal["amplitude_lsb", "gray_value"]


@dataclasses.dataclass
class Frames:
    """``n`` frames of a ROI, each array (n, height, width): depth (m), the amplitude-like output
    (its meaning is the camera's :attr:`Camera.amplitude_quantity`) and validity."""

    depth_m: np.ndarray
    amplitude_lsb: np.ndarray
    valid: np.ndarray


@runtime_checkable
class Stage(Protocol):
    """A linear translation stage carrying the target (positions in metres along its axis).

    ``travel_m`` is the (lowest, highest) position it may be sent to: ``move_to`` outside it raises
    :class:`measurements.StageLimitError` before anything moves.
    """

    travel_m: tuple[float, float]

    def enable(self) -> None: ...

    def home(self) -> None: ...

    def move_to(self, position_m: float) -> float:
        """Move and return the position read back (m)."""
        ...

    def position_m(self) -> float: ...

    def stop(self) -> None: ...

    def close(self) -> None: ...


@runtime_checkable
class Camera(Protocol):
    """A ToF camera delivering depth, an amplitude-like value and validity for a centre ROI.

    - ``model`` / ``serial``: recorded in the file's metadata (known after :meth:`open`).
    - ``modulation_frequency_hz``: the frequency the depth refers to.
    - ``depth_wrap_m``: the range the depth wraps at (statistics are then circular), or ``None``
      when the camera delivers unwrapped depth already (a vendor pipeline that fuses frequencies).
    - ``amplitude_quantity``: see :data:`AmplitudeQuantity`.
    """

    model: str
    serial: str
    amplitude_quantity: AmplitudeQuantity

    @property
    def modulation_frequency_hz(self) -> float: ...

    @property
    def depth_wrap_m(self) -> float | None: ...

    def open(self) -> None: ...

    def set_integration_time(self, seconds: float) -> None: ...

    def grab(self, n: int) -> Frames: ...

    def close(self) -> None: ...


@runtime_checkable
class LuxMeter(Protocol):
    """Reads the illuminance on the target (lx)."""

    def read_lx(self) -> float: ...
