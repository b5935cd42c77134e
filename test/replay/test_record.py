import time

import rclpy
from std_msgs.msg import String
from rosbags.highlevel import AnyReader

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
    with AnyReader([tmp_path / "bag"]) as reader:
        messages = [reader.deserialize(raw, c.msgtype).data for c, _, raw in reader.messages()]
    assert messages and set(messages) == {"TRACK"}
