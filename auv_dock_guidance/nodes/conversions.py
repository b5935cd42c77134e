"""Messages <-> core types. The only place that knows both sides."""

from __future__ import annotations

import math

import numpy as np
from builtin_interfaces.msg import Time as TimeMsg
from geometry_msgs.msg import PoseStamped
from sensor_msgs.msg import CameraInfo, Image, Imu

from auv_dock_guidance.control.cascade import Attitude
from auv_dock_guidance.geometry.camera import CameraModel
from auv_dock_guidance.geometry.rotations import navigation_attitude, rep103_quaternion
from auv_dock_guidance.sim.world import VehiclePose
from auv_dock_guidance.vision.image_input import image_from_fields


def stamp_seconds(stamp: TimeMsg) -> float:
    return stamp.sec + stamp.nanosec * 1e-9


def seconds_stamp(seconds: float) -> TimeMsg:
    sec = math.floor(seconds)
    return TimeMsg(sec=int(sec), nanosec=int(round((seconds - sec) * 1e9)) % 1_000_000_000)


def image_to_array(msg: Image) -> np.ndarray:
    """The image message as an 8-bit BGR or mono array (a zero-copy view for bgr8 and mono8);
    ImageInputError when it does not add up."""
    return image_from_fields(msg.height, msg.width, msg.encoding, msg.step, msg.data, bool(msg.is_bigendian))


def array_to_image(frame: np.ndarray, stamp: TimeMsg, frame_id: str) -> Image:
    """An Image message (bgr8 or mono8) from a numpy frame, with one bytes copy."""
    msg = Image()
    msg.header.stamp = stamp
    msg.header.frame_id = frame_id
    msg.height, msg.width = int(frame.shape[0]), int(frame.shape[1])
    msg.encoding = "bgr8" if frame.ndim == 3 else "mono8"
    msg.step = msg.width * (3 if frame.ndim == 3 else 1)
    msg.data = np.ascontiguousarray(frame).tobytes()  # assigning the array itself costs ~0.5 s
    return msg


def camera_to_info(camera: CameraModel, stamp: TimeMsg) -> CameraInfo:
    msg = CameraInfo()
    msg.header.stamp = stamp
    msg.header.frame_id = camera.frame_id
    msg.width, msg.height = camera.width, camera.height
    msg.distortion_model = "plumb_bob"
    msg.d = [float(x) for x in camera.distortion]
    msg.k = [float(x) for x in camera.matrix.ravel()]
    msg.r = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0]
    msg.p = [camera.fx, 0.0, camera.cx, 0.0, 0.0, camera.fy, camera.cy, 0.0, 0.0, 0.0, 1.0, 0.0]
    return msg


def info_to_camera(msg: CameraInfo) -> CameraModel:
    """Raises CameraModelError for NaN, zero sizes or an unsupported model."""
    return CameraModel.from_camera_info(
        msg.width, msg.height, list(msg.k), list(msg.d), msg.distortion_model or "plumb_bob",
        frame_id=msg.header.frame_id or "camera_optical_frame",
    )


def attitude_to_imu(attitude: Attitude, rates: tuple[float, float, float], frame_id: str) -> Imu:
    """Navigation attitude (pitch nose up +, yaw to starboard +) as a REP 103 Imu message.

    REP 103 uses x forward, y left, z up (ENU world, FLU body): roll stays, pitch and yaw
    change sign.
    """
    msg = Imu()
    msg.header.stamp = seconds_stamp(attitude.stamp_s)
    msg.header.frame_id = frame_id
    qx, qy, qz, qw = rep103_quaternion(attitude.roll_rad, attitude.pitch_rad, attitude.yaw_rad)
    msg.orientation.x, msg.orientation.y, msg.orientation.z, msg.orientation.w = qx, qy, qz, qw
    msg.angular_velocity.x, msg.angular_velocity.y, msg.angular_velocity.z = rates[0], -rates[1], -rates[2]
    msg.linear_acceleration_covariance[0] = -1.0  # no acceleration data
    return msg


def imu_to_attitude(msg: Imu, depth_m: float) -> Attitude:
    q = msg.orientation
    roll, pitch, yaw = navigation_attitude(q.x, q.y, q.z, q.w)
    return Attitude(stamp_seconds(msg.header.stamp), roll, pitch, yaw, depth_m)


def vehicle_to_pose(pose: VehiclePose, stamp: TimeMsg, frame_id: str = "pool") -> PoseStamped:
    """The simulated vehicle in the world frame (REP 103 orientation)."""
    msg = PoseStamped()
    msg.header.stamp = stamp
    msg.header.frame_id = frame_id
    msg.pose.position.x, msg.pose.position.y, msg.pose.position.z = pose.x, pose.y, pose.z
    q = rep103_quaternion(pose.roll, pose.pitch, pose.yaw)
    msg.pose.orientation.x, msg.pose.orientation.y, msg.pose.orientation.z, msg.pose.orientation.w = q
    return msg


def pose_to_vehicle(msg: PoseStamped) -> VehiclePose:
    q = msg.pose.orientation
    roll, pitch, yaw = navigation_attitude(q.x, q.y, q.z, q.w)
    p = msg.pose.position
    return VehiclePose(p.x, p.y, p.z, roll, pitch, yaw)
