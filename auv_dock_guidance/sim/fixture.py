"""A small recorded-looking bag made by the simulator: the replay regression fixture.

A straight approach from 10 m to 3 m past a surface reflection, 960x540 JPEG frames at
10 Hz with camera info and IMU, about 2 MB as MCAP. Regenerate with
``auv-dock make-fixture test/fixtures/approach_bag`` (then refresh the golden output with
``auv-dock replay test/fixtures/approach_bag --no-inputs --output test/fixtures/approach_golden``).
"""

from __future__ import annotations

import math
from pathlib import Path

import cv2
import numpy as np
from rosbags.rosbag2 import StoragePlugin, Writer
from rosbags.typesys import Stores, get_typestore

from auv_dock_guidance.errors import DockGuidanceError
from auv_dock_guidance.geometry.camera import paper_camera
from auv_dock_guidance.geometry.rotations import rep103_quaternion
from auv_dock_guidance.sim.scene import SceneSpec, render


def make_fixture(path: Path, frames: int = 30, rate_hz: float = 10.0, jpeg_quality: int = 85) -> None:
    if path.exists():
        raise DockGuidanceError(f"{path} exists; remove it first to regenerate the fixture")
    camera = paper_camera().scaled(0.5)
    ts = get_typestore(Stores.ROS2_JAZZY)
    t = ts.types
    writer = Writer(path, version=9, storage_plugin=StoragePlugin.MCAP)
    writer.open()
    image_conn = writer.add_connection("/camera/image_raw/compressed", "sensor_msgs/msg/CompressedImage", typestore=ts)
    info_conn = writer.add_connection("/camera/camera_info", "sensor_msgs/msg/CameraInfo", typestore=ts)
    imu_conn = writer.add_connection("/vehicle/imu", "sensor_msgs/msg/Imu", typestore=ts)
    start_ns = 1_700_000_000_000_000_000
    rng = np.random.default_rng(11)
    for i in range(frames):
        share = i / max(frames - 1, 1)
        stamp_ns = start_ns + int(i * 1e9 / rate_hz)
        stamp = t["builtin_interfaces/msg/Time"](sec=stamp_ns // 1_000_000_000, nanosec=stamp_ns % 1_000_000_000)
        header = t["std_msgs/msg/Header"](stamp=stamp, frame_id=camera.frame_id)
        spec = SceneSpec(
            marker_center_m=(0.8 * (1 - share), 0.4 * (1 - share) + 0.1, 10.0 - 7.0 * share),
            marker_normal=(0.1, 0.0, -1.0), brightness=3.0, attenuation_per_m=0.08, surface_height_m=1.6,
            reflection_gain=0.9, ripple_m=0.02, motion_blur_px=float(rng.uniform(0, 2)), seed=100 + i,
        )
        image, _ = render(camera, spec)
        ok, jpeg = cv2.imencode(".jpg", image, [cv2.IMWRITE_JPEG_QUALITY, jpeg_quality])
        if not ok:
            raise DockGuidanceError("JPEG encoding failed")
        msg = t["sensor_msgs/msg/CompressedImage"](header=header, format="jpeg", data=jpeg.ravel())
        writer.write(image_conn, stamp_ns, ts.serialize_cdr(msg, "sensor_msgs/msg/CompressedImage"))
        info = ts.serialize_cdr(_camera_info(t, header, camera), "sensor_msgs/msg/CameraInfo")
        writer.write(info_conn, stamp_ns, info)
        writer.write(imu_conn, stamp_ns, ts.serialize_cdr(_imu(t, header, math.radians(1.0) * math.sin(i / 5)),
                                                        "sensor_msgs/msg/Imu"))
    writer.close()


def _camera_info(t, header, camera):
    roi = t["sensor_msgs/msg/RegionOfInterest"](x_offset=0, y_offset=0, height=0, width=0, do_rectify=False)
    return t["sensor_msgs/msg/CameraInfo"](
        header=header, height=camera.height, width=camera.width, distortion_model="plumb_bob",
        d=np.array(camera.distortion, dtype=np.float64), k=camera.matrix.ravel().astype(np.float64),
        r=np.eye(3).ravel(), p=np.array([camera.fx, 0, camera.cx, 0, 0, camera.fy, camera.cy, 0, 0, 0, 1, 0],
                                        dtype=np.float64),
        binning_x=0, binning_y=0, roi=roi,
    )


def _imu(t, header, yaw):
    x, y, z, w = rep103_quaternion(0.0, 0.0, yaw)
    vector = t["geometry_msgs/msg/Vector3"]
    return t["sensor_msgs/msg/Imu"](
        header=t["std_msgs/msg/Header"](stamp=header.stamp, frame_id="base_link"),
        orientation=t["geometry_msgs/msg/Quaternion"](x=x, y=y, z=z, w=w),
        orientation_covariance=np.zeros(9), angular_velocity=vector(x=0.0, y=0.0, z=0.0),
        angular_velocity_covariance=np.zeros(9), linear_acceleration=vector(x=0.0, y=0.0, z=0.0),
        linear_acceleration_covariance=np.array([-1.0] + [0.0] * 8),
    )
