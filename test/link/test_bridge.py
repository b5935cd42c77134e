import itertools
import math
import time

import serial

from auv_dock_guidance.link.bridge import LinkBridge
from auv_dock_guidance.link.protocol import StreamDecoder, TelemetryMsg, ThrusterCommandMsg, encode
from auv_dock_guidance.link.transport import WRITE_TIMEOUTS_LOST, SerialTransport
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


class RecordingTransport:
    """Stands in for the serial port: decodes what the bridge writes, stamped with the bridge's clock."""

    connected = True

    def __init__(self, clock) -> None:
        self.clock = clock
        self.sent: list[tuple[float, object]] = []
        self._decoder = StreamDecoder()

    def write(self, data: bytes) -> bool:
        self.sent += [(self.clock(), frame.message) for frame in self._decoder.feed(data)]
        return True

    def read(self) -> bytes:
        return b""


def test_failsafe_sends_neutral_at_the_first_tick_past_the_timeout_within_200_ms():
    tick_s = 0.02  # 50 Hz
    ticks = [0]
    clock = lambda: ticks[0] * tick_s  # noqa: E731
    transport = RecordingTransport(clock)
    bridge = LinkBridge(transport, clock=clock)  # the default timeout
    bridge.set_armed(True)
    for _ in range(10):
        bridge.command([1700, 1700, 1700, 1700])
        bridge.tick()
        ticks[0] += 1
    last_command = clock() - tick_s
    for _ in range(20):  # guidance has stopped
        bridge.tick()
        ticks[0] += 1
    after = [(t, m.pwm_us) for t, m in transport.sent if isinstance(m, ThrusterCommandMsg) and t > last_command]
    first_neutral = after[0][0]
    assert all(pwm == NEUTRAL for _, pwm in after)  # nothing but neutral once commands stop
    assert first_neutral - last_command > bridge.failsafe_timeout_s - 1e-9  # not before the timeout
    assert first_neutral - last_command <= bridge.failsafe_timeout_s + tick_s + 1e-9  # but at the first tick past it
    assert first_neutral - last_command <= 0.2  # the vehicle's deadline
    assert len(after) >= 5 and bridge.stats.failsafe_events == 1  # neutral again on every tick, one event
    bridge.command([1600, 1600, 1600, 1600])  # commands again: forwarded at once
    assert transport.sent[-1][1].pwm_us == (1600, 1600, 1600, 1600)


def test_telemetry_age_counts_from_the_last_valid_telemetry():
    now = [10.0]
    transport = RecordingTransport(lambda: now[0])
    bridge = LinkBridge(transport, clock=lambda: now[0])
    assert bridge.telemetry_age_s() == math.inf  # none yet
    valid = TelemetryMsg(1, 0.0, 0.0, 0.0, 2.0, 0.0, 0.0, 0.0, 0, NEUTRAL, 0)
    transport.read = lambda: encode(valid, 1)
    bridge.poll()
    now[0] += 0.3
    assert math.isclose(bridge.telemetry_age_s(), 0.3)
    transport.read = lambda: encode(TelemetryMsg(2, math.nan, 0.0, 0.0, 2.0, 0.0, 0.0, 0.0, 0, NEUTRAL, 0), 2)
    bridge.poll()  # a non-finite attitude is not telemetry to steer by: the age runs on
    now[0] += 0.2
    assert math.isclose(bridge.telemetry_age_s(), 0.5)


def test_bridge_finds_the_controller_again_after_the_cable_is_pulled_and_put_back():
    with MainControllerSim() as controller:
        bridge = LinkBridge(SerialTransport(controller.port))
        bridge.set_armed(True)
        _pump(bridge, 0.3, [1600, 1600, 1600, 1600])
        assert controller.applied == (1600, 1600, 1600, 1600)
        controller.unplug(0.6)
        _pump(bridge, 0.4, [1600, 1600, 1600, 1600])
        assert not controller.plugged and not bridge.transport.connected
        _pump(bridge, 3.0, [1650, 1650, 1650, 1650])  # back-off reaches at most 2 s
        assert controller.plugged
        assert bridge.transport.connected and bridge.transport.stats.opens == 2
        assert controller.applied == (1650, 1650, 1650, 1650)
        assert bridge.telemetry_time is not None and time.monotonic() - bridge.telemetry_time < 0.5
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
        self.timeouts = 0  # the next writes raise pyserial's write timeout

    def write(self, data):
        if not self.plugged:
            raise serial.SerialException("device disconnected")
        self.written += data
        if self.timeouts:
            self.timeouts -= 1
            raise serial.SerialTimeoutException("Write timeout")  # as pyserial does after a paused write

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
    gaps = [b - a for a, b in itertools.pairwise(attempts[1:])]
    assert all(later >= earlier for earlier, later in itertools.pairwise(gaps))  # back-off grows
    port.plugged = True
    clock[0] += 5.0
    assert transport.write(b"d") and transport.connected
    assert transport.stats.opens == 2 and port.written.endswith(b"d")


def test_a_lone_write_timeout_keeps_the_port_and_timeouts_in_a_row_drop_it():
    port = FlakyPort()
    transport = SerialTransport("/dev/ttyFAKE", opener=lambda name, **kw: port)
    assert transport.write(b"a")
    port.timeouts = 1  # the process was paused in write(): pyserial times out after writing
    transport.write(b"b")
    assert transport.connected and transport.write(b"c") and port.written == b"abc"
    port.timeouts = WRITE_TIMEOUTS_LOST  # the device takes nothing: gone, reopened with back-off
    for _ in range(WRITE_TIMEOUTS_LOST):
        transport.write(b"x")
    assert not transport.connected
    assert transport.stats.write_timeouts == 1 + WRITE_TIMEOUTS_LOST and transport.stats.write_errors == 1


def test_an_empty_port_is_not_read():
    """A read (or poll) of an empty terminal waits for the kernel's input worker: only bytes that wait are read."""
    class Port(FlakyPort):
        def __init__(self):
            super().__init__()
            self.pending, self.reads = b"", []

        @property
        def in_waiting(self):
            return len(self.pending)

        def read(self, n):
            self.reads.append(n)
            data, self.pending = self.pending[:n], self.pending[n:]
            return data

    port = Port()
    transport = SerialTransport("/dev/ttyFAKE", opener=lambda name, **kw: port)
    assert transport.read() == b"" and port.reads == []
    port.pending = b"abc"
    assert transport.read() == b"abc" and port.reads == [3]
    assert transport.read() == b"" and port.reads == [3]
