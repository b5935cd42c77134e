"""ArduSub over MAVLink, as an alternative main-controller link (BlueROV2-class vehicles).

Out: RC_CHANNELS_OVERRIDE with the normalized surge, yaw and pitch demands on ArduSub's
default channels (1 pitch, 4 yaw, 5 forward); ArduSub does its own thruster mixing, so
this path sends demands, not pulse widths. In: ATTITUDE (roll, pitch, yaw, rates) and
VFR_HUD (altitude, negative below the surface) become attitude and depth.
Requires pymavlink (`pip install pymavlink`), imported only when this link is chosen.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from auv_dock_guidance.errors import ConfigError

IGNORE = 65535  # RC override: leave this channel to the pilot/autopilot


@dataclass(frozen=True)
class ArduSubChannels:
    pitch: int = 1
    yaw: int = 4
    forward: int = 5
    span_us: int = 400  # full demand = neutral +- span
    neutral_us: int = 1500


@dataclass
class MavlinkState:
    roll: float = math.nan
    pitch: float = math.nan
    yaw: float = math.nan
    roll_rate: float = math.nan
    pitch_rate: float = math.nan
    yaw_rate: float = math.nan
    depth: float = math.nan
    attitude_updates: int = 0


@dataclass
class MavlinkCodec:
    target_system: int = 1
    target_component: int = 1
    channels: ArduSubChannels = field(default_factory=ArduSubChannels)

    def __post_init__(self) -> None:
        try:
            from pymavlink.dialects.v20 import ardupilotmega
        except ImportError as exc:  # pragma: no cover - depends on the installation
            raise ConfigError("link_type 'mavlink' needs pymavlink: pip install pymavlink") from exc
        self._dialect = ardupilotmega
        self._out = ardupilotmega.MAVLink(None, srcSystem=255, srcComponent=190)
        self._in = ardupilotmega.MAVLink(None)
        self._in.robust_parsing = True
        self.state = MavlinkState()

    def rc_override(self, surge: float, yaw: float, pitch: float) -> bytes:
        """One RC_CHANNELS_OVERRIDE frame; non-finite demands become neutral."""
        c = self.channels
        values = [IGNORE] * 8
        for channel, demand in ((c.pitch, pitch), (c.yaw, yaw), (c.forward, surge)):
            demand = 0.0 if not math.isfinite(demand) else max(-1.0, min(1.0, demand))
            values[channel - 1] = int(round(c.neutral_us + demand * c.span_us))
        msg = self._out.rc_channels_override_encode(self.target_system, self.target_component, *values)
        return msg.pack(self._out)

    def neutral(self) -> bytes:
        return self.rc_override(0.0, 0.0, 0.0)

    def heartbeat(self) -> bytes:
        d = self._dialect
        msg = self._out.heartbeat_encode(d.MAV_TYPE_GCS, d.MAV_AUTOPILOT_INVALID, 0, 0, 0)
        return msg.pack(self._out)

    def feed(self, data: bytes) -> MavlinkState:
        """Parse incoming bytes (garbage tolerated) into the navigation state."""
        for msg in self._in.parse_buffer(data) or []:
            kind = msg.get_type()
            if kind == "ATTITUDE":
                s = self.state
                s.roll, s.pitch, s.yaw = msg.roll, msg.pitch, msg.yaw
                s.roll_rate, s.pitch_rate, s.yaw_rate = msg.rollspeed, msg.pitchspeed, msg.yawspeed
                s.attitude_updates += 1
            elif kind == "VFR_HUD":
                self.state.depth = -float(msg.alt)
        return self.state
