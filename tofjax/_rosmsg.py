"""The fields of ROS messages, without ROS (issue 51 item 3; docs/simulators.md, "ROS messages"):
plain dictionaries with the field names and values of sensor_msgs/Image, CameraInfo and PointCloud2,
their ``data`` as ``bytes``, which a ROS node copies into its message (``msg.height = fields["height"]``
...) or a bridge serialises. NumPy only.

- ``ros_version=2`` (default): ROS 2's field names (CameraInfo's ``d``, ``k``, ``r``, ``p``; a header's
  ``stamp = {"sec", "nanosec"}``); ``ros_version=1``: ROS 1's (``D``, ``K``, ``R``, ``P``; ``stamp =
  {"secs", "nsecs"}`` and a ``seq`` of 0).
- Every array is written little-endian (``is_bigendian = 0``), rows top to bottom.
- Depth (REP 118): ``32FC1`` metres along the optical axis (Z), NaN where the camera delivers
  nothing (REP 117: invalid); ``16UC1`` millimetres, rounded, 0 where nothing is delivered or the
  depth does not fit (beyond 65.535 m).
"""

from __future__ import annotations

import math

import numpy as np

#: Image encodings (sensor_msgs/image_encodings.h): NumPy's little-endian type and channels.
ENCODINGS = {"32FC1": ("<f4", 1), "16UC1": ("<u2", 1), "mono16": ("<u2", 1), "8UC1": ("u1", 1), "mono8": ("u1", 1),
             "32SC1": ("<i4", 1), "64FC1": ("<f8", 1)}
#: sensor_msgs/PointField's datatype of FLOAT32.
FLOAT32 = 7


def header(stamp_s: float, frame_id: str, ros_version: int = 2) -> dict:
    """A std_msgs/Header's fields: the stamp split into whole seconds and nanoseconds."""
    _version(ros_version)
    sec = math.floor(stamp_s)
    nanosec = int(round((stamp_s - sec) * 1e9))
    if nanosec >= 1_000_000_000:
        sec, nanosec = sec + 1, nanosec - 1_000_000_000
    if ros_version == 1:
        return {"seq": 0, "stamp": {"secs": int(sec), "nsecs": nanosec}, "frame_id": frame_id}
    return {"stamp": {"sec": int(sec), "nanosec": nanosec}, "frame_id": frame_id}


def _version(ros_version: int) -> None:
    if ros_version not in (1, 2):
        raise ValueError(f"ros_version = {ros_version!r}: allowed 1 or 2")


def image(array, encoding: str, *, stamp_s: float = 0.0, frame_id: str = "", ros_version: int = 2) -> dict:
    """A sensor_msgs/Image's fields of ``array`` ``(height, width)`` in ``encoding``
    (:data:`ENCODINGS`). ``16UC1`` / ``mono16`` of a float array are millimetres of metres (REP 118's
    16-bit depth): rounded, 0 where not finite, <= 0 or beyond 65535 mm; ``32FC1`` keeps NaN."""
    if encoding not in ENCODINGS:
        raise ValueError(f"encoding = {encoding!r}: allowed {', '.join(ENCODINGS)}")
    a = np.asarray(array)
    if a.ndim != 2:
        raise ValueError(f"an image is (height, width), got shape {a.shape}")
    dtype, channels = ENCODINGS[encoding]
    if encoding in ("16UC1", "mono16") and np.issubdtype(a.dtype, np.floating):
        mm = np.rint(np.where(np.isfinite(a), a, 0.0) * 1e3)
        a = np.where((mm > 0.0) & (mm <= 65535.0), mm, 0.0)
    data = np.ascontiguousarray(a.astype(dtype))
    return {"header": header(stamp_s, frame_id, ros_version), "height": a.shape[0], "width": a.shape[1],
            "encoding": encoding, "is_bigendian": 0, "step": a.shape[1] * channels * np.dtype(dtype).itemsize,
            "data": data.tobytes()}


def camera_info(intrinsics: dict, *, stamp_s: float = 0.0, frame_id: str = "", ros_version: int = 2) -> dict:
    """A sensor_msgs/CameraInfo's fields from a camera's intrinsics (:func:`tofjax.optics.intrinsics`):
    ``distortion_model`` ``"plumb_bob"`` with D = (k1, k2, p1, p2, k3) (OpenCV's order, what tofjax's
    lens has), or ``"rational_polynomial"`` with (k1, k2, p1, p2, k3, k4, k5, k6) for eight
    coefficients; K the camera matrix, R the identity (a monocular camera), P = [K | 0] (the image is
    not rectified: P's focal lengths are K's, as most depth cameras publish them), no binning, no ROI."""
    _version(ros_version)
    fx, fy, cx, cy = (float(intrinsics[k]) for k in ("fx", "fy", "cx", "cy"))
    dist = [float(x) for x in intrinsics.get("dist_coeffs", [0.0] * 5)]
    if len(dist) == 5:
        model = "plumb_bob"
    elif len(dist) == 8:
        model = "rational_polynomial"
    else:
        raise ValueError(f"dist_coeffs has {len(dist)} coefficients: allowed 5 (plumb_bob) or 8 (rational_polynomial)")
    k = [fx, 0.0, cx, 0.0, fy, cy, 0.0, 0.0, 1.0]
    r = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0]
    p = [fx, 0.0, cx, 0.0, 0.0, fy, cy, 0.0, 0.0, 0.0, 1.0, 0.0]
    names = ("D", "K", "R", "P") if ros_version == 1 else ("d", "k", "r", "p")
    roi = {"x_offset": 0, "y_offset": 0, "height": 0, "width": 0, "do_rectify": False}
    return {"header": header(stamp_s, frame_id, ros_version), "height": int(intrinsics["height"]),
            "width": int(intrinsics["width"]), "distortion_model": model, names[0]: dist, names[1]: k, names[2]: r,
            names[3]: p, "binning_x": 0, "binning_y": 0, "roi": roi}


def pointcloud2(points, intensity=None, *, stamp_s: float = 0.0, frame_id: str = "", ros_version: int = 2) -> dict:
    """A sensor_msgs/PointCloud2's fields of an organized cloud ``points`` ``(height, width, 3)`` (m;
    NaN where there is no point) and an optional ``intensity`` ``(height, width)``: fields x, y, z
    (and intensity) FLOAT32 at offsets 0, 4, 8 (12), ``point_step`` 12 (16), ``row_step`` width x
    point_step, ``is_dense`` false (it has NaN points), little-endian, rows top to bottom."""
    p = np.asarray(points, dtype=np.float32)
    if p.ndim != 3 or p.shape[-1] != 3:
        raise ValueError(f"an organized cloud is (height, width, 3), got shape {p.shape}")
    names = ["x", "y", "z"]
    columns = [p[..., 0], p[..., 1], p[..., 2]]
    if intensity is not None:
        i = np.asarray(intensity, dtype=np.float32)
        if i.shape != p.shape[:2]:
            raise ValueError(f"intensity has shape {i.shape}: allowed the cloud's {p.shape[:2]}")
        names.append("intensity")
        columns.append(i)
    data = np.ascontiguousarray(np.stack(columns, axis=-1).astype("<f4"))
    step = 4 * len(names)
    fields = [{"name": n, "offset": 4 * j, "datatype": FLOAT32, "count": 1} for j, n in enumerate(names)]
    return {"header": header(stamp_s, frame_id, ros_version), "height": p.shape[0], "width": p.shape[1],
            "fields": fields, "is_bigendian": False, "point_step": step, "row_step": step * p.shape[1],
            "data": data.tobytes(), "is_dense": False}
