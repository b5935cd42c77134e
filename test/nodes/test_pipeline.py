"""The four real nodes as separate processes: camera_ingest (folder) -> detector -> guidance
-> serial_bridge -> simulated main controller on a pseudo-terminal."""

from __future__ import annotations

import subprocess
import sys
import time

import cv2
import pytest
import rclpy
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import PointStamped
from sensor_msgs.msg import CompressedImage
from std_msgs.msg import String

from auv_dock_guidance.geometry.camera import paper_camera
from auv_dock_guidance.launcher import NodeGroup, ros_environment
from auv_dock_guidance.sim.main_controller import MainControllerSim
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


def test_commands_reach_the_controller_and_follow_the_marker(frames, domain_id, tmp_path):
    controller = MainControllerSim().start()
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
        monitor = subprocess.run([sys.executable, "-m", "auv_dock_guidance.cli.main", "monitor", "--once", "3"],
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
