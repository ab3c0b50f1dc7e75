"""Cameras, lux meters and a virtual stage.

- :class:`VirtualCamera` renders frames with tofjax's Monte Carlo model at the stage's current
  position and the lux meter's current reading; every ROI pixel is an independent realisation of
  the centre pixel (the model has no spatial structure).
- :class:`RoyaleCamera` drives a pmd Royale camera through ``roypy`` when the SDK is installed
  (imported lazily; without it, a clear message says how to install it).
- :class:`ManualLuxMeter` asks the operator for the reading (thesis §5.5.2 used a handheld meter);
  :class:`VirtualLuxMeter` returns a set value.
"""

from __future__ import annotations

import dataclasses
import math

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import tofjax as tj


class CameraError(RuntimeError):
    """A camera failure or a missing SDK."""


@dataclasses.dataclass
class Frames:
    """``n`` frames of a ROI: depth (m), amplitude (LSB) and validity, each (n, height, width)."""

    depth_m: np.ndarray
    amplitude_lsb: np.ndarray
    valid: np.ndarray


class VirtualStage:
    """A stage that moves instantly (for virtual campaigns); same interface as :class:`AptStage`."""

    def __init__(self, position_m: float = 1.0, travel_m=(0.0, 10.0)):
        self._position, self.travel_m, self.counts_per_mm = float(position_m), tuple(travel_m), 1.0

    def enable(self) -> None: ...

    def home(self) -> None:
        self._position = self.travel_m[0]

    def move_to(self, position_m: float) -> float:
        from ._apt import StageLimitError

        lo, hi = self.travel_m
        if not lo <= position_m <= hi:
            raise StageLimitError(f"stage position {position_m!r} m is outside the travel: allowed {lo:g} <= value "
                                  f"<= {hi:g} m; nothing moved")
        self._position = float(position_m)
        return self._position

    def position_m(self) -> float:
        return self._position

    def stop(self) -> None: ...

    def close(self) -> None: ...


class VirtualLuxMeter:
    """Reads a set illuminance (lx)."""

    def __init__(self, value_lx: float = 0.0):
        self.value_lx = float(value_lx)

    def read_lx(self) -> float:
        return self.value_lx


class ManualLuxMeter:
    """Asks the operator to type the lux meter's reading (re-asks until it is a number >= 0)."""

    def __init__(self, ask=input, tell=print):
        self.ask, self.tell = ask, tell

    def read_lx(self) -> float:
        while True:
            text = self.ask("illuminance on the target [lx]: ").strip()
            try:
                value = float(text)
            except ValueError:
                value = math.nan
            if math.isfinite(value) and value >= 0:
                return value
            self.tell(f"{text!r} is not a number >= 0; type the lux meter's reading in lx")


class VirtualCamera:
    """A camera rendered by tofjax's Monte Carlo (module docstring).

    **Arguments:** ``params`` (the camera model), ``stage`` and ``lux_meter`` (read at every grab),
    ``roi`` (width, height) in pixels, ``seed``, ``distance_offset_m`` (stage reading to target distance).
    """

    model = "tofjax virtual camera"
    serial = "virtual-0"

    def __init__(self, params: tj.Params, stage, lux_meter, roi=(3, 3), seed: int = 0, distance_offset_m: float = 0.0):
        self.params, self.stage, self.lux, self.roi = params, stage, lux_meter, tuple(roi)
        self.offset = float(distance_offset_m)
        self._key = jax.random.key(seed)
        self._grabs = 0

    def open(self) -> None: ...

    def close(self) -> None: ...

    def set_integration_time(self, seconds: float) -> None:
        self.params = eqx.tree_at(lambda p: p.scene.integration_time_s, self.params, jnp.asarray(seconds, dtype=float))

    def set_modulation_frequency(self, hz: float) -> None:
        self.params = eqx.tree_at(lambda p: p.illumination_waveform.modulation_frequency_hz, self.params,
                                  jnp.asarray(hz, dtype=float))

    @property
    def modulation_frequency_hz(self) -> float:
        return float(self.params.illumination_waveform.modulation_frequency_hz)

    def grab(self, n: int) -> Frames:
        width, height = self.roi
        distance = self.stage.position_m() + self.offset
        p = eqx.tree_at(lambda q: q.scene.illuminance_lx, self.params, jnp.asarray(self.lux.read_lx(), dtype=float))
        key = jax.random.fold_in(self._key, self._grabs)
        self._grabs += 1
        frames = n * width * height
        r = tj.simulate(p, tj.Sweep("distance", [distance]), key, frames, keep_frames=frames)
        shape = (n, height, width)
        return Frames(np.asarray(r.depth_m[0]).reshape(shape), np.asarray(r.amplitude_lsb[0]).reshape(shape),
                      np.asarray(r.valid[0]).reshape(shape))


class RoyaleCamera:  # pragma: no cover - needs the pmd Royale SDK and a camera
    """A pmd Royale camera through ``roypy`` (the SDK's Python wrapper), centre ROI of ``roi`` pixels."""

    def __init__(self, roi=(3, 3), use_case: str | None = None):
        try:
            import roypy
        except ImportError:
            raise CameraError("the pmd Royale SDK's Python wrapper (roypy) is not importable: install the Royale SDK "
                              "from pmdtechnologies and add its python folder (with roypy and its shared library) to "
                              "PYTHONPATH; see README, 'Recording with real hardware'") from None
        self._roypy, self.roi, self.use_case = roypy, tuple(roi), use_case
        self._camera = None
        self.model = self.serial = "unknown"

    def open(self) -> None:
        manager = self._roypy.CameraManager()
        ids = manager.getConnectedCameraList()
        if ids.size() == 0:
            raise CameraError("no Royale camera is connected")
        self._camera = manager.createCamera(ids[0])
        self._camera.initialize()
        if self.use_case:
            self._camera.setUseCase(self.use_case)
        self.model, self.serial = str(self._camera.getCameraName()), str(self._camera.getId())

    def set_integration_time(self, seconds: float) -> None:
        self._camera.setExposureTime(int(round(seconds * 1e6)))

    def set_modulation_frequency(self, hz: float) -> None:
        raise CameraError("Royale sets the modulation frequency through the use case: choose one with use_case")

    def grab(self, n: int) -> Frames:
        import queue

        frames: queue.Queue = queue.Queue()
        roypy, width, height = self._roypy, *self.roi

        class Listener(roypy.IDepthDataListener):
            def onNewData(self, data):  # noqa: N802 - Royale's callback name
                w, h = data.width, data.height
                cx, cy = w // 2, h // 2
                depth = np.zeros((height, width))
                amp = np.zeros((height, width))
                ok = np.zeros((height, width), bool)
                for j in range(height):
                    for i in range(width):
                        k = (cy - height // 2 + j) * w + (cx - width // 2 + i)
                        depth[j, i], amp[j, i] = data.getZ(k), data.getGrayValue(k)
                        ok[j, i] = data.getDepthConfidence(k) > 0
                frames.put((depth, amp, ok))

        listener = Listener()
        self._camera.registerDataListener(listener)
        self._camera.startCapture()
        try:
            got = [frames.get(timeout=10.0) for _ in range(n)]
        finally:
            self._camera.stopCapture()
            self._camera.unregisterDataListener()
        return Frames(*(np.stack(x) for x in zip(*got, strict=True)))

    def close(self) -> None:
        self._camera = None
