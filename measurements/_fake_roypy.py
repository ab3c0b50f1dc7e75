"""A fake ``roypy`` (the pmd Royale SDK's Python wrapper) for tests and demonstrations.

It mimics the API :class:`measurements.RoyaleCamera` uses, as the SDK's Python samples document it
(see :mod:`measurements._royale`): a camera manager listing connected cameras, a camera with use
cases, a manual exposure mode, exposure limits and time, and a data listener called from the
SDK's own thread with depth data whose ``npoints()`` is an array (height, width, 6) of x, y, z,
noise, gray value and depth confidence. The scene is a flat target at ``distance_m()`` with
Gaussian depth noise; the gray value grows with the exposure time.

Use it in place of the module: ``sys.modules["roypy"] = FakeRoypy(...)``, or pass it as
``RoyaleCamera(..., roypy=FakeRoypy(...))``.
"""

from __future__ import annotations

import threading
import time
import types

import numpy as np


class _DepthData:
    def __init__(self, points: np.ndarray):
        self._points = points
        self.height, self.width = points.shape[:2]

    def npoints(self) -> np.ndarray:
        return self._points

    def getNumPoints(self) -> int:  # noqa: N802 - Royale's names
        return self.width * self.height

    def getZ(self, i: int) -> float:  # noqa: N802
        return float(self._points.reshape(-1, 6)[i, 2])

    def getGrayValue(self, i: int) -> int:  # noqa: N802
        return int(self._points.reshape(-1, 6)[i, 4])

    def getDepthConfidence(self, i: int) -> int:  # noqa: N802
        return int(self._points.reshape(-1, 6)[i, 5])


class _Camera:
    def __init__(self, fake: FakeRoypy, camera_id: str):
        self._fake, self._id = fake, camera_id
        self._initialized = False
        self._use_case = fake.use_cases[0]
        self._mode = fake.ExposureMode.AUTOMATIC
        self._exposure_us = fake.exposure_limits_us[1]
        self._listener = None
        self._thread: threading.Thread | None = None
        self._running = threading.Event()
        self._rng = np.random.default_rng(fake.seed)

    def _need_init(self):
        if not self._initialized:
            raise RuntimeError("camera not initialized (royale::CameraStatus::DEVICE_NOT_INITIALIZED)")

    def initialize(self) -> None:
        self._initialized = True

    def getCameraName(self) -> str:  # noqa: N802
        return self._fake.camera_name

    def getId(self) -> str:  # noqa: N802
        return self._id

    def getUseCases(self) -> list[str]:  # noqa: N802
        self._need_init()
        return list(self._fake.use_cases)

    def setUseCase(self, name: str) -> None:  # noqa: N802
        self._need_init()
        if name not in self._fake.use_cases:
            raise RuntimeError(f"use case {name!r} not found (royale::CameraStatus::INVALID_VALUE)")
        self._use_case = name

    def getMaxSensorWidth(self) -> int:  # noqa: N802
        return self._fake.sensor[0]

    def getMaxSensorHeight(self) -> int:  # noqa: N802
        return self._fake.sensor[1]

    def setExposureMode(self, mode) -> None:  # noqa: N802
        self._need_init()
        self._mode = mode

    def getExposureLimits(self) -> tuple[int, int]:  # noqa: N802
        return self._fake.exposure_limits_us

    def setExposureTime(self, us: int) -> None:  # noqa: N802
        self._need_init()
        lo, hi = self._fake.exposure_limits_us
        if self._mode != self._fake.ExposureMode.MANUAL:
            raise RuntimeError("exposure mode is automatic (royale::CameraStatus::EXPOSURE_MODE_INVALID)")
        if not lo <= us <= hi:
            raise RuntimeError("exposure time out of bounds (royale::CameraStatus::EXPOSURE_TIME_NOT_SUPPORTED)")
        self._exposure_us = int(us)

    def registerDataListener(self, listener) -> None:  # noqa: N802
        if not isinstance(listener, self._fake.IDepthDataListener):
            raise TypeError("listener must derive from roypy.IDepthDataListener")
        self._listener = listener

    def unregisterDataListener(self) -> None:  # noqa: N802
        self._listener = None

    def _frame(self) -> _DepthData:
        w, h = self._fake.sensor
        z = self._fake.distance_m() + self._fake.depth_noise_m * self._rng.standard_normal((h, w))
        gray = np.full((h, w), min(4095, 100 + self._exposure_us // 2)) + self._rng.integers(0, 5, (h, w))
        points = np.zeros((h, w, 6), dtype=np.float32)
        points[..., 2], points[..., 3], points[..., 4], points[..., 5] = z, self._fake.depth_noise_m, gray, 255
        return _DepthData(points)

    def startCapture(self) -> None:  # noqa: N802
        self._need_init()
        if self._listener is None:
            raise RuntimeError("no data listener registered")
        self._running.set()

        def deliver():  # the SDK calls onNewData from its own thread, frame after frame
            while self._running.is_set():
                listener = self._listener
                if listener is not None:
                    listener.onNewData(self._frame())
                time.sleep(self._fake.frame_period_s or 0.0005)

        self._thread = threading.Thread(target=deliver, daemon=True)
        self._thread.start()

    def stopCapture(self) -> None:  # noqa: N802
        self._running.clear()
        if self._thread is not None:
            self._thread.join()
            self._thread = None


class FakeRoypy(types.SimpleNamespace):
    """A stand-in for the ``roypy`` module (module docstring).

    **Arguments:** ``distance_m`` (callable returning the target's distance, m), ``cameras`` (how
    many are connected), ``sensor`` (width, height), ``use_cases``, ``exposure_limits_us``,
    ``depth_noise_m``, ``frame_period_s``, ``seed``, ``camera_name``.
    """

    def __init__(self, distance_m=lambda: 1.0, *, cameras: int = 1, sensor=(224, 172),
                 use_cases=("MODE_9_5FPS_2000", "MODE_5_45FPS_500"), exposure_limits_us=(50, 2000),
                 depth_noise_m: float = 0.003, frame_period_s: float = 0.0, seed: int = 0,
                 camera_name: str = "PICOFLEXX (fake roypy)"):
        fake = self

        class IDepthDataListener:  # noqa: N801 - Royale's name
            def onNewData(self, data):  # noqa: N802
                raise NotImplementedError

        class CameraManager:
            def getConnectedCameraList(self):  # noqa: N802
                return [f"0005-4805-0050-{i:04d}" for i in range(fake.cameras)]

            def createCamera(self, camera_id):  # noqa: N802
                return _Camera(fake, camera_id)

        super().__init__(
            distance_m=distance_m, cameras=cameras, sensor=tuple(sensor), use_cases=tuple(use_cases),
            exposure_limits_us=tuple(exposure_limits_us), depth_noise_m=depth_noise_m, frame_period_s=frame_period_s,
            seed=seed, camera_name=camera_name, IDepthDataListener=IDepthDataListener, CameraManager=CameraManager,
            ExposureMode=types.SimpleNamespace(MANUAL=0, AUTOMATIC=1),
        )
