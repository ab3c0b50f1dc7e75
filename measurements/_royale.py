"""pmd Royale cameras through ``roypy``, the Royale SDK's Python wrapper.

The calls are those of the SDK's documented Python samples (``sample_camera_info.py``,
``sample_retrieve_data.py``): ``roypy.CameraManager().getConnectedCameraList()``,
``createCamera(id)``, ``initialize()``, ``getUseCases()`` / ``setUseCase(name)``,
``setExposureMode(roypy.ExposureMode.MANUAL)``, ``getExposureLimits()``, ``setExposureTime(us)``,
``registerDataListener(listener)`` with a ``roypy.IDepthDataListener`` subclass whose
``onNewData(data)`` receives ``data.width``, ``data.height`` and ``data.npoints()`` (an array
(height, width, k) of x, y, z, noise, gray value, depth confidence), ``startCapture()`` /
``stopCapture()``, ``getCameraName()``, ``getId()``, ``getMaxSensorWidth()`` /
``getMaxSensorHeight()``.

What normal (level 1) users get, and how it is recorded (docs/measurements.md):
- depth: the point's ``z`` (m) after Royale's own processing (its use case fuses its modulation
  frequencies and unwraps), so depth statistics are linear, not circular (``depth_wrap_m`` None);
  for a centre ROI ``z`` equals the radial distance to within 1 - cos of the ROI's half angle;
- the gray value: an intensity-like number of unknown scale, not the model's amplitude in LSB. It
  is written to the ``gray_value_mean`` / ``gray_value_std`` columns, the amplitude columns stay
  empty, and the metadata says so; ``tofjax calibrate`` then fits depth noise only;
- validity: depth confidence > 0;
- the modulation frequency is not reported at level 1 (raw data needs level 2): it is taken from
  the configuration and the metadata says so.
"""

from __future__ import annotations

import queue

import numpy as np

from ._interfaces import CameraError, Frames

INSTALL_HINT = ("install the Royale SDK from pmdtechnologies and add its python folder (with roypy and its shared "
                "library) to PYTHONPATH; see README, 'Recording with real hardware'")
#: Columns of ``DepthData.npoints()`` (the SDK samples: x, y, z, noise, gray value, depth confidence).
_Z, _GRAY, _CONFIDENCE = 2, 4, 5


class RoyaleCamera:
    """A pmd Royale camera, centre ROI of ``roi`` (width, height) pixels.

    **Arguments:** ``roi``; ``use_case`` (a name from ``getUseCases()``; ``None`` keeps the
    camera's default); ``modulation_frequency_hz`` (the use case's frequency the depth noise refers
    to, from the configuration: Royale does not report it to level-1 users); ``timeout_s`` per frame;
    ``roypy`` (the module; default: import it, for tests a fake with the same API).
    """

    amplitude_quantity = "gray_value"
    depth_wrap_m = None  # Royale delivers unwrapped depth

    def __init__(self, roi=(3, 3), use_case: str | None = None, *, modulation_frequency_hz: float,
                 timeout_s: float = 10.0, roypy=None):
        if roypy is None:
            try:
                import roypy
            except ImportError:
                raise CameraError(f"the pmd Royale SDK's Python wrapper (roypy) is not importable: {INSTALL_HINT}") \
                    from None
        self._roypy, self.roi, self.use_case = roypy, tuple(int(v) for v in roi), use_case
        self._frequency_hz, self.timeout_s = float(modulation_frequency_hz), float(timeout_s)
        self._camera = None
        self.model = self.serial = "unknown"

    @property
    def modulation_frequency_hz(self) -> float:
        return self._frequency_hz

    def _call(self, what: str, fn, *args):
        try:
            return fn(*args)
        except CameraError:
            raise
        except Exception as err:  # noqa: BLE001 - the SDK raises its own kinds; report them uniformly
            raise CameraError(f"Royale camera: {what} failed: {err}") from None

    def open(self) -> None:
        manager = self._call("CameraManager()", self._roypy.CameraManager)
        ids = self._call("getConnectedCameraList()", manager.getConnectedCameraList)
        if (ids.size() if callable(getattr(ids, "size", None)) else len(ids)) == 0:  # a royale Vector, or a list
            raise CameraError("no Royale camera is connected (getConnectedCameraList() is empty)")
        camera = self._call("createCamera", manager.createCamera, ids[0])
        self._call("initialize()", camera.initialize)
        if self.use_case is not None:
            cases = [str(c) for c in self._call("getUseCases()", camera.getUseCases)]
            if self.use_case not in cases:
                raise CameraError(f"--use-case {self.use_case!r} is not a use case of this camera: allowed "
                                  + ", ".join(cases))
            self._call("setUseCase", camera.setUseCase, self.use_case)
        width, height = (int(self._call("sensor size", f)) for f in (camera.getMaxSensorWidth,
                                                                      camera.getMaxSensorHeight))
        if self.roi[0] > width or self.roi[1] > height:
            raise CameraError(f"--roi {self.roi[0]},{self.roi[1]} does not fit the sensor: allowed W <= {width}, "
                              f"H <= {height}")
        self._call("setExposureMode(MANUAL)", camera.setExposureMode, self._roypy.ExposureMode.MANUAL)
        self._camera = camera
        self.model = str(self._call("getCameraName()", camera.getCameraName))
        self.serial = str(self._call("getId()", camera.getId))

    def _require_open(self):
        if self._camera is None:
            raise CameraError("the Royale camera is not open (call open() first)")
        return self._camera

    def set_integration_time(self, seconds: float) -> None:
        camera = self._require_open()
        lo, hi = self._call("getExposureLimits()", camera.getExposureLimits)
        us = int(round(seconds * 1e6))
        if not lo <= us <= hi:
            raise CameraError(f"integration time {seconds:g} s = {us} us is outside this use case's exposure limits: "
                              f"allowed {lo} <= value <= {hi} us")
        self._call("setExposureTime", camera.setExposureTime, us)

    def grab(self, n: int) -> Frames:
        camera = self._require_open()
        frames: queue.Queue = queue.Queue()
        width, height = self.roi

        class Listener(self._roypy.IDepthDataListener):
            def onNewData(self, data):  # noqa: N802 - Royale's callback name
                points = np.asarray(data.npoints())  # (height, width, k)
                top, left = data.height // 2 - height // 2, data.width // 2 - width // 2
                roi = points[top:top + height, left:left + width]
                frames.put((roi[..., _Z].astype(float), roi[..., _GRAY].astype(float), roi[..., _CONFIDENCE] > 0))

        listener = Listener()
        self._call("registerDataListener", camera.registerDataListener, listener)
        self._call("startCapture()", camera.startCapture)
        try:
            got = []
            for i in range(n):
                try:
                    got.append(frames.get(timeout=self.timeout_s))
                except queue.Empty:
                    raise CameraError(f"the Royale camera delivered {i} of {n} frames, then nothing for "
                                      f"{self.timeout_s:g} s") from None
        finally:
            self._call("stopCapture()", camera.stopCapture)
            self._call("unregisterDataListener()", camera.unregisterDataListener)
        return Frames(*(np.stack(x) for x in zip(*got, strict=True)))

    def close(self) -> None:
        self._camera = None
