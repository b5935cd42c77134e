"""Bad input at each node's boundary: refused with a log line and a diagnostic, and the node keeps working.

The nodes run in this process on one executor with a harness node that publishes what a
broken camera, navigation or main controller would send, over real topics.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable

import numpy as np
import pytest
import rclpy
from diagnostic_msgs.msg import DiagnosticStatus
from geometry_msgs.msg import PointStamped
from node_harness import beside, detector_with_camera, spin_until  # test/nodes is on the path (pytest's prepend import)
from sensor_msgs.msg import Image, Imu
from std_msgs.msg import Float64, UInt16MultiArray

from auv_dock_guidance.geometry.camera import paper_camera
from auv_dock_guidance.link.protocol import TelemetryMsg, encode
from auv_dock_guidance.nodes.conversions import array_to_image, camera_to_info, seconds_stamp
from auv_dock_guidance.nodes.guidance import GuidanceNode
from auv_dock_guidance.nodes.serial_bridge import SerialBridgeNode
from auv_dock_guidance.sim.main_controller import MainControllerSim
from auv_dock_guidance.sim.scene import SceneSpec, render


def test_detector_refuses_bad_frames_and_camera_info_and_keeps_detecting(ros, capfd):
    detector, harness, executor, images, infos, detected = detector_with_camera()
    camera = paper_camera().scaled(0.25)
    frame, _ = render(camera, SceneSpec(marker_center_m=(0.2, 0.1, 6.0), brightness=3.0, seed=1))
    problems = detector.problems.counts
    try:
        spin_until(executor, lambda: images.get_subscription_count() > 0 and infos.get_subscription_count() > 0)
        nan_info = camera_to_info(camera, seconds_stamp(1.0))
        nan_info.k[0] = math.nan
        infos.publish(nan_info)
        spin_until(executor, lambda: problems["camera_info"] == 1)
        infos.publish(camera_to_info(camera, seconds_stamp(1.0)))
        spin_until(executor, lambda: detector.detector.camera is not None)

        def send(msg: Image, done: Callable[[], bool]) -> None:
            images.publish(msg)
            spin_until(executor, done)

        def good(stamp_s: float) -> Image:
            return array_to_image(frame, seconds_stamp(stamp_s), camera.frame_id)

        wrong_encoding, bad_step, truncated = good(10.0), good(10.1), good(10.2)
        wrong_encoding.encoding = "32FC1"
        bad_step.step = camera.width  # a colour image claiming one byte per pixel
        truncated.data = truncated.data[: len(truncated.data) // 2]
        wrong_size = array_to_image(np.zeros((200, 200, 3), np.uint8), seconds_stamp(10.3),
                                    camera.frame_id)  # not a resize of the calibrated 480x270
        for number, msg in enumerate((wrong_encoding, bad_step, truncated, wrong_size), start=1):
            send(msg, lambda n=number: problems["frame"] == n)
        send(good(11.0), lambda: len(detected) == 1)
        send(good(11.0), lambda: problems["frame_stamp"] == 1)  # the same frame again
        send(good(10.9), lambda: problems["frame_stamp"] == 2)  # an older one, late
        send(good(11.1), lambda: len(detected) == 2)
        status = detector.diagnostics()
    finally:
        harness.destroy_node()
        detector.destroy_node()
    assert [d.data for d in detected] == [True, True]  # good frames before and after are detected
    assert dict(problems) == {"camera_info": 1, "frame": 4, "frame_stamp": 2}
    assert status.level == DiagnosticStatus.WARN and "refusing input: frame_stamp" in status.message
    assert "older than the previous one" in status.message  # the latest reason, while the log is throttled
    values = {kv.key: kv.value for kv in status.values}
    assert values["rejected_frame"] == "4" and values["rejected_camera_info"] == "1"
    log = capfd.readouterr().err
    for expected in ("camera_info: fx nan", "encoding '32FC1' is not supported", "frame_stamp: repeated stamp"):
        assert expected in log  # one line per kind of problem


def test_guidance_refuses_bad_navigation_and_targets_and_keeps_commanding(ros, capfd):
    guidance = GuidanceNode()
    harness, executor = beside(guidance)
    imu_pub = harness.create_publisher(Imu, "vehicle/imu", 10)
    depth_pub = harness.create_publisher(Float64, "vehicle/depth", 10)
    target_pub = harness.create_publisher(PointStamped, "dock/target", 10)
    commands: list[UInt16MultiArray] = []
    harness.create_subscription(UInt16MultiArray, "thrusters/command", commands.append, 10)
    problems = guidance.problems.counts

    def imu(stamp_s: float, w: float = 1.0) -> Imu:
        msg = Imu()
        msg.header.stamp = seconds_stamp(stamp_s)
        msg.orientation.w = w
        return msg

    def target(stamp_s: float, z: float) -> PointStamped:
        msg = PointStamped()
        msg.header.stamp = seconds_stamp(stamp_s)
        msg.point.x, msg.point.y, msg.point.z = 0.3, 0.1, z
        return msg

    try:
        spin_until(executor, lambda: imu_pub.get_subscription_count() > 0 and target_pub.get_subscription_count() > 0)
        now = time.time()
        imu_pub.publish(imu(now, w=math.nan))
        spin_until(executor, lambda: problems["imu"] == 1)
        imu_pub.publish(imu(now))
        spin_until(executor, lambda: guidance._attitude is not None)
        imu_pub.publish(imu(now))  # repeated
        spin_until(executor, lambda: problems["imu_stamp"] == 1)
        depth_pub.publish(Float64(data=math.inf))
        spin_until(executor, lambda: problems["depth"] == 1)
        target_pub.publish(target(time.time(), math.nan))
        spin_until(executor, lambda: problems["target"] == 1)
        target_pub.publish(target(time.time() - 30.0, 8.0))  # a detection from long ago
        spin_until(executor, lambda: problems["target"] == 2)
        sent = len(commands)
        spin_until(executor, lambda: len(commands) > sent + 5)  # still commanding (neutral, in SEARCH)
        status = guidance.diagnostics()
    finally:
        harness.destroy_node()
        guidance.destroy_node()
    assert dict(problems) == {"imu": 1, "imu_stamp": 1, "depth": 1, "target": 2}
    assert guidance.guidance.state.value == "SEARCH"
    assert all(tuple(c.data) == (1500, 1500, 1500, 1500) for c in commands)
    assert status.level == DiagnosticStatus.WARN and "refusing input: target" in status.message
    assert "s ago (limit 0.5 s either way)" in status.message
    log = capfd.readouterr().err
    for expected in ("imu: orientation (0.0, 0.0, 0.0, nan) is not a finite rotation", "imu_stamp: repeated stamp",
                     "depth: depth inf", "target: not a finite position"):
        assert expected in log


@pytest.fixture()
def controller():
    with MainControllerSim() as sim:
        yield sim


def test_bridge_refuses_line_garbage_and_bad_telemetry_and_keeps_the_link(controller, domain_id, capfd):
    rclpy.init(domain_id=domain_id, args=["--ros-args", "-p", f"serial_bridge:port:={controller.port}"])
    bridge = SerialBridgeNode()
    harness, executor = beside(bridge, "guidance")  # the trusted publisher's name: its commands are only checked
    imu: list[Imu] = []
    harness.create_subscription(Imu, "vehicle/imu", imu.append, 50)
    commands = harness.create_publisher(UInt16MultiArray, "thrusters/command", 10)
    problems = bridge.problems.counts
    nan_telemetry = TelemetryMsg(1, math.nan, 0.0, 0.0, 2.0, 0.0, 0.0, 0.0, 0, (1500, 1500, 1500, 1500), 0)
    try:
        spin_until(executor, lambda: len(imu) > 5)
        controller.inject(np.random.default_rng(3).integers(0, 256, 3000, dtype=np.uint8).tobytes())
        controller.inject(encode(nan_telemetry, 7))
        spin_until(executor, lambda: problems["serial_bytes"] >= 1 and problems["telemetry"] == 1)
        spin_until(executor, lambda: commands.get_subscription_count() > 0)
        commands.publish(UInt16MultiArray(data=[1600, 1600, 1600]))
        spin_until(executor, lambda: problems["command"] == 1)
        received = len(imu)
        spin_until(executor, lambda: len(imu) > received + 10)  # telemetry still flows
        status = bridge.diagnostics()
    finally:
        harness.destroy_node()
        bridge.close()
        bridge.destroy_node()
        rclpy.try_shutdown()
    assert all(math.isfinite(m.orientation.x) and math.isfinite(m.orientation.w) for m in imu)
    assert bridge.bridge.decoder.stats.bytes_dropped > 0
    log = capfd.readouterr().err
    for expected in ("serial_bytes: garbage on", "telemetry: non-finite attitude",
                     "command: thruster command with 3 values"):
        assert expected in log
    assert status.level == DiagnosticStatus.WARN and "refusing input: command" in status.message
