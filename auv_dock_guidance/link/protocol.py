"""The binary protocol between the guidance computer and the main controller (version 1).

Frame (little-endian)::

    0xA5 0x5A | version u8 | length u8 | msg_id u8 | seq u8 | payload[length] | crc16 u16

The CRC is CRC-16/CCITT-FALSE (poly 0x1021, init 0xFFFF) over version..payload. Each
message id has one fixed payload length; a frame with another length is rejected. The
sequence number counts per sender, modulo 256. See docs/serial_protocol.md.
"""

from __future__ import annotations

import math
import struct
from dataclasses import dataclass
from enum import IntEnum
from typing import ClassVar

START = b"\xa5\x5a"
VERSION = 1
HEADER = struct.Struct("<2sBBBB")  # start, version, length, msg_id, seq
CRC = struct.Struct("<H")
MAX_PAYLOAD = 64


class MsgId(IntEnum):
    THRUSTER_COMMAND = 0x01  # guidance -> controller
    HEARTBEAT = 0x02  # both ways
    ARM = 0x03  # guidance -> controller
    TELEMETRY = 0x10  # controller -> guidance


class Source(IntEnum):
    GUIDANCE = 1
    MAIN_CONTROLLER = 2


class Status(IntEnum):
    """Bits of Telemetry.status."""

    ARMED = 1 << 0
    DOCKED = 1 << 1
    FAILSAFE = 1 << 2  # the controller itself timed out on commands
    LEAK = 1 << 3


@dataclass(frozen=True)
class ThrusterCommandMsg:
    pwm_us: tuple[int, int, int, int]
    armed: bool

    _layout: ClassVar[struct.Struct] = struct.Struct("<4HB")

    def pack(self) -> bytes:
        return self._layout.pack(*self.pwm_us, 1 if self.armed else 0)

    @classmethod
    def unpack(cls, data: bytes) -> ThrusterCommandMsg:
        *pwm, flags = cls._layout.unpack(data)
        return cls(tuple(pwm), bool(flags & 1))


@dataclass(frozen=True)
class HeartbeatMsg:
    source: int
    state: int  # sender-defined state code
    uptime_ms: int

    _layout: ClassVar[struct.Struct] = struct.Struct("<BBI")

    def pack(self) -> bytes:
        return self._layout.pack(self.source, self.state, self.uptime_ms & 0xFFFFFFFF)

    @classmethod
    def unpack(cls, data: bytes) -> HeartbeatMsg:
        return cls(*cls._layout.unpack(data))


@dataclass(frozen=True)
class ArmMsg:
    arm: bool

    _layout: ClassVar[struct.Struct] = struct.Struct("<B")

    def pack(self) -> bytes:
        return self._layout.pack(1 if self.arm else 0)

    @classmethod
    def unpack(cls, data: bytes) -> ArmMsg:
        return cls(bool(cls._layout.unpack(data)[0]))


@dataclass(frozen=True)
class TelemetryMsg:
    """Navigation state: attitude (rad, aerospace convention), depth (m), body rates (rad/s)."""

    time_ms: int
    roll: float
    pitch: float
    yaw: float
    depth: float
    roll_rate: float
    pitch_rate: float
    yaw_rate: float
    status: int
    applied_pwm_us: tuple[int, int, int, int]  # what the controller drives right now
    last_command_seq: int

    _layout: ClassVar[struct.Struct] = struct.Struct("<I7fH4HB")

    def pack(self) -> bytes:
        return self._layout.pack(
            self.time_ms & 0xFFFFFFFF, self.roll, self.pitch, self.yaw, self.depth,
            self.roll_rate, self.pitch_rate, self.yaw_rate, self.status, *self.applied_pwm_us,
            self.last_command_seq & 0xFF,
        )

    @classmethod
    def unpack(cls, data: bytes) -> TelemetryMsg:
        v = cls._layout.unpack(data)
        return cls(v[0], v[1], v[2], v[3], v[4], v[5], v[6], v[7], v[8], (v[9], v[10], v[11], v[12]), v[13])

    def is_finite(self) -> bool:
        return all(math.isfinite(x) for x in (self.roll, self.pitch, self.yaw, self.depth,
                                              self.roll_rate, self.pitch_rate, self.yaw_rate))


Message = ThrusterCommandMsg | HeartbeatMsg | ArmMsg | TelemetryMsg
MESSAGE_TYPES: dict[MsgId, type[ThrusterCommandMsg] | type[HeartbeatMsg] | type[ArmMsg] | type[TelemetryMsg]] = {
    MsgId.THRUSTER_COMMAND: ThrusterCommandMsg,
    MsgId.HEARTBEAT: HeartbeatMsg,
    MsgId.ARM: ArmMsg,
    MsgId.TELEMETRY: TelemetryMsg,
}
PAYLOAD_LENGTH = {msg_id: cls._layout.size for msg_id, cls in MESSAGE_TYPES.items()}
MSG_ID_OF = {cls: msg_id for msg_id, cls in MESSAGE_TYPES.items()}


def crc16_ccitt(data: bytes, crc: int = 0xFFFF) -> int:
    """CRC-16/CCITT-FALSE."""
    for byte in data:
        crc ^= byte << 8
        for _ in range(8):
            crc = ((crc << 1) ^ 0x1021) & 0xFFFF if crc & 0x8000 else (crc << 1) & 0xFFFF
    return crc


def encode(message: Message, seq: int) -> bytes:
    """One complete frame."""
    msg_id = MSG_ID_OF[type(message)]
    payload = message.pack()
    header = HEADER.pack(START, VERSION, len(payload), msg_id, seq & 0xFF)
    return header + payload + CRC.pack(crc16_ccitt(header[2:] + payload))


@dataclass(frozen=True)
class Frame:
    seq: int
    message: Message


@dataclass
class DecoderStats:
    frames: int = 0
    crc_errors: int = 0
    length_errors: int = 0  # known id with the wrong payload length, or an oversized length
    unknown_ids: int = 0
    version_errors: int = 0
    bytes_dropped: int = 0  # bytes discarded while resynchronizing


class StreamDecoder:
    """Frames out of a byte stream that may hold garbage, torn frames and bit errors.

    After any bad frame it drops one byte and searches for the next start marker, so a
    valid frame right after garbage (even garbage that looks like a header) is found.
    The buffer never holds more than one maximal frame plus one read.
    """

    def __init__(self, max_buffer: int = 4096) -> None:
        self.stats = DecoderStats()
        self._buffer = bytearray()
        self._max_buffer = max_buffer

    def feed(self, data: bytes) -> list[Frame]:
        self._buffer += data
        frames: list[Frame] = []
        buf = self._buffer
        while True:
            start = buf.find(START)
            if start < 0:
                keep = 1 if buf.endswith(START[:1]) else 0
                self.stats.bytes_dropped += len(buf) - keep
                del buf[: len(buf) - keep]
                break
            if start:
                self.stats.bytes_dropped += start
                del buf[:start]
            if len(buf) < HEADER.size:
                break
            _, version, length, msg_id, seq = HEADER.unpack_from(buf)
            problem = self._header_problem(version, length, msg_id)
            if problem is not None:
                setattr(self.stats, problem, getattr(self.stats, problem) + 1)
                self._drop_one()
                continue
            total = HEADER.size + length + CRC.size
            if len(buf) < total:
                break
            body = bytes(buf[2 : HEADER.size + length])
            (crc,) = CRC.unpack_from(buf, HEADER.size + length)
            if crc != crc16_ccitt(body):
                self.stats.crc_errors += 1
                self._drop_one()
                continue
            payload = bytes(buf[HEADER.size : HEADER.size + length])
            frames.append(Frame(seq, MESSAGE_TYPES[MsgId(msg_id)].unpack(payload)))
            self.stats.frames += 1
            del buf[:total]
        if len(buf) > self._max_buffer:  # cannot happen with a valid header, but never grow
            self.stats.bytes_dropped += len(buf) - self._max_buffer
            del buf[: len(buf) - self._max_buffer]
        return frames

    def _header_problem(self, version: int, length: int, msg_id: int) -> str | None:
        if version != VERSION:
            return "version_errors"
        if msg_id not in PAYLOAD_LENGTH:
            return "unknown_ids"
        if length != PAYLOAD_LENGTH[MsgId(msg_id)]:
            return "length_errors"
        return None

    def _drop_one(self) -> None:
        self.stats.bytes_dropped += 1
        del self._buffer[:1]
