"""Thorlabs APT motion controllers (KDC101, KST101, BSC20x ... behind an FTDI USB chip) over USB.

The messages are packed and parsed by the thorlabs-apt-protocol library; this module frames them,
converts positions between metres and encoder counts, enforces travel limits before anything moves,
and turns timeouts, unexpected replies and a lost device into clear errors. A stop is sent whenever a
move is interrupted by an error or Ctrl-C.

The link (:class:`Transport`) is a seam: :class:`FtdiTransport` is the real USB path (pyftdi over
pyusb, 115200 8N1 with RTS/CTS as Thorlabs specifies), and tests plug in a byte-exact fake controller
(:class:`measurements.FakeAptController`) underneath the same driver code.
"""

from __future__ import annotations

import io
import struct
import time
from typing import Protocol

from ._interfaces import StageError, StageLimitError

try:
    import thorlabs_apt_protocol as apt
except ImportError:  # the [record] extra: AptStage says so when it is built
    apt = None

#: What a missing driver library's error says.
RECORD_EXTRA = 'pip install "tofjax[record]"'

HOST = 0x01
GENERIC_USB = 0x50
#: Encoder counts per mm of common stages (Thorlabs manuals).
COUNTS_PER_MM = {"z8": 34304.0, "lts": 409600.0, "dds": 20000.0}
_REQ_STATUSBITS = 0x0429


__all__ = ["COUNTS_PER_MM", "AptStage", "FtdiTransport", "StageError", "StageLimitError", "Transport"]


class Transport(Protocol):
    """A byte link to one controller."""

    def write(self, data: bytes) -> None: ...

    def read(self, timeout_s: float) -> bytes:
        """Whatever bytes arrived within ``timeout_s`` (possibly none)."""
        ...

    def close(self) -> None: ...


class FtdiTransport:
    """The USB link through pyftdi (which drives libusb via pyusb). ``url`` like
    ``ftdi://0x0403:0xfaf0/1`` (Thorlabs' VID/PID); needs read/write access to the device (udev rule)."""

    def __init__(self, url: str = "ftdi://0x0403:0xfaf0/1"):
        try:
            from pyftdi.serialext import serial_for_url
        except ImportError:
            raise StageError(f"USB stages need pyftdi, which is not installed: {RECORD_EXTRA}") from None
        try:
            self._port = serial_for_url(url, baudrate=115200, bytesize=8, parity="N", stopbits=1, rtscts=True,
                                        timeout=0.05)
        except Exception as err:  # noqa: BLE001 - pyusb/pyftdi raise many kinds; report them uniformly
            raise StageError(f"cannot open the stage at {url}: {err} (is it connected, and is the udev rule for "
                             "0403:faf0 installed? see README)") from None
        time.sleep(0.05)
        self._port.reset_input_buffer()
        self._port.reset_output_buffer()
        self._port.rts = True  # Thorlabs: RTS high enables the controller's flow control

    def write(self, data: bytes) -> None:
        try:
            self._port.write(data)
        except Exception as err:  # noqa: BLE001
            raise StageError(f"stage disconnected while writing: {err}") from None

    def read(self, timeout_s: float) -> bytes:
        self._port.timeout = timeout_s
        try:
            return self._port.read(max(1, self._port.in_waiting))
        except Exception as err:  # noqa: BLE001
            raise StageError(f"stage disconnected while reading: {err}") from None

    def close(self) -> None:
        self._port.close()


class AptStage:
    """One channel of an APT controller, positions in metres.

    **Arguments:**
    - ``transport``: the byte link (:class:`FtdiTransport` or a fake).
    - ``counts_per_mm``: encoder counts per mm (:data:`COUNTS_PER_MM`).
    - ``travel_m``: (lowest, highest) allowed position; requests outside are refused before moving.
    - ``timeout_s``: how long a reply may take; ``move_timeout_s``: how long a home or a move may take
      (an LTS300 at 50 mm/s needs 90 s for 4.5 m).
    """

    def __init__(self, transport: Transport, *, counts_per_mm: float, travel_m: tuple[float, float] = (0.0, 4.5),
                 channel: int = 1, timeout_s: float = 5.0, move_timeout_s: float = 300.0,
                 destination: int = GENERIC_USB):
        if apt is None:
            raise StageError(f"APT stages need thorlabs-apt-protocol, which is not installed: {RECORD_EXTRA}")
        if not counts_per_mm > 0:
            raise ValueError(f"counts_per_mm = {counts_per_mm!r} is out of range: allowed value > 0")
        if not travel_m[0] < travel_m[1]:
            raise ValueError(f"travel_m = {travel_m!r} must be (lowest, highest) with lowest < highest")
        self.transport, self.counts_per_mm, self.travel_m = transport, float(counts_per_mm), tuple(travel_m)
        self.channel, self.timeout_s, self.destination = channel, timeout_s, destination
        self.move_timeout_s = move_timeout_s
        self._buffer = b""

    # -- framing -------------------------------------------------------------------------------
    def _send(self, data: bytes) -> None:
        self.transport.write(data)

    def _next_message(self, deadline: float, timeout_s: float):
        while True:
            if len(self._buffer) >= 6:
                long_form = self._buffer[4] & 0x80
                size = 6 + (struct.unpack_from("<H", self._buffer, 2)[0] if long_form else 0)
                if len(self._buffer) >= size:
                    raw, self._buffer = self._buffer[:size], self._buffer[size:]
                    parsed = list(apt.Unpacker(io.BytesIO(raw)))
                    if len(parsed) != 1:
                        raise StageError(f"unexpected reply from the stage: {raw.hex()}")
                    return parsed[0]
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                raise StageError(f"the stage did not answer within {timeout_s:g} s")
            self._buffer += self.transport.read(min(remaining, 0.1))

    def _wait_for(self, name: str, timeout_s: float | None = None):
        timeout_s = self.timeout_s if timeout_s is None else timeout_s
        deadline = time.monotonic() + timeout_s
        while True:
            msg = self._next_message(deadline, timeout_s)
            if msg.msg == name:
                return msg
            if msg.msg in ("mot_get_statusupdate", "mot_get_dcstatusupdate", "mot_move_stopped"):
                if msg.msg == "mot_move_stopped" and name != "mot_move_stopped":
                    raise StageError("the stage stopped before reaching its target (limit switch or stop button?)")
                continue  # periodic status updates are harmless
            raise StageError(f"unexpected reply from the stage: {msg.msg} while waiting for {name}")

    # -- units ---------------------------------------------------------------------------------
    def to_counts(self, position_m: float) -> int:
        return int(round(position_m * 1e3 * self.counts_per_mm))

    def to_m(self, counts: int) -> float:
        return counts / (1e3 * self.counts_per_mm)

    # -- commands ------------------------------------------------------------------------------
    def enable(self) -> None:
        self._send(apt.mod_set_chanenablestate(self.destination, HOST, self.channel, 1))

    def position_m(self) -> float:
        self._send(apt.mot_req_poscounter(self.destination, HOST, self.channel))
        return self.to_m(self._wait_for("mot_get_poscounter").position)

    def status(self) -> dict:
        """The status bits (homed, moving_forward, channel_enabled, limit switches, ...)."""
        self._send(struct.pack("<HBBBB", _REQ_STATUSBITS, self.channel, 0, self.destination, HOST))
        msg = self._wait_for("mot_get_statusbits")
        return {k: v for k, v in msg._asdict().items() if isinstance(v, bool)}

    def stop(self) -> None:
        """Stop now (profiled stop); waits briefly for the confirmation."""
        self._send(apt.mot_move_stop(self.destination, HOST, self.channel, 2))

    def _guarded(self, start, done: str):
        """Run a motion command; on any error or interrupt while it runs, send a stop and re-raise."""
        try:
            start()
            return self._wait_for(done, self.move_timeout_s)
        except BaseException as err:
            try:
                self.stop()
            except Exception:  # noqa: BLE001 - the stop is best effort; report the original failure
                pass
            if isinstance(err, StageError):
                raise StageError(f"{err}; a stop was sent") from None
            raise

    def home(self) -> None:
        self._guarded(lambda: self._send(apt.mot_move_home(self.destination, HOST, self.channel)), "mot_move_homed")

    def move_to(self, position_m: float) -> float:
        """Move to ``position_m`` (m) and return the position read back."""
        lo, hi = self.travel_m
        if not lo <= position_m <= hi:
            raise StageLimitError(f"stage position {float(position_m):g} m is outside the travel: allowed {lo:g} <= "
                                  f"value <= {hi:g} m; nothing moved")
        counts = self.to_counts(position_m)
        self._guarded(lambda: self._send(apt.mot_move_absolute(self.destination, HOST, self.channel, counts)),
                      "mot_move_completed")
        return self.position_m()

    def close(self) -> None:
        self.transport.close()
