"""The simulated main controller in its own process: driven over its link, read through shared memory."""

import time
from pathlib import Path

import pytest

from auv_dock_guidance.link.bridge import LinkBridge
from auv_dock_guidance.link.transport import SerialTransport
from auv_dock_guidance.sim.controller_process import ControllerProcess
from auv_dock_guidance.sim.world import VehiclePose

FORWARD = [1700, 1700, 1700, 1700]


def _drive(bridge: LinkBridge, seconds: float) -> None:
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        bridge.command(FORWARD)
        bridge.tick()
        time.sleep(0.01)


def test_commands_move_the_vehicle_and_a_reposition_puts_it_back_at_rest(tmp_path: Path):
    start = VehiclePose(x=-10.0, y=1.0, z=-2.0, yaw=0.2)
    controller = ControllerProcess(start, seed=3, link=tmp_path / "main_controller").start()
    try:
        assert controller.pose.x == pytest.approx(start.x) and controller.pose.yaw == pytest.approx(start.yaw)
        bridge = LinkBridge(SerialTransport(controller.port))
        bridge.set_armed(True)
        _drive(bridge, 1.0)
        assert bridge.telemetry is not None  # telemetry from the child reaches us
        moved = controller.pose
        assert moved.x > start.x + 0.05, "forward thrust should move the vehicle forward"
        assert any(r.pwm_us == tuple(FORWARD) for r in controller.records())
        bridge.set_armed(False)  # thrusters neutral, so the vehicle stays where it is put
        deadline = time.monotonic() + 5.0
        while not (records := controller.records()) or records[-1].armed:
            assert time.monotonic() < deadline, "the disarm never reached the controller"
            time.sleep(0.01)
        controller.reposition(start)
        assert abs(controller.pose.x - start.x) < 0.05
        bridge.set_armed(True)
        controller.inject(b"\x00garbage\xff")  # noise on the line: the controller keeps running
        controller.pause_telemetry(0.1)
        _drive(bridge, 0.3)
        assert controller.pose.x > start.x
        bridge.transport.close()
    finally:
        controller.stop()
    assert not (tmp_path / "main_controller").exists(), "the link goes with the controller"
    with pytest.raises(RuntimeError, match="not running"):
        controller.records()


def test_a_link_that_cannot_be_made_is_reported_by_start(tmp_path: Path):
    controller = ControllerProcess(VehiclePose(0.0, 0.0, 0.0), seed=0, link=tmp_path / "missing" / "link")
    with pytest.raises(FileNotFoundError):
        controller.start()


def test_its_own_link_folder_goes_with_it_even_when_it_never_started():
    controller = ControllerProcess(VehiclePose(0.0, 0.0, 0.0), seed=0)
    folder = Path(controller.port).parent
    assert folder.is_dir()
    controller.stop()
    assert not folder.exists()


def test_a_child_that_cannot_be_spawned_leaves_its_own_error_and_stop_harmless(tmp_path: Path, monkeypatch):
    controller = ControllerProcess(VehiclePose(0.0, 0.0, 0.0), seed=0, link=tmp_path / "main_controller")

    def refuse(self: object) -> None:
        raise RuntimeError("cannot spawn here")

    monkeypatch.setattr(controller._context.Process, "start", refuse)
    with pytest.raises(RuntimeError, match="cannot spawn here"):
        controller.start()
    controller.stop()  # the caller's cleanup: nothing to end, no second error
