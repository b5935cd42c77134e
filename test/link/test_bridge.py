import math
import time

import serial

from auv_dock_guidance.link.bridge import LinkBridge
from auv_dock_guidance.link.transport import SerialTransport
from auv_dock_guidance.sim.main_controller import MainControllerSim

NEUTRAL = (1500, 1500, 1500, 1500)


def _pump(bridge: LinkBridge, seconds: float, command=None) -> None:
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        if command is not None:
            bridge.command(command)
        bridge.tick()
        time.sleep(0.01)


def test_commands_reach_the_controller_and_telemetry_comes_back():
    with MainControllerSim() as controller:
        bridge = LinkBridge(SerialTransport(controller.port))
        bridge.set_armed(True)
        _pump(bridge, 0.3, [1600, 1400, 1600, 1400])
        assert controller.applied == (1600, 1400, 1600, 1400)
        assert bridge.telemetry is not None and bridge.telemetry.applied_pwm_us == (1600, 1400, 1600, 1400)
        bridge.transport.close()


def test_failsafe_sends_neutral_soon_after_commands_stop():
    with MainControllerSim(watchdog_s=5.0) as controller:  # the controller's own watchdog stays out of it
        bridge = LinkBridge(SerialTransport(controller.port))
        bridge.set_armed(True)
        _pump(bridge, 0.3, [1700, 1700, 1700, 1700])
        last = bridge.last_command_time
        _pump(bridge, 0.6)
        neutral = [r for r in controller.records() if r.time_s > last and r.pwm_us == NEUTRAL]
        assert neutral, "no neutral command reached the controller"
        assert neutral[0].time_s - last < 0.4  # configured 0.2 s; generous bound for a loaded machine
        assert controller.applied == NEUTRAL
        assert bridge.stats.failsafe_events == 1
        bridge.transport.close()


def test_nan_and_out_of_range_pulses_never_reach_the_wire():
    with MainControllerSim() as controller:
        bridge = LinkBridge(SerialTransport(controller.port))
        bridge.set_armed(True)
        _pump(bridge, 0.2, [math.nan, 5000, -3, 1550])
        assert all(1100 <= p <= 1900 for r in controller.records() for p in r.pwm_us)
        assert controller.applied == (1500, 1900, 1100, 1550)
        assert bridge.stats.rejected_values > 0
        bridge.transport.close()


def test_disarmed_bridge_only_sends_neutral():
    with MainControllerSim() as controller:
        bridge = LinkBridge(SerialTransport(controller.port))
        _pump(bridge, 0.2, [1800, 1800, 1800, 1800])
        assert controller.records() and all(r.pwm_us == NEUTRAL for r in controller.records())
        bridge.transport.close()


class FlakyPort:
    """A serial port that can be unplugged."""

    def __init__(self):
        self.plugged = True
        self.written = b""

    def write(self, data):
        if not self.plugged:
            raise serial.SerialException("device disconnected")
        self.written += data

    @property
    def in_waiting(self):
        if not self.plugged:
            raise serial.SerialException("device disconnected")
        return 0

    def read(self, n):
        return b""

    def close(self):
        pass


def test_transport_reconnects_with_back_off_after_unplug():
    clock = [0.0]
    port = FlakyPort()
    attempts = []

    def opener(name, **kwargs):
        attempts.append(clock[0])
        if not port.plugged:
            raise serial.SerialException("no such device")
        return port

    transport = SerialTransport("/dev/ttyFAKE", clock=lambda: clock[0], opener=opener, backoff_initial_s=0.1)
    assert transport.write(b"a")
    port.plugged = False
    assert not transport.write(b"b")  # lost
    for _ in range(40):
        clock[0] += 0.05
        transport.write(b"c")
    gaps = [b - a for a, b in zip(attempts[1:], attempts[2:])]
    assert all(later >= earlier for earlier, later in zip(gaps, gaps[1:]))  # back-off grows
    port.plugged = True
    clock[0] += 5.0
    assert transport.write(b"d") and transport.connected
    assert transport.stats.opens == 2 and port.written.endswith(b"d")
