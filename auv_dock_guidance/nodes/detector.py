"""detector node: camera frames in, the dock's position and bearing out.

Subscribes  camera/image_raw (sensor_msgs/Image), camera/camera_info (sensor_msgs/CameraInfo)
Publishes   dock/target (geometry_msgs/PointStamped, metres, camera optical frame),
            dock/bearing (geometry_msgs/Vector3Stamped: x yaw rad, y pitch rad, z range m),
            dock/pose (geometry_msgs/PoseWithCovarianceStamped, camera optical frame: the ring's
            centre, x axis along the dock's axis; see geometry/uncertainty.py),
            dock/marker (visualization_msgs/Marker: the ring and the dock axis; DELETE when lost),
            dock/detected (std_msgs/Bool, every frame),
            dock/debug_image/compressed (sensor_msgs/CompressedImage, JPEG, throttled),
            /diagnostics (diagnostic_msgs/DiagnosticArray, 1 Hz: rate, skipped frames, timings)
Tracking (on by default) refines a window around where the marker is predicted to be; it
searches the whole frame when the marker is lost, and every ``full_search_every`` frames
a slice at a time over the next frames (no frame waits for a whole search).
Only the newest frame is processed: a slow frame never queues stale ones. Frames the
camera published but the detector never saw are counted from the publisher's sequence
numbers and reported on /diagnostics. In one process with camera_ingest
(vision_pipeline) frames are handed over directly (``submit``), without a copy.
Frames whose stamp repeats or goes back, malformed frames and unusable camera info are
refused, logged with the reason and counted on /diagnostics (WARN while it happens).
"""

from __future__ import annotations

import threading
import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, cast

import numpy as np
from builtin_interfaces.msg import Time as TimeMsg
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from geometry_msgs.msg import PointStamped, PoseWithCovarianceStamped, Vector3Stamped
from rclpy.node import Node
from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import CameraInfo, CompressedImage, Image
from std_msgs.msg import Bool, Header
from visualization_msgs.msg import Marker

from auv_dock_guidance.errors import ConfigError, DockGuidanceError
from auv_dock_guidance.geometry.camera import ApproximateLens, CameraModel
from auv_dock_guidance.geometry.pose import MarkerPose
from auv_dock_guidance.geometry.uncertainty import dock_pose, observation_of
from auv_dock_guidance.nodes.common import (
    InputProblems,
    Param,
    declare,
    diagnostic_status,
    on_parameter_change,
    publish_diagnostics,
    run_node,
)
from auv_dock_guidance.nodes.conversions import (
    clear_dock_markers,
    dock_markers,
    dock_pose_to_msg,
    image_to_array,
    info_to_camera,
    stamp_seconds,
)
from auv_dock_guidance.stamps import StampGate
from auv_dock_guidance.vision.detector import Detection, Detector, DetectorConfig
from auv_dock_guidance.vision.marker import colour_bgr
from auv_dock_guidance.vision.overlay import overlay_jpeg, overlay_text
from auv_dock_guidance.vision.selection import SelectionConfig
from auv_dock_guidance.vision.threshold import ThresholdConfig

PARAMS = [
    Param("marker_radius_m", 0.35, "radius of the LED ring's centre line (m)", 0.01, 5.0),
    Param("marker_led_count", -1, "LEDs on the ring: 0 a continuous strip, -1 not known (found from the frames)",
          -1, 360),
    Param("marker_colour", "", "colour of the LEDs: #RRGGBB or blue, green, red, white, cyan, yellow, magenta; "
          "empty: any colour"),
    Param("approximate_focal_px", 0.0, "no calibration: focal length in pixels (principal point at the centre, "
          "no distortion; ranges approximate); 0: off", 0.0, 100000.0, read_only=True),
    Param("approximate_hfov_deg", 0.0, "no calibration: horizontal field of view instead; 0: off", 0.0, 170.0,
          read_only=True),
    Param("max_range_m", 40.0, "rings that look smaller than at this range are rejected (m)", 1.0, 200.0),
    Param("camera_info_file", "", "camera_info YAML; empty: use the camera_info topic"),
    Param("reliable", True, "reliable image QoS (with the shared-memory profile) instead of best effort",
          read_only=True),
    Param("tracking", True, "refine a window around the predicted marker; search the whole frame when lost"),
    Param("track_window_radii", 1.5, "tracking window half-width in ring radii (plus room for motion)", 0.5, 20.0),
    Param("full_search_every", 15, "while tracking, still search the whole frame this often (frames)", 1, 1000),
    Param("debug_image_rate_hz", 2.0, "debug overlay rate (0 = off)", 0.0, 30.0),
    Param("debug_image_scale", 0.25, "debug overlay size relative to the frame", 0.05, 1.0),
    Param("debug_jpeg_quality", 60, "debug overlay JPEG quality", 10, 100),
    Param("dock_marker_rate_hz", 2.0, "dock/marker rate: a 3D panel needs no more (0 = off)", 0.0, 30.0),
    Param("threshold.reference_radius_px", 80.0, "apparent ring radius at an intermediate range (px)", 5.0, 1000.0),
    Param("threshold.fraction_at_reference", 0.4, "threshold share of (peak - background) there", 0.05, 0.95),
    Param("threshold.fraction_far", 0.2, "lowest share (faint, far light)", 0.01, 0.95),
    Param("threshold.fraction_near", 0.6, "highest share (LEDs, not halo)", 0.05, 0.99),
    Param("threshold.floor_grey", 8.0, "threshold floor above the background (grey levels)", 0.0, 100.0),
    Param("threshold.floor_noise_sigmas", 5.0, "threshold floor in noise deviations", 0.0, 20.0),
    Param("selection.tie_ratio", 0.7, "areas within this ratio count as equally large", 0.05, 1.0),
]


def detector_config(values: dict[str, Any]) -> DetectorConfig:
    """Raises ConfigError with a reason when the combination is invalid."""
    threshold = ThresholdConfig(
        **{k.split(".", 1)[1]: float(v) for k, v in values.items() if k.startswith("threshold.")})
    selection = SelectionConfig(tie_ratio=float(values["selection.tie_ratio"]))
    count = int(values["marker_led_count"])
    return DetectorConfig(
        marker_radius_m=float(values["marker_radius_m"]),
        led_count=None if count < 0 else count,
        led_bgr=colour_bgr(str(values["marker_colour"])) if values["marker_colour"] else None,
        max_range_m=float(values["max_range_m"]),
        tracking=bool(values["tracking"]),
        track_window_radii=float(values["track_window_radii"]),
        full_search_every=int(values["full_search_every"]),
        threshold=threshold,
        selection=selection,
    )


def approximate(values: dict[str, Any]) -> ApproximateLens | None:
    """The approximate camera the parameters ask for (None: use camera_info)."""
    focal, hfov = float(values["approximate_focal_px"]), float(values["approximate_hfov_deg"])
    if focal <= 0 and hfov <= 0:
        return None
    if focal > 0 and hfov > 0:
        raise ConfigError("approximate_focal_px and approximate_hfov_deg: give one, not both")
    return ApproximateLens(focal_px=focal if focal > 0 else None, hfov_deg=hfov if hfov > 0 else None)


@dataclass(frozen=True)
class Frame:
    """A camera frame on its way to the detector; ``sequence`` counts the camera's frames."""

    image: np.ndarray
    stamp: TimeMsg
    frame_id: str
    sequence: int


class NewestFrame:
    """One slot between a camera thread and the detector: a frame not taken before the next
    one arrives is replaced (the detector works on the newest)."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._frame: Frame | None = None

    def put(self, frame: Frame) -> None:
        with self._lock:
            self._frame = frame

    def take(self) -> Frame | None:
        with self._lock:
            frame, self._frame = self._frame, None
        return frame


class DetectorNode(Node):
    def __init__(self, subscribe: bool = True) -> None:
        """``subscribe``: frames come from the camera/image_raw topic; otherwise only
        through ``submit`` (camera_ingest in the same process)."""
        super().__init__("detector")
        self.values = declare(self, PARAMS)
        self.config = detector_config(self.values)
        camera = CameraModel.from_yaml(self.values["camera_info_file"]) if self.values["camera_info_file"] else None
        self._calibrated = camera  # as calibrated; the detector's may be scaled to the frames
        self.detector = Detector(camera, self.config, lens=approximate(self.values))
        on_parameter_change(self, self._apply_parameters)
        reliability = ReliabilityPolicy.RELIABLE if self.values["reliable"] else ReliabilityPolicy.BEST_EFFORT
        newest_only = QoSProfile(depth=1, history=HistoryPolicy.KEEP_LAST, reliability=reliability)
        if subscribe:
            # rclpy passes the message info (publication sequence numbers) to two-argument callbacks
            with_info = cast(Callable[[Any], None], self._on_image)
            self.create_subscription(Image, "camera/image_raw", with_info, newest_only)
        self.create_subscription(CameraInfo, "camera/camera_info", self._on_camera_info, 1)
        self.target_pub = self.create_publisher(PointStamped, "dock/target", 10)
        self.bearing_pub = self.create_publisher(Vector3Stamped, "dock/bearing", 10)
        self.detected_pub = self.create_publisher(Bool, "dock/detected", 10)
        self.pose_pub = self.create_publisher(PoseWithCovarianceStamped, "dock/pose", 10)
        self.marker_pub = self.create_publisher(Marker, "dock/marker", 10)
        self.debug_pub = self.create_publisher(CompressedImage, "dock/debug_image/compressed", 1)
        self.diag_pub = self.create_publisher(DiagnosticArray, "/diagnostics", 10)
        self.create_timer(1.0, lambda: publish_diagnostics(self, self.diag_pub, self.diagnostics()))
        self._times: deque[tuple[float, float, bool, float]] = deque(maxlen=300)  # (time, s, found, frame age s)
        self._skips: deque[tuple[float, int]] = deque(maxlen=300)  # (time, frames skipped)
        self.problems = InputProblems(self)
        self._frame_order = StampGate()
        self._inbox = NewestFrame()
        self._wake = self.create_guard_condition(self._on_submitted)
        self._last_sequence: int | None = None
        self.frames_processed = 0
        self.frames_skipped = 0
        self._last_debug = 0.0
        self._last_marker = 0.0
        self._found = False
        self._warned_no_camera = False

    def _apply_parameters(self, changes: dict[str, Any]) -> str | None:
        values = {**self.values, **changes}
        try:
            config = detector_config(values)
        except DockGuidanceError as exc:
            return str(exc)
        self.values, self.config = values, config
        self.detector.config = config
        self.detector.threshold.config = config.threshold
        return None

    def _on_camera_info(self, msg: CameraInfo) -> None:
        if self.values["camera_info_file"] or self.detector.lens is not None:
            return
        try:
            camera = info_to_camera(msg)
        except DockGuidanceError as exc:
            self.problems.report("camera_info", str(exc))
            return
        if camera != self._calibrated:
            self.get_logger().info(f"camera model {camera.width}x{camera.height} fx {camera.fx:.1f} from camera_info")
            self._calibrated = self.detector.camera = camera

    def submit(self, image: np.ndarray, stamp: TimeMsg, frame_id: str, sequence: int) -> None:
        """A frame from camera_ingest in this process (any thread): processed on this node's
        executor, unless a newer one comes first."""
        self._inbox.put(Frame(image, stamp, frame_id, sequence))
        self._wake.trigger()

    def _on_submitted(self) -> None:
        frame = self._inbox.take()
        if frame is not None:
            self._count_skipped(frame.sequence)
            self._process(frame)

    def _on_image(self, msg: Image, info: dict[str, Any]) -> None:
        sequence = info.get("publication_sequence_number")
        sequence = sequence if isinstance(sequence, int) else -1
        self._count_skipped(sequence)
        try:
            image = image_to_array(msg)
        except DockGuidanceError as exc:
            self.problems.report("frame", str(exc))
            return
        self._process(Frame(image, msg.header.stamp, msg.header.frame_id, sequence))

    def _count_skipped(self, sequence: int) -> None:
        """Count the frames the camera sent between the last one that reached the detector and
        this one (never seen: a newer one came while a frame was processed)."""
        last, self._last_sequence = self._last_sequence, sequence if sequence >= 0 else None
        if last is not None and sequence > last + 1:  # not the first, numbered, not a restarted camera
            self.frames_skipped += sequence - last - 1
            self._skips.append((time.monotonic(), sequence - last - 1))

    def _process(self, frame: Frame) -> None:
        if self.detector.camera is None and self.detector.lens is None:
            if not self._warned_no_camera:
                self._warned_no_camera = True
                self.get_logger().warn("no camera model yet (camera_info topic or camera_info_file): frames skipped")
            return
        stamp = stamp_seconds(frame.stamp)
        out_of_order = self._frame_order.admit(stamp)
        if out_of_order is not None:
            self.problems.report("frame_stamp", f"{out_of_order} (frame stamped {stamp:.3f} s)")
            return
        start = time.perf_counter()
        try:
            note = self.detector.fit_camera(frame.image.shape[1], frame.image.shape[0])
            if note is not None:
                self.get_logger().info(note)
            detection = self.detector.detect(frame.image, stamp)
        except DockGuidanceError as exc:
            self.problems.report("frame", str(exc))
            return
        elapsed = time.perf_counter() - start
        self.detected_pub.publish(Bool(data=detection.found))
        pose = detection.pose
        camera = self.detector.camera
        assert camera is not None  # a frame is processed with a camera model (calibrated or approximate)
        header = Header(stamp=frame.stamp, frame_id=frame.frame_id or camera.frame_id)
        if detection.found and pose is not None:
            self._publish_position(header, pose)
            self._publish_dock_pose(header, detection)
        if detection.found != self._found:
            self._found = detection.found
            self.get_logger().info("marker found" if detection.found else f"marker lost: {detection.reason}")
            if not detection.found:
                for marker in clear_dock_markers(header):
                    self.marker_pub.publish(marker)
        self.frames_processed += 1
        self._times.append((time.monotonic(), elapsed, detection.found, time.time() - stamp))
        self._maybe_publish_debug(frame, detection)

    def _publish_position(self, header: Header, pose: MarkerPose) -> None:
        target = PointStamped()
        target.header = header
        target.point.x, target.point.y, target.point.z = pose.offset_x_m, pose.offset_y_m, pose.range_m
        self.target_pub.publish(target)
        bearing = Vector3Stamped()
        bearing.header = header
        bearing.vector.x, bearing.vector.y, bearing.vector.z = pose.yaw_rad, pose.pitch_rad, pose.range_m
        self.bearing_pub.publish(bearing)

    def _publish_dock_pose(self, header: Header, detection: Detection) -> None:
        """dock/pose with its covariance, and the ring and axis for a 3D panel (while anyone listens)."""
        if self.pose_pub.get_subscription_count() == 0 and self.marker_pub.get_subscription_count() == 0:
            return
        camera = self.detector.camera
        assert camera is not None  # frames are only processed with a camera model
        radius = self.config.marker_radius_m
        observation = observation_of(detection, radius, camera.focal_px, camera.width)
        if observation is None:
            return
        try:
            pose = dock_pose(observation)
        except ValueError as exc:  # a fit behind the camera: nothing to publish
            self.problems.report("dock_pose", str(exc))
            return
        self.pose_pub.publish(dock_pose_to_msg(pose, header))
        rate = self.values["dock_marker_rate_hz"]
        now = time.monotonic()
        if rate > 0 and now - self._last_marker >= 1.0 / rate:
            self._last_marker = now
            for marker in dock_markers(pose, radius, header):
                self.marker_pub.publish(marker)

    def _maybe_publish_debug(self, frame: Frame, detection: Any) -> None:
        rate = self.values["debug_image_rate_hz"]
        now = time.monotonic()
        if rate <= 0 or now - self._last_debug < 1.0 / rate or self.debug_pub.get_subscription_count() == 0:
            return
        self._last_debug = now
        camera = self.detector.camera
        assert camera is not None  # frames are only processed with a camera model
        text = overlay_text(detection, self.detector.threshold.fraction)
        out = CompressedImage()
        out.header.stamp, out.header.frame_id = frame.stamp, frame.frame_id
        out.format = "jpeg"
        out.data = overlay_jpeg(frame.image, detection, (camera.cx, camera.cy), text,
                                self.values["debug_image_scale"], self.values["debug_jpeg_quality"])
        self.debug_pub.publish(out)

    def diagnostics(self) -> DiagnosticStatus:
        """Real rate, frames skipped, processing time, frame age at publication, detection rate,
        threshold; WARN without frames, while skipping more than 1 % of them, or refusing input."""
        now = time.monotonic()
        recent = [t for t in self._times if now - t[0] < 5.0]
        fps = len(recent) / 5.0
        processing = sorted(t[1] for t in recent)
        ages = sorted(t[3] for t in recent)
        skipped = sum(n for t, n in self._skips if now - t < 5.0)
        share = self.detector.threshold.fraction
        level, message = (DiagnosticStatus.OK, f"{fps:.1f} fps") if recent else \
            (DiagnosticStatus.WARN, "no frames processed in the last 5 s")
        if skipped > 0.01 * (skipped + len(recent)):
            level, message = DiagnosticStatus.WARN, f"{message}; behind the camera: {skipped} frames skipped in 5 s"
        if self.problems.recent():
            level, message = DiagnosticStatus.WARN, f"{message}; refusing input: {self.problems.last_reason}"
        return diagnostic_status(
            "detector", "camera", level, message,
            {
                "fps": f"{fps:.2f}",
                "frames_processed": self.frames_processed,
                "frames_skipped": self.frames_skipped,
                "skipped_last_5s": skipped,
                "tracking": "on" if self.config.tracking else "off",
                "processing_ms_p50": _ms(processing, 0.5),
                "processing_ms_p95": _ms(processing, 0.95),
                "frame_age_ms_p95": _ms(ages, 0.95),
                "detection_rate": f"{sum(t[2] for t in recent) / len(recent):.3f}" if recent else "0",
                "threshold_share": f"{share:.3f}" if share is not None else "nan",
                **self.problems.values(),
            },
        )


def _ms(ordered: list[float], quantile: float) -> str:
    """A quantile of sorted seconds, in milliseconds ('nan' when empty)."""
    return f"{1000 * ordered[min(len(ordered) - 1, int(quantile * len(ordered)))]:.2f}" if ordered else "nan"


def main(args: list[str] | None = None) -> int:
    return run_node(DetectorNode, args)


if __name__ == "__main__":
    raise SystemExit(main())
