"""camera_ingest node: frames from a camera, a video, a folder or the simulator, published with camera info.

Publishes   camera/image_raw (sensor_msgs/Image, bgr8), camera/camera_info (sensor_msgs/CameraInfo),
            /diagnostics (1 Hz: frames, drops, stalls)
Subscribes  sim/vehicle_pose (geometry_msgs/PoseStamped, source 'sim' only)
Sources (parameter ``source``): 'device' (V4L2 index or path), 'video' (file or GStreamer
pipeline via OpenCV), 'folder' (images in name order, optionally looping), 'sim' (renders
the pool scene from the vehicle pose the simulator publishes).
Frames are captured on a thread of their own, on the camera's clock whatever the consumers
do, and stamped when captured (the sim source renders on the executor instead: rendering
stands in for camera hardware and must not take the CPU from the detector).
camera/image_raw is only filled while someone subscribes (one copy of the frame into the
message); a detector in the same process (vision_pipeline) gets each frame through
``frame_sinks`` without a copy.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from pathlib import Path

import cv2
import numpy as np
from builtin_interfaces.msg import Time as TimeMsg
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from geometry_msgs.msg import PoseStamped
from rclpy.node import Node
from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import CameraInfo, Image

from auv_dock_guidance.errors import ConfigError, DockGuidanceError
from auv_dock_guidance.geometry.camera import CameraModel, paper_camera
from auv_dock_guidance.nodes.common import (
    InputProblems,
    Param,
    declare,
    diagnostic_status,
    publish_diagnostics,
    run_node,
)
from auv_dock_guidance.nodes.conversions import array_to_image, camera_to_info, pose_to_vehicle, seconds_stamp
from auv_dock_guidance.sim.scene import render
from auv_dock_guidance.sim.world import PoolWorld, VehiclePose
from auv_dock_guidance.vision.image_input import read_image

FrameSink = Callable[[np.ndarray, TimeMsg, str, int], None]  # (frame, stamp, frame_id, sequence number)
IMAGE_SUFFIXES = {".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff"}
MAX_CACHED_FRAMES = 64  # about 400 MB of 1080p frames

PARAMS = [
    Param("source", "sim", "device, video, folder or sim", read_only=True),
    Param("path", "", "device index or path, video file or pipeline, or image folder", read_only=True),
    Param("loop", False, "folder/video: start again at the end", read_only=True),
    Param("rate_hz", 30.0, "frame rate for folder and sim sources (Hz)", 0.1, 240.0, read_only=True),
    Param("camera_info_file", "", "camera_info YAML (empty: the paper's calibration)", read_only=True),
    Param("sim_scale", 0.5, "sim source: render at this share of the camera resolution", 0.1, 1.0, read_only=True),
    Param("sim_reflection", False, "sim source: the surface reflects the ring", read_only=True),
    Param("reliable", True, "reliable image QoS (with the shared-memory profile) instead of best effort",
          read_only=True),
    Param("stall_timeout_s", 1.0, "no frame from the source this long is reported as a stall (s)", 0.1, 60.0),
]


class CameraIngestNode(Node):
    def __init__(self) -> None:
        super().__init__("camera_ingest")
        self.values = declare(self, PARAMS)
        info_file = self.values["camera_info_file"]
        base = CameraModel.from_yaml(info_file) if info_file else paper_camera()
        source = self.values["source"]
        self.camera = base.scaled(self.values["sim_scale"]) if source == "sim" else base
        reliability = ReliabilityPolicy.RELIABLE if self.values["reliable"] else ReliabilityPolicy.BEST_EFFORT
        qos = QoSProfile(depth=1, history=HistoryPolicy.KEEP_LAST, reliability=reliability)
        self.image_pub = self.create_publisher(Image, "camera/image_raw", qos)
        self.info_pub = self.create_publisher(CameraInfo, "camera/camera_info", 1)
        self.diag_pub = self.create_publisher(DiagnosticArray, "/diagnostics", 10)
        self.frames = 0
        self.frame_sinks: list[FrameSink] = []  # consumers in this process, called on the capture thread
        self.problems = InputProblems(self)
        self.stalls = 0
        self._last_frame = time.monotonic()
        self._stalled = False
        self._capture = None
        self._files: list[Path] = []
        self._decoded: dict[Path, np.ndarray] = {}
        self._index = 0
        self._pose: VehiclePose | None = None
        if source == "sim":
            self.world = PoolWorld(reflection=self.values["sim_reflection"])
            self.create_subscription(PoseStamped, "sim/vehicle_pose", self._on_pose, 1)
        elif source == "folder":
            folder = Path(self.values["path"])
            if not folder.is_dir():
                raise ConfigError(f"source folder {folder} {'is a file' if folder.exists() else 'does not exist'}")
            self._files = sorted(p for p in folder.iterdir() if p.suffix.lower() in IMAGE_SUFFIXES)
            if not self._files:
                raise ConfigError(f"source folder {folder} holds no images ({', '.join(sorted(IMAGE_SUFFIXES))})")
        elif source in ("device", "video"):
            path = self.values["path"]
            self._capture = cv2.VideoCapture(int(path) if path.isdigit() else path)
            if not self._capture.isOpened():
                raise ConfigError(f"cannot open {source} {path!r}")
        else:
            raise ConfigError(f"source {source!r} must be device, video, folder or sim")
        self.create_timer(1.0, lambda: publish_diagnostics(self, self.diag_pub, self.diagnostics()))
        self.get_logger().info(f"source {source} {self.values['path']} -> {self.camera.width}x{self.camera.height}")
        period = 0.001 if source in ("device", "video") else 1.0 / self.values["rate_hz"]
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        if source == "sim":  # rendering stands in for the camera's own hardware: on the executor,
            self.create_timer(period, self._capture_once)  # between detections, never starving them
        else:
            self._thread = threading.Thread(target=self._capture_loop, args=(period,), name="capture", daemon=True)
            self._thread.start()

    def close(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=2.0)
        if self._capture is not None:
            self._capture.release()

    def _capture_loop(self, period_s: float) -> None:
        """Capture at ``period_s`` (a device or video paces itself): late ticks are not made up
        in a burst, as a camera does not deliver the frames it missed."""
        due = time.monotonic()
        while not self._stop.is_set():
            due += period_s
            wait = due - time.monotonic()
            if wait > 0:
                self._stop.wait(wait)
            elif wait < -period_s:
                due = time.monotonic()
            try:
                self._capture_once()
            except Exception as exc:
                self.problems.report("capture", f"{type(exc).__name__}: {exc}")

    def _on_pose(self, msg: PoseStamped) -> None:
        self._pose = pose_to_vehicle(msg)

    def _next_frame(self) -> np.ndarray | None:
        source = self.values["source"]
        if source == "sim":
            if self._pose is None:
                return None
            image, _ = render(self.camera, self.world.scene_for(self._pose, seed=self.frames))
            return image
        if source == "folder":
            if self._index >= len(self._files):
                if not self.values["loop"]:
                    return None
                self._index = 0
            path = self._files[self._index]
            self._index += 1
            if path in self._decoded:
                return self._decoded[path]
            try:
                frame = read_image(path)
            except DockGuidanceError as exc:
                self.problems.report("image_file", str(exc))
                return None
            if self.values["loop"] and len(self._decoded) < MAX_CACHED_FRAMES:
                self._decoded[path] = frame  # a looping folder is decoded once, not at every pass
            return frame
        assert self._capture is not None
        ok, frame = self._capture.read()
        if not ok:
            if self.values["loop"] and source == "video":
                self._capture.set(cv2.CAP_PROP_POS_FRAMES, 0)
            return None
        return frame

    def _capture_once(self) -> None:
        frame = self._next_frame()
        now = time.monotonic()
        if frame is None:
            if not self._stalled and now - self._last_frame > self.values["stall_timeout_s"]:
                self._stalled = True
                self.stalls += 1
                self.get_logger().warn(f"no frame from the {self.values['source']} source for "
                                       f"{now - self._last_frame:.1f} s")
            return
        if self._stalled:
            self._stalled = False
            self.get_logger().info("frames again")
        self._last_frame = now
        if frame.shape[:2] != (self.camera.height, self.camera.width):
            self.problems.report("frame_size", f"frame is {frame.shape[1]}x{frame.shape[0]}, camera_info says "
                                 f"{self.camera.width}x{self.camera.height}")
            return
        stamp = seconds_stamp(time.time())
        self.frames += 1
        for sink in self.frame_sinks:
            sink(frame, stamp, self.camera.frame_id, self.frames)
        self.info_pub.publish(camera_to_info(self.camera, stamp))
        if self.image_pub.get_subscription_count() > 0:
            self.image_pub.publish(array_to_image(frame, stamp, self.camera.frame_id))

    def diagnostics(self) -> DiagnosticStatus:
        """Frames and stalls; WARN while stalled or refusing input."""
        level, message = (DiagnosticStatus.WARN, "stalled") if self._stalled else (DiagnosticStatus.OK, "streaming")
        if self.problems.recent():
            level, message = DiagnosticStatus.WARN, f"{message}; refusing input: {self.problems.last_reason}"
        return diagnostic_status("camera_ingest", self.values["source"], level, message,
                                   {"frames": self.frames, "stalls": self.stalls, **self.problems.values()})


def main(args: list[str] | None = None) -> int:
    return run_node(CameraIngestNode, args)


if __name__ == "__main__":
    raise SystemExit(main())
