"""The four nodes as processes against a simulated vehicle and main controller: what the demo and soak run.

This process publishes the simulated vehicle's pose on ``sim/vehicle_pose`` for
camera_ingest to render from; the vehicle dynamics behind the main-controller simulator on
a pseudo-terminal run in a child process (sim.controller_process), as a main controller
runs on its own computer. Needs rclpy (imported here, never by the core).
"""

from __future__ import annotations

import time
from pathlib import Path

import rclpy
from geometry_msgs.msg import PoseStamped
from rclpy.signals import SignalHandlerOptions
from std_srvs.srv import Trigger

from auv_dock_guidance.geometry.mounting import CameraMounting
from auv_dock_guidance.geometry.rotations import rep103_quaternion
from auv_dock_guidance.launcher import VISION_COMBINED, NodeGroup, private_domain_id, ros_environment
from auv_dock_guidance.nodes.common import destroy_and_shut_down
from auv_dock_guidance.nodes.conversions import seconds_stamp, vehicle_to_pose
from auv_dock_guidance.recording import BagRecorder, FrameTransform
from auv_dock_guidance.sim.controller_process import ControllerProcess
from auv_dock_guidance.sim.world import PoolWorld, VehiclePose

WORLD_FRAME = "pool"  # the simulated pool (REP 103: x along the pool towards the dock, y left, z up)


class SimulatedSystem:
    """Its owner handles the stop signals (launcher.stop_on_signals): rclpy installs none here."""

    def __init__(self, world: PoolWorld, start: VehiclePose, log_dir: Path, seed: int = 7,
                 domain_id: int | None = None) -> None:
        self.world = world
        self.controller = ControllerProcess(start, seed)
        self.domain = domain_id if domain_id is not None else private_domain_id()
        self.group = NodeGroup(
            VISION_COMBINED,
            overrides={
                "camera_ingest": {"source": "sim", "sim_reflection": world.reflection},
                "detector": {"marker_led_count": world.scene.led_count},  # the simulated dock, described
                "serial_bridge": {"port": self.controller.port, "arm_on_start": True},
                "guidance": {"side_room_m": world.side_room_m() if world.walls else 0.0},
            },
            env=ros_environment(domain_id=self.domain),
            log_dir=log_dir,
        )
        rclpy.init(domain_id=self.domain, signal_handler_options=SignalHandlerOptions.NO)
        self.node = rclpy.create_node("simulator")
        publisher = self.node.create_publisher(PoseStamped, "sim/vehicle_pose", 1)
        self.node.create_timer(
            1 / 30, lambda: publisher.publish(vehicle_to_pose(self.controller.pose, seconds_stamp(time.time()))))
        self._reset_client = self.node.create_client(Trigger, "guidance/reset")

    def start(self) -> SimulatedSystem:
        self.controller.start()
        self.group.start()
        return self

    def spin(self, seconds: float) -> None:
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            rclpy.spin_once(self.node, timeout_sec=min(0.05, max(0.0, end - time.monotonic())))

    def reposition(self, pose: VehiclePose, settle_s: float = 0.5) -> None:
        """Put the vehicle at a new start, at rest, and re-arm guidance once the detections of frames
        taken before the jump have passed (``settle_s``). Re-armed at once, guidance confirmed the
        marker from those close-in detections, and its tracker then refused the far ones as farther
        than the vehicle could have moved, until the marker counted as lost (3 of 86 soaks)."""
        self.controller.reposition(pose)
        self.spin(settle_s)
        if self._reset_client.wait_for_service(timeout_sec=2.0):
            future = self._reset_client.call_async(Trigger.Request())
            end = time.monotonic() + 2.0
            while not future.done() and time.monotonic() < end:
                rclpy.spin_once(self.node, timeout_sec=0.05)

    def record_transforms(self, recorder: BagRecorder, rate_hz: float = 10.0) -> None:
        """The frames into the recorder's bag: base_link -> camera_optical_frame (the camera on
        the nose, as /tf_static) once, and pool -> base_link (the simulated vehicle, /tf) at
        ``rate_hz``, so a 3D panel shows the vehicle, its camera and the dock it saw."""
        mounting = CameraMounting(x_m=self.world.camera_offset_m)
        now = self.node.get_clock().now
        recorder.write_transforms([FrameTransform(mounting.parent_frame, mounting.optical_frame,
                                                  (mounting.x_m, mounting.y_m, mounting.z_m),
                                                  mounting.transform_quaternion())],
                                  now().nanoseconds, static=True)

        def vehicle() -> None:
            p = self.controller.pose
            recorder.write_transforms([FrameTransform(WORLD_FRAME, mounting.parent_frame, (p.x, p.y, p.z),
                                                      rep103_quaternion(p.roll, p.pitch, p.yaw))],
                                      now().nanoseconds)

        self.node.create_timer(1.0 / rate_hz, vehicle)

    def nose_past_dock(self) -> bool:
        return bool(self.world.camera_position(self.controller.pose)[0] >= self.world.dock_x_m)

    def stop(self) -> dict[str, int | None]:
        """The node processes first (the bridge leaves the thrusters neutral at the controller), then our own."""
        codes = self.group.stop()
        self.controller.stop()
        destroy_and_shut_down([self.node])
        return codes
