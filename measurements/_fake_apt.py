"""A fake APT controller that speaks the protocol byte for byte, for tests and demos without hardware.

It parses the host's messages (6-byte headers, long-form data) and answers like a KDC101: position
counter, status bits, homed / move-completed / move-stopped notifications after a realistic time
(distance over velocity). Faults can be injected: ``silent`` (no answers: a timeout), ``garbage``
(the next answer is noise), ``disconnect_on_move`` (the link fails once a move has started).
"""

from __future__ import annotations

import struct
import time

from ._interfaces import StageError

_HOST = 0x01
_DEVICE = 0x50
_ENABLED, _HOMED, _HOMING, _FWD, _REV = 0x80000000, 0x400, 0x200, 0x10, 0x20


class FakeAptController:
    """Implements :class:`measurements._apt.Transport`; ``received`` lists the message ids it got.

    The default velocity, 2.048e7 counts/s, is 50 mm/s on an LTS stage (409600 counts/mm), the
    LTS300's maximum speed; tests pass a higher one to keep long moves short.
    """

    def __init__(self, *, velocity_counts_per_s: float = 2.048e7, position_counts: int = 0, home_time_s: float = 0.05):
        self.position, self.velocity, self.home_time_s = position_counts, velocity_counts_per_s, home_time_s
        self.enabled = self.homed = False
        self.silent = self.garbage = self.disconnect_on_move = False
        self.received: list[int] = []
        self.attempted: list[bytes] = []  # every write, also those that failed on a broken link
        self._pending: list[tuple[float, bytes]] = []
        self._move: tuple[float, float, int, int] | None = None  # (t0, t1, from, to)
        self._buffer = b""
        self._broken = False

    # -- device side ---------------------------------------------------------------------------
    def _status(self) -> int:
        bits = (_ENABLED if self.enabled else 0) | (_HOMED if self.homed else 0)
        if self._move is not None:
            bits |= _FWD if self._move[3] > self._move[2] else _REV
        return bits

    def _current(self) -> int:
        if self._move is None:
            return self.position
        t0, t1, a, b = self._move
        frac = min(1.0, (time.monotonic() - t0) / max(t1 - t0, 1e-9))
        return int(round(a + (b - a) * frac))

    def _long(self, msgid: int, data: bytes) -> bytes:
        return struct.pack("<HHBB", msgid, len(data), _HOST | 0x80, _DEVICE) + data

    def _status_update(self, msgid: int) -> bytes:
        return self._long(msgid, struct.pack("<HiHHI", 1, self._current(), 0, 0, self._status()))

    def _reply(self, at: float, data: bytes) -> None:
        if not self.silent:
            self._pending.append((at, data))

    def _handle(self, msgid: int, p1: int, p2: int, data: bytes) -> None:
        self.received.append(msgid)
        now = time.monotonic()
        if msgid == 0x0210:  # MOD_SET_CHANENABLESTATE
            self.enabled = p2 == 1
        elif msgid == 0x0411:  # MOT_REQ_POSCOUNTER
            self._reply(now, self._long(0x0412, struct.pack("<Hi", 1, self._current())))
        elif msgid == 0x0429:  # MOT_REQ_STATUSBITS
            self._reply(now, self._long(0x042A, struct.pack("<HI", 1, self._status())))
        elif msgid == 0x0443:  # MOT_MOVE_HOME
            self._move = (now, now + self.home_time_s, self._current(), 0)
            self._finish(0x0444, now + self.home_time_s, home=True)
        elif msgid == 0x0453:  # MOT_MOVE_ABSOLUTE, data: chan (H), position (i)
            _, target = struct.unpack("<Hi", data)
            start = self._current()
            t1 = now + abs(target - start) / self.velocity
            self._move = (now, t1, start, target)
            if self.disconnect_on_move:
                self._broken = True
            self._finish(0x0464, t1)
        elif msgid == 0x0465:  # MOT_MOVE_STOP
            self.position = self._current()
            self._move = None
            self._pending = [(t, d) for t, d in self._pending if d[:2] not in (b"\x64\x04", b"\x44\x04")]
            self._reply(now, self._status_update(0x0466))
        else:
            raise AssertionError(f"the fake controller does not know message 0x{msgid:04x}")

    def _finish(self, msgid: int, at: float, home: bool = False) -> None:
        target = self._move[3]

        def done():
            self.position, self._move = target, None
            if home:
                self.homed = True
            return struct.pack("<HBBBB", msgid, 1, 0, _HOST, _DEVICE) if home else self._status_update(msgid)

        self._pending.append((at, done))

    # -- transport side ------------------------------------------------------------------------
    def write(self, data: bytes) -> None:
        self.attempted.append(bytes(data))
        if self._broken:
            raise StageError("stage disconnected while writing: [Errno 19] No such device")
        self._buffer += data
        while len(self._buffer) >= 6:
            msgid, p1, p2, dest, _ = struct.unpack_from("<HBBBB", self._buffer)
            size = 6 + (struct.unpack_from("<H", self._buffer, 2)[0] if dest & 0x80 else 0)
            if len(self._buffer) < size:
                break
            data_part, self._buffer = self._buffer[6:size], self._buffer[size:]
            self._handle(msgid, p1, p2, data_part)

    def read(self, timeout_s: float) -> bytes:
        if self._broken:
            raise StageError("stage disconnected while reading: [Errno 19] No such device")
        deadline = time.monotonic() + timeout_s
        while True:
            now = time.monotonic()
            ready = [p for p in self._pending if p[0] <= now]
            if ready:
                self._pending = [p for p in self._pending if p[0] > now]
                out = b"".join(d() if callable(d) else d for _, d in sorted(ready, key=lambda p: p[0]))
                if self.garbage:
                    self.garbage = False
                    return b"\xde\xad\xbe\xef\x00\x00" + out[6:]
                return out
            upcoming = min((p[0] for p in self._pending), default=deadline)
            if now >= deadline:
                return b""
            time.sleep(max(0.0, min(upcoming, deadline) - now))

    def close(self) -> None:
        pass
