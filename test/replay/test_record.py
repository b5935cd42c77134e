import time

import rclpy
from rosbags.highlevel import AnyReader
from std_msgs.msg import String

from auv_dock_guidance.geometry.mounting import CameraMounting
from auv_dock_guidance.nodes.common import TRANSITION_QOS
from auv_dock_guidance.recording import BagRecorder, FrameTransform


def test_recorder_writes_live_messages_into_an_mcap_bag(tmp_path, domain_id):
    rclpy.init(domain_id=domain_id)
    try:
        node = rclpy.create_node("record_test")
        recorder = BagRecorder(node, tmp_path / "bag", {"guidance/state": "std_msgs/msg/String"})
        publisher = node.create_publisher(String, "guidance/state", 10)
        end = time.monotonic() + 3.0
        while time.monotonic() < end and recorder.counts["/guidance/state"] < 5:
            publisher.publish(String(data="TRACK"))
            rclpy.spin_once(node, timeout_sec=0.1)
        recorder.close()
        node.destroy_node()
    finally:
        rclpy.try_shutdown()
    messages = _recorded(tmp_path / "bag")
    assert messages and set(messages) == {"TRACK"}


def test_a_recorder_started_after_a_transition_still_records_it(tmp_path, domain_id):
    rclpy.init(domain_id=domain_id)
    try:
        guidance = rclpy.create_node("guidance")
        transitions = guidance.create_publisher(String, "guidance/transition", TRANSITION_QOS)
        transitions.publish(String(data="SEARCH -> TRACK: marker confirmed in 3 frames"))  # before anyone listens
        shore = rclpy.create_node("shore_recorder")
        recorder = BagRecorder(shore, tmp_path / "bag", {"guidance/transition": "std_msgs/msg/String"})
        end = time.monotonic() + 5.0
        while time.monotonic() < end and recorder.counts["/guidance/transition"] < 1:
            rclpy.spin_once(shore, timeout_sec=0.1)
        recorder.close()
        shore.destroy_node()
        guidance.destroy_node()
    finally:
        rclpy.try_shutdown()
    assert _recorded(tmp_path / "bag") == ["SEARCH -> TRACK: marker confirmed in 3 frames"]


def _recorded(bag) -> list[str]:
    """The data of every String message in the bag, in order."""
    with AnyReader([bag]) as reader:
        return [reader.deserialize(raw, c.msgtype).data for c, _, raw in reader.messages()]


def test_transforms_go_into_the_bag_as_tf_messages(tmp_path, domain_id):
    """/tf_static and /tf written without tf2_msgs installed (rosbags serializes them)."""
    mounting = CameraMounting()
    rclpy.init(domain_id=domain_id)
    try:
        node = rclpy.create_node("record_tf_test")
        recorder = BagRecorder(node, tmp_path / "bag", {})
        recorder.write_transforms([FrameTransform("base_link", "camera_optical_frame", (0.9, 0.0, 0.0),
                                                  mounting.transform_quaternion())], 1_000_000_000, static=True)
        for i in range(3):
            recorder.write_transforms([FrameTransform("pool", "base_link", (16.0 + i, 1.0, -1.5),
                                                      (0.0, 0.0, 0.0, 1.0))], 2_000_000_000 + i)
        recorder.close()
        node.destroy_node()
    finally:
        rclpy.try_shutdown()
    with AnyReader([tmp_path / "bag"]) as reader:
        seen = {}
        for connection, _, raw in reader.messages():
            message = reader.deserialize(raw, connection.msgtype)
            seen.setdefault(connection.topic, []).append(message.transforms[0])
    static = seen["/tf_static"][0]
    assert (static.header.frame_id, static.child_frame_id) == ("base_link", "camera_optical_frame")
    q = static.transform.rotation
    assert (q.x, q.y, q.z, q.w) == mounting.transform_quaternion()
    assert [t.transform.translation.x for t in seen["/tf"]] == [16.0, 17.0, 18.0]
