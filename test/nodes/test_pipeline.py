"""The four real nodes as separate processes: camera_ingest (folder) -> detector -> guidance
-> serial_bridge -> simulated main controller on a pseudo-terminal; and the dock as ROS sees it."""

from __future__ import annotations

import subprocess
import sys
import time

import cv2
import numpy as np
import pytest
import rclpy
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import PointStamped, PoseWithCovarianceStamped
from sensor_msgs.msg import CompressedImage
from std_msgs.msg import String
from visualization_msgs.msg import Marker

from auv_dock_guidance.geometry.camera import paper_camera
from auv_dock_guidance.launcher import NodeGroup, ros_environment
from auv_dock_guidance.sim.main_controller import MainControllerSim, VehicleState
from auv_dock_guidance.sim.scene import SceneSpec, render

PU, SU, PL, SL = range(4)
NEUTRAL = (1500, 1500, 1500, 1500)
EXPECTED_DIAGNOSTICS = {"auv_dock_guidance: detector", "auv_dock_guidance: serial_bridge",
                        "auv_dock_guidance: camera_ingest"}


@pytest.fixture(scope="module")
def frames(tmp_path_factory):
    folder = tmp_path_factory.mktemp("frames")
    camera = paper_camera()
    for i in range(6):  # the dock right of and below the image centre
        image, _ = render(camera, SceneSpec(marker_center_m=(1.0, 0.6, 8.0), seed=i))
        cv2.imwrite(str(folder / f"frame_{i:02d}.png"), image)
    return folder


class HeldStill:
    """The navigation of a vehicle that does not move, as the still frames show it: a vehicle
    that turned while the dock stayed put in the image would tell guidance a world that cannot be."""

    def step(self, pwm_us: tuple[int, int, int, int], dt: float) -> VehicleState:
        return VehicleState()


def test_commands_reach_the_controller_and_follow_the_marker(frames, domain_id, tmp_path):
    controller = MainControllerSim(vehicle=HeldStill()).start()
    group = NodeGroup(
        ["camera_ingest", "detector", "guidance", "serial_bridge"],
        overrides={
            "camera_ingest": {"source": "folder", "path": str(frames), "loop": True, "rate_hz": 10.0},
            "serial_bridge": {"port": controller.port, "arm_on_start": True},
        },
        env=ros_environment(domain_id=domain_id),
        log_dir=tmp_path / "logs",
    )
    rclpy.init(domain_id=domain_id)
    node = rclpy.create_node("pipeline_test_listener")
    seen: dict[str, list] = {"debug": [], "diagnostics": [], "state": [], "target": []}
    node.create_subscription(CompressedImage, "dock/debug_image/compressed", seen["debug"].append, 1)
    node.create_subscription(DiagnosticArray, "/diagnostics", seen["diagnostics"].append, 10)
    node.create_subscription(String, "guidance/state", seen["state"].append, 10)
    node.create_subscription(PointStamped, "dock/target", seen["target"].append, 10)
    group.start()
    try:
        deadline = time.monotonic() + 40.0
        while time.monotonic() < deadline:
            rclpy.spin_once(node, timeout_sec=0.1)
            tracking = [s for s in seen["state"] if s.data == "TRACK"]
            if tracking and seen["debug"] and len(seen["target"]) > 5 and _driving(controller) \
                    and _diagnostic_names(seen) >= EXPECTED_DIAGNOSTICS:
                break
        assert not group.exited(), f"a node died: {group.exited()}"
        monitor = subprocess.run([sys.executable, "-m", "auv_dock_guidance.cli.main", "monitor", "--once", "10"],
                                 env=group.env, capture_output=True, text=True, timeout=60)
    finally:
        node.destroy_node()
        rclpy.try_shutdown()
        codes = group.stop()
        controller.stop()
    logs = {p.name: p.read_text() for p in (tmp_path / "logs").iterdir()}
    driving = _driving(controller)
    assert driving, f"no thrust reached the controller; logs: {logs}"
    thrust = [(p - 1500) / 400 for p in driving[-1].pwm_us]
    assert thrust[PU] + thrust[PL] > thrust[SU] + thrust[SL], "marker right: should yaw right"
    assert thrust[PU] + thrust[SU] > thrust[PL] + thrust[SL], "marker below: should pitch down"
    assert any(s.data == "TRACK" for s in seen["state"])
    assert seen["target"][-1].point.x > 0 and seen["target"][-1].point.y > 0
    assert bytes(seen["debug"][-1].data[:2]) == b"\xff\xd8"  # a JPEG
    assert _diagnostic_names(seen) >= EXPECTED_DIAGNOSTICS
    assert all(code == 0 for code in codes.values()), f"unclean shutdown {codes}; logs: {logs}"
    assert controller.applied == NEUTRAL  # the bridge leaves the thrusters neutral on shutdown
    assert monitor.returncode == 0, monitor.stderr
    assert "TRACK" in monitor.stdout and "live" in monitor.stdout, monitor.stdout  # the shore monitor saw the run


def _driving(controller: MainControllerSim) -> list:
    return [r for r in controller.records() if r.armed and r.pwm_us != NEUTRAL]


def _diagnostic_names(seen: dict) -> set[str]:
    return {status.name for array in seen["diagnostics"] for status in array.status}


FAR_M, NEAR_M = (1.0, 0.6, 8.0), (0.5, 0.3, 4.0)  # one bearing, right of and below the image centre


@pytest.fixture(scope="module")
def far_near_gone(tmp_path_factory):
    folder = tmp_path_factory.mktemp("far_near_gone")
    camera = paper_camera()
    # The dock far, near, then out of view; each held a few frames, as in a real approach (the
    # first frame after a jump is segmented with the threshold of the last size, and is rougher).
    for i, centre in enumerate([FAR_M] * 5 + [NEAR_M] * 5 + [None]):
        image, _ = render(camera, SceneSpec(marker_center_m=centre, seed=i % 5))
        cv2.imwrite(str(folder / f"frame_{i:02d}.png"), image)
    return folder


def test_dock_pose_and_marker_follow_the_dock(far_near_gone, domain_id, tmp_path):
    """dock/pose follows the marker's side and distance, with a covariance that is positive
    definite and larger far away; dock/marker draws the ring at its true radius where the
    dock is, and is cleared when the dock leaves the view."""
    group = NodeGroup(
        ["vision_pipeline"],
        overrides={"camera_ingest": {"source": "folder", "path": str(far_near_gone), "loop": True, "rate_hz": 10.0},
                   "detector": {"dock_marker_rate_hz": 30.0}},  # a marker for every frame
        env=ros_environment(domain_id=domain_id), log_dir=tmp_path / "logs",
    )
    rclpy.init(domain_id=domain_id)
    node = rclpy.create_node("dock_pose_listener")
    poses: list[PoseWithCovarianceStamped] = []
    markers: list[Marker] = []
    node.create_subscription(PoseWithCovarianceStamped, "dock/pose", poses.append, 10)
    node.create_subscription(Marker, "dock/marker", markers.append, 10)
    group.start()
    try:
        deadline = time.monotonic() + 40.0
        while time.monotonic() < deadline and not (_both_ranges(poses) and _cleared(markers)):
            rclpy.spin_once(node, timeout_sec=0.1)
        assert not group.exited(), f"a node died: {group.exited()}"
    finally:
        node.destroy_node()
        rclpy.try_shutdown()
        codes = group.stop()
    assert _both_ranges(poses), f"dock/pose at both distances: {[m.pose.pose.position.z for m in poses]}"
    variance = {"near": [], "far": []}
    for msg in poses:
        p = msg.pose.pose.position
        truth = NEAR_M if p.z < 6.0 else FAR_M
        assert np.allclose((p.x, p.y, p.z), truth, rtol=0.05, atol=0.02), f"{p} vs {truth}"
        cov = np.array(msg.pose.covariance).reshape(6, 6)
        assert np.allclose(cov, cov.T) and np.linalg.eigvalsh(cov).min() > 0
        variance["near" if truth is NEAR_M else "far"].append(cov[2, 2])
        assert msg.header.frame_id == "camera_optical_frame"
    assert np.median(variance["far"]) > 2 * np.median(variance["near"]), "the range's variance grows with the range"
    ring = [m for m in markers if m.action == Marker.ADD and m.type == Marker.LINE_STRIP]
    assert ring and any(m.action == Marker.ADD and m.type == Marker.ARROW for m in markers)
    assert np.allclose([np.hypot(q.y, q.z) for q in ring[-1].points], 0.35)
    assert {round(m.pose.position.z) for m in ring} >= {4, 8}, "the ring drawn where the dock is"
    assert _cleared(markers), "no DELETE when the dock left the view"
    assert all(code == 0 for code in codes.values()), codes


def _both_ranges(poses: list, each: int = 4) -> bool:
    near = sum(msg.pose.pose.position.z < 6.0 for msg in poses)
    return near >= each and len(poses) - near >= each


def _cleared(markers: list) -> bool:
    return any(m.action == Marker.DELETE for m in markers)
