"""Vehicle and shore as two hosts: network namespaces joined by a veth pair (needs root).

The vehicle nodes run in one namespace, the shore monitor and a rogue publisher in the
other, with shared memory off on the shore side so everything crosses the link. The
monitor must see the run; nothing published from the shore may drive a thruster.
"""

from __future__ import annotations

import os
import subprocess
import sys
import time

import cv2
import pytest

from auv_dock_guidance.geometry.camera import paper_camera
from auv_dock_guidance.launcher import NodeGroup, ros_environment
from auv_dock_guidance.resources import config_file
from auv_dock_guidance.sim.main_controller import MainControllerSim
from auv_dock_guidance.sim.scene import SceneSpec, render

NEUTRAL = (1500, 1500, 1500, 1500)
ROGUE = """
import time, rclpy
from std_msgs.msg import UInt16MultiArray
rclpy.init()
node = rclpy.create_node("shore_rogue")
pub = node.create_publisher(UInt16MultiArray, "thrusters/command", 10)
end = time.monotonic() + {seconds}
while time.monotonic() < end:
    pub.publish(UInt16MultiArray(data=[1900, 1900, 1900, 1900]))
    rclpy.spin_once(node, timeout_sec=0.05)
"""


def _ip(*args: str) -> None:
    subprocess.run(["ip", *args], check=True, capture_output=True)


@pytest.fixture()
def two_hosts():
    if os.geteuid() != 0:
        pytest.fail("this test needs root for ip netns (CI runs as root)")
    suffix = str(os.getpid())[-5:]
    vehicle, shore = f"auvv{suffix}", f"auvs{suffix}"
    _ip("netns", "add", vehicle)
    _ip("netns", "add", shore)
    try:
        _ip("link", "add", f"vv{suffix}", "type", "veth", "peer", "name", f"vs{suffix}")
        _ip("link", "set", f"vv{suffix}", "netns", vehicle)
        _ip("link", "set", f"vs{suffix}", "netns", shore)
        for ns, dev, address in ((vehicle, f"vv{suffix}", "10.231.7.1/24"), (shore, f"vs{suffix}", "10.231.7.2/24")):
            _ip("-n", ns, "addr", "add", address, "dev", dev)
            _ip("-n", ns, "link", "set", dev, "up", "multicast", "on")
            _ip("-n", ns, "link", "set", "lo", "up")
            _ip("-n", ns, "route", "add", "224.0.0.0/4", "dev", dev)
        yield vehicle, shore
    finally:
        subprocess.run(["ip", "netns", "del", vehicle], capture_output=True)
        subprocess.run(["ip", "netns", "del", shore], capture_output=True)


def test_shore_sees_the_run_and_cannot_drive_the_thrusters(two_hosts, domain_id, tmp_path):
    vehicle, shore = two_hosts
    frames = tmp_path / "frames"
    frames.mkdir()
    for i in range(4):
        image, _ = render(paper_camera(), SceneSpec(marker_center_m=(0.5, 0.3, 8.0), seed=i))
        cv2.imwrite(str(frames / f"f{i}.png"), image)
    controller = MainControllerSim().start()
    env = ros_environment(domain_id=domain_id, localhost_only=False)
    env.pop("ROS_AUTOMATIC_DISCOVERY_RANGE", None)
    group = NodeGroup(["camera_ingest", "detector", "guidance", "serial_bridge"],
                      overrides={"camera_ingest": {"source": "folder", "path": str(frames), "loop": True,
                                                   "rate_hz": 10.0},
                                 "serial_bridge": {"port": controller.port, "arm_on_start": True}},
                      env=env, log_dir=tmp_path / "logs", prefix=["ip", "netns", "exec", vehicle])
    shore_env = dict(env, FASTRTPS_DEFAULT_PROFILES_FILE=str(config_file("fastdds_udp_only.xml")))
    group.start()
    try:
        time.sleep(8.0)  # the vehicle tracks the dock before the shore connects
        driving_before = [r for r in controller.records() if r.pwm_us != NEUTRAL]
        monitor = subprocess.run(["ip", "netns", "exec", shore, sys.executable, "-m", "auv_dock_guidance.cli.main",
                                  "monitor", "--once", "6"], env=shore_env, capture_output=True, text=True,
                                 timeout=90)
        rogue = subprocess.run(["ip", "netns", "exec", shore, sys.executable, "-c", ROGUE.format(seconds=8)],
                               env=shore_env, capture_output=True, text=True, timeout=90)
        time.sleep(1.0)
    finally:
        codes = group.stop()
        controller.stop()
    logs = {p.name: p.read_text() for p in (tmp_path / "logs").iterdir()}
    assert driving_before, f"the vehicle never drove; logs: {logs}"
    assert monitor.returncode == 0, monitor.stderr
    assert "TRACK" in monitor.stdout and "live" in monitor.stdout, monitor.stdout
    assert rogue.returncode == 0, rogue.stderr
    shore_command = (1900, 1900, 1900, 1900)
    assert all(r.pwm_us != shore_command for r in controller.records()), "a shore command drove the thrusters"
    assert "foreign" in logs["serial_bridge.log"], logs["serial_bridge.log"]
    assert all(code == 0 for code in codes.values()), (codes, logs)
