"""The guidance side of the link, and the owner of the failsafe.

* Commands are validated before they can reach the wire: a non-finite pulse width
  becomes neutral, anything else is clamped to [pwm_min, pwm_max].
* Disarmed, or with no fresh command for ``failsafe_timeout_s`` (default 150 ms), the
  bridge sends neutral on every tick instead; the first neutral goes out on the first
  tick after the timeout, so with 50 Hz ticks it is on the wire within 200 ms of the
  last command (the deadline the vehicle needs).
* Telemetry is decoded from the same stream; heartbeats go out once a second.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

from auv_dock_guidance.control.mixer import PwmConfig
from auv_dock_guidance.link.protocol import (
    ArmMsg,
    Frame,
    HeartbeatMsg,
    Message,
    Source,
    StreamDecoder,
    TelemetryMsg,
    ThrusterCommandMsg,
    encode,
)
from auv_dock_guidance.link.transport import SerialTransport


@dataclass
class BridgeStats:
    commands_sent: int = 0
    neutral_sent: int = 0
    failsafe_events: int = 0  # times the bridge fell back to neutral for a stale command
    rejected_values: int = 0  # pulse widths that were NaN or out of range
    frames_sent: int = 0


@dataclass
class LinkBridge:
    transport: SerialTransport
    pwm: PwmConfig = field(default_factory=PwmConfig)
    failsafe_timeout_s: float = 0.15
    heartbeat_period_s: float = 1.0
    clock: Callable[[], float] = time.monotonic

    def __post_init__(self) -> None:
        self.decoder = StreamDecoder()
        self.stats = BridgeStats()
        self.armed = False
        self.telemetry: TelemetryMsg | None = None
        self.telemetry_time: float | None = None
        self._seq = 0
        self._command: tuple[int, int, int, int] | None = None
        self._command_time = -math.inf
        self._in_failsafe = True
        self._last_heartbeat = -math.inf
        self._start = self.clock()
        self.last_command_seq = 0

    def validated(self, pwm_us: Sequence[float]) -> tuple[int, int, int, int]:
        """Pulse widths that are safe to send (NaN -> neutral, clamped to the limits)."""
        p = self.pwm
        out = []
        for value in list(pwm_us)[:4] + [math.nan] * (4 - min(4, len(pwm_us))):
            if not math.isfinite(value):
                self.stats.rejected_values += 1
                out.append(p.pwm_neutral_us)
                continue
            if not p.pwm_min_us <= value <= p.pwm_max_us:
                self.stats.rejected_values += 1
            out.append(int(round(min(p.pwm_max_us, max(p.pwm_min_us, value)))))
        return tuple(out)  # type: ignore[return-value]

    def set_armed(self, armed: bool) -> None:
        self.armed = armed
        self._send(ArmMsg(armed))
        if not armed:
            self._send_neutral()

    def command(self, pwm_us: Sequence[float]) -> None:
        """A new thruster command from guidance: validated and sent at once when armed."""
        self._command = self.validated(pwm_us)
        self._command_time = self.clock()
        if self.armed:
            self._in_failsafe = False
            self.last_command_seq = self._seq
            self._send(ThrusterCommandMsg(self._command, True))
            self.stats.commands_sent += 1
        else:
            self._send_neutral()

    def tick(self) -> list[Frame]:
        """Run the failsafe and heartbeat, read telemetry. Call at 50 Hz or faster."""
        now = self.clock()
        stale = now - self._command_time > self.failsafe_timeout_s
        if not self.armed or stale:
            if self.armed and stale and not self._in_failsafe:
                self.stats.failsafe_events += 1
            self._in_failsafe = True
            self._send_neutral()
        if now - self._last_heartbeat >= self.heartbeat_period_s:
            self._last_heartbeat = now
            self._send(HeartbeatMsg(Source.GUIDANCE, 1 if self.armed else 0, int((now - self._start) * 1000)))
        return self.poll()

    def poll(self) -> list[Frame]:
        frames = self.decoder.feed(self.transport.read())
        for frame in frames:
            if isinstance(frame.message, TelemetryMsg) and frame.message.is_finite():
                self.telemetry = frame.message
                self.telemetry_time = self.clock()
        return frames

    def telemetry_age_s(self) -> float:
        """Seconds since the last valid telemetry; infinite before the first."""
        return self.clock() - self.telemetry_time if self.telemetry_time is not None else math.inf

    @property
    def last_command_time(self) -> float:
        """Clock time of the newest command from guidance (-inf before the first)."""
        return self._command_time

    @property
    def in_failsafe(self) -> bool:
        return self._in_failsafe

    def _send_neutral(self) -> None:
        n = self.pwm.pwm_neutral_us
        self._send(ThrusterCommandMsg((n, n, n, n), False))
        self.stats.neutral_sent += 1

    def _send(self, message: Message) -> None:
        if self.transport.write(encode(message, self._seq)):
            self.stats.frames_sent += 1
        self._seq = (self._seq + 1) & 0xFF
