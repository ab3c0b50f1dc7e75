"""A ToF sensor for robot simulators (issue 51; docs/simulators.md): a :class:`tofjax.Camera` stepped
frame by frame with a simulator's depth buffers, delivering what the camera would in the robot
stack's conventions.

- :class:`ToFSensor` ``(camera, seed=0, ...)``: holds the prepared camera, its fixed pattern, the
  random key stream, the clock and the buffers' resampling; ``sensor.step(depth, intrinsics=...,
  ...)`` makes one :class:`SensorFrame` (REP 118 depth, radial distance, amplitude, confidence, flags,
  an organized point cloud, the stamp, raw phase images on request; two-bounce light from the
  buffers with ``multipath=True``).
- :func:`image`, :func:`camera_info`, :func:`pointcloud2`, :func:`header`: the fields of
  sensor_msgs/Image, CameraInfo, PointCloud2 and std_msgs/Header as plain dictionaries (no ROS needed;
  a frame's :meth:`SensorFrame.image`, :meth:`SensorFrame.camera_info`, :meth:`SensorFrame.pointcloud2`).

Example::

    import numpy as np, tofjax as tj
    from tofjax.sensor import ToFSensor

    sensor = ToFSensor(tj.Camera.from_config(tj.preset_config("melexis-mlx75027")), seed=1)
    for t in np.arange(10) / 30.0:
        depth = np.full((600, 800), 1.2, dtype=np.float32)            # the simulator's planar depth, m
        frame = sensor.step(depth, fov_deg=100.0, time_s=t)           # its buffer: 100 degrees across
        msg = frame.image("depth")                                    # sensor_msgs/Image fields, 32FC1
"""

from ._rosmsg import camera_info, header, image, pointcloud2
from ._sensor import DEPTH_TYPES, SensorFrame, ToFSensor

__all__ = ["DEPTH_TYPES", "SensorFrame", "ToFSensor", "camera_info", "header", "image", "pointcloud2"]
