"""Messages <-> core types. The only place that knows both sides."""

from __future__ import annotations

import array
import math

import numpy as np
from builtin_interfaces.msg import Duration as DurationMsg
from builtin_interfaces.msg import Time as TimeMsg
from geometry_msgs.msg import Point, PoseStamped, PoseWithCovarianceStamped
from sensor_msgs.msg import CameraInfo, Image, Imu
from std_msgs.msg import Header
from visualization_msgs.msg import Marker

from auv_dock_guidance.control.cascade import Attitude
from auv_dock_guidance.geometry.camera import CameraModel
from auv_dock_guidance.geometry.rotations import navigation_attitude, navigation_yaw_rate, rep103_quaternion
from auv_dock_guidance.geometry.uncertainty import DockPose
from auv_dock_guidance.sim.world import VehiclePose
from auv_dock_guidance.vision.image_input import image_from_fields


def stamp_seconds(stamp: TimeMsg) -> float:
    return stamp.sec + stamp.nanosec * 1e-9


def _sec_nanosec(seconds: float) -> dict[str, int]:
    sec = math.floor(seconds)
    return {"sec": int(sec), "nanosec": int(round((seconds - sec) * 1e9)) % 1_000_000_000}


def seconds_stamp(seconds: float) -> TimeMsg:
    return TimeMsg(**_sec_nanosec(seconds))


def seconds_duration(seconds: float) -> DurationMsg:
    return DurationMsg(**_sec_nanosec(seconds))


def image_to_array(msg: Image) -> np.ndarray:
    """The image message as an 8-bit BGR or mono array (a zero-copy view for bgr8 and mono8);
    ImageInputError when it does not add up."""
    return image_from_fields(msg.height, msg.width, msg.encoding, msg.step, msg.data, bool(msg.is_bigendian))


def array_to_image(frame: np.ndarray, stamp: TimeMsg, frame_id: str) -> Image:
    """An Image message (bgr8 or mono8) from a numpy frame, with one copy of the pixels."""
    msg = Image(check_fields=True)  # checked fields take an array.array as it is; unchecked ones copy it
    msg.header.stamp = stamp
    msg.header.frame_id = frame_id
    msg.height, msg.width = int(frame.shape[0]), int(frame.shape[1])
    msg.encoding = "bgr8" if frame.ndim == 3 else "mono8"
    msg.step = msg.width * (3 if frame.ndim == 3 else 1)
    pixels = array.array("B")
    pixels.frombytes(np.ascontiguousarray(frame).data)  # assigning the numpy array itself costs ~0.5 s
    msg.data = pixels
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
    yaw_rate = navigation_yaw_rate(msg.angular_velocity.z, msg.angular_velocity_covariance[0])
    return Attitude(stamp_seconds(msg.header.stamp), roll, pitch, yaw, depth_m, yaw_rate)


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


def dock_pose_to_msg(pose: DockPose, header: Header) -> PoseWithCovarianceStamped:
    msg = PoseWithCovarianceStamped()
    msg.header = header
    p, q = msg.pose.pose.position, msg.pose.pose.orientation
    p.x, p.y, p.z = pose.position_m
    q.x, q.y, q.z, q.w = pose.orientation_xyzw
    msg.pose.covariance = np.array(pose.covariance, dtype=np.float64)
    return msg


DOCK_MARKER_NAMESPACE = "dock"
RING_MARKER_ID, AXIS_MARKER_ID = 0, 1


def dock_markers(pose: DockPose, marker_radius_m: float, header: Header, lifetime_s: float = 1.0,
                 axis_length_m: float = 1.0) -> list[Marker]:
    """The ring (a line strip of its true radius) and the dock axis (an arrow out of the
    entrance), both placed at the dock's pose; green where the axis was measured, amber
    where the ring was only seen face-on (its orientation then is the line of sight)."""
    angles = np.linspace(0.0, 2.0 * math.pi, 33)  # 32 segments: round on screen, 0.8 kB
    ring = _marker(pose, header, RING_MARKER_ID, Marker.LINE_STRIP, lifetime_s)
    ring.points = [Point(x=0.0, y=float(marker_radius_m * math.cos(a)), z=float(marker_radius_m * math.sin(a)))
                   for a in angles]  # the ring lies in the dock frame's y-z plane
    ring.scale.x = 0.03  # line width
    axis = _marker(pose, header, AXIS_MARKER_ID, Marker.ARROW, lifetime_s)
    axis.points = [Point(), Point(x=float(axis_length_m))]
    axis.scale.x, axis.scale.y, axis.scale.z = 0.03, 0.08, 0.12  # shaft, head diameter, head length
    return [ring, axis]


def clear_dock_markers(header: Header) -> list[Marker]:
    """DELETE for the ring and the axis: the dock was lost."""
    markers = []
    for marker_id in (RING_MARKER_ID, AXIS_MARKER_ID):
        marker = Marker()
        marker.header = header
        marker.ns, marker.id, marker.action = DOCK_MARKER_NAMESPACE, marker_id, Marker.DELETE
        markers.append(marker)
    return markers


def _marker(pose: DockPose, header: Header, marker_id: int, kind: int, lifetime_s: float) -> Marker:
    marker = Marker()
    marker.header = header
    marker.ns, marker.id, marker.type, marker.action = DOCK_MARKER_NAMESPACE, marker_id, kind, Marker.ADD
    p, q = marker.pose.position, marker.pose.orientation
    p.x, p.y, p.z = pose.position_m
    q.x, q.y, q.z, q.w = pose.orientation_xyzw
    marker.color.r, marker.color.g, marker.color.b, marker.color.a = \
        (0.1, 0.9, 0.3, 1.0) if pose.axis_observed else (1.0, 0.7, 0.1, 1.0)
    marker.lifetime = seconds_duration(lifetime_s)  # gone on its own if the DELETE is lost
    return marker
