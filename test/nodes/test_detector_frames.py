"""The detector node works on the newest frame and says how many it skipped; tracking is on
by default and can be switched off or given another window."""

from __future__ import annotations

from diagnostic_msgs.msg import DiagnosticStatus
from node_harness import beside, detector_with_camera, spin_until  # test/nodes is on the path (pytest's prepend import)
from rclpy.parameter import Parameter
from std_msgs.msg import Bool

from auv_dock_guidance.geometry.camera import paper_camera
from auv_dock_guidance.nodes.conversions import array_to_image, camera_to_info, seconds_stamp
from auv_dock_guidance.nodes.detector import DetectorNode
from auv_dock_guidance.sim.scene import SceneSpec, render

CAMERA = paper_camera().scaled(0.25)


def _frame():
    return render(CAMERA, SceneSpec(marker_center_m=(0.2, 0.1, 6.0), brightness=3.0, seed=1))[0]


def _values(status: DiagnosticStatus) -> dict[str, str]:
    return {kv.key: kv.value for kv in status.values}


def test_frames_that_came_while_one_was_processed_are_skipped_and_reported(ros):
    detector, harness, executor, images, infos, detected = detector_with_camera()
    frame = _frame()
    try:
        spin_until(executor, lambda: images.get_subscription_count() > 0 and infos.get_subscription_count() > 0)
        infos.publish(camera_to_info(CAMERA, seconds_stamp(1.0)))
        spin_until(executor, lambda: detector.detector.camera is not None)
        images.publish(array_to_image(frame, seconds_stamp(10.0), CAMERA.frame_id))
        spin_until(executor, lambda: len(detected) == 1)
        for i in range(1, 4):  # three frames while the detector is busy: only the newest is processed
            images.publish(array_to_image(frame, seconds_stamp(10.0 + i / 30), CAMERA.frame_id))
        spin_until(executor, lambda: len(detected) == 2)
        status = detector.diagnostics()
    finally:
        harness.destroy_node()
        detector.destroy_node()
    assert detector.frames_skipped == 2 and detector.frames_processed == 2
    values = _values(status)
    assert values["frames_skipped"] == "2" and values["skipped_last_5s"] == "2"
    assert status.level == DiagnosticStatus.WARN and "2 frames skipped" in status.message


def test_frames_handed_over_in_process_are_taken_newest_first(ros):
    detector = DetectorNode(subscribe=False)
    detector.detector.camera = CAMERA
    harness, executor = beside(detector)
    detected: list[Bool] = []
    harness.create_subscription(Bool, "dock/detected", detected.append, 10)
    frame = _frame()
    try:
        detector.submit(frame, seconds_stamp(20.0), CAMERA.frame_id, 1)
        spin_until(executor, lambda: len(detected) == 1)
        for sequence in (2, 3, 4):
            detector.submit(frame, seconds_stamp(20.0 + sequence / 30), CAMERA.frame_id, sequence)
        spin_until(executor, lambda: len(detected) == 2)
    finally:
        harness.destroy_node()
        detector.destroy_node()
    assert detected[-1].data and detector.frames_processed == 2 and detector.frames_skipped == 2


def test_tracking_is_on_by_default_and_its_window_and_switch_are_parameters(ros):
    node = DetectorNode()
    try:
        assert node.detector.config.tracking and _values(node.diagnostics())["tracking"] == "on"
        assert node.set_parameters([Parameter("tracking", value=False),
                                    Parameter("track_window_radii", value=3.0)])[0].successful
        assert not node.detector.config.tracking and node.detector.config.track_window_radii == 3.0
        assert not node.set_parameters([Parameter("track_window_radii", value=0.1)])[0].successful
    finally:
        node.destroy_node()
