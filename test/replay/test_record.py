import time

import rclpy
from rosbags.highlevel import AnyReader
from std_msgs.msg import String

from auv_dock_guidance.nodes.common import TRANSITION_QOS
from auv_dock_guidance.recording import BagRecorder


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
