"""A simulated main controller on a pseudo-terminal: the vehicle's side of the serial link.

It speaks the protocol, applies the thruster commands it receives to a vehicle model,
sends telemetry at a fixed rate, and keeps its own watchdog (neutral and the FAILSAFE
status bit after ``watchdog_s`` without a command). Every command that arrives is logged
with its arrival time, so tests and `auv-dock link-selftest` can measure what the
vehicle really saw.

The bridge opens ``port``, a symbolic link to the pseudo-terminal, as a vehicle opens its
adapter's /dev/serial/by-id link: ``unplug()`` closes the terminal and removes the link,
and the re-plugged device comes back as a new terminal behind the same link.
"""

from __future__ import annotations

import array
import fcntl
import math
import os
import shutil
import tempfile
import termios
import threading
import time
import tty
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Protocol

from auv_dock_guidance.control.mixer import DEFAULT_ALLOCATION
from auv_dock_guidance.link.protocol import (
    ArmMsg,
    HeartbeatMsg,
    Status,
    StreamDecoder,
    TelemetryMsg,
    ThrusterCommandMsg,
    encode,
)

NEUTRAL = (1500, 1500, 1500, 1500)


@dataclass
class VehicleState:
    roll: float = 0.0
    pitch: float = 0.0
    yaw: float = 0.0
    depth: float = 2.0
    roll_rate: float = 0.0
    pitch_rate: float = 0.0
    yaw_rate: float = 0.0
    docked: bool = False


class VehicleModel(Protocol):
    def step(self, pwm_us: tuple[int, int, int, int], dt: float) -> VehicleState: ...


@dataclass
class SimpleVehicle:
    """First-order yaw and pitch response to the four stern thrusters; enough for link tests."""

    state: VehicleState = field(default_factory=VehicleState)
    yaw_gain: float = 1.2  # rad/s^2 per unit yaw demand
    pitch_gain: float = 1.0
    damping: float = 1.5  # 1/s
    restoring: float = 1.0  # pitch back to level, 1/s^2

    def step(self, pwm_us: tuple[int, int, int, int], dt: float) -> VehicleState:
        thrust = [(p - 1500) / 400.0 for p in pwm_us]
        yaw_demand = sum(t * row[1] for t, row in zip(thrust, DEFAULT_ALLOCATION, strict=True)) / 4.0
        pitch_demand = sum(t * row[2] for t, row in zip(thrust, DEFAULT_ALLOCATION, strict=True)) / 4.0
        s = self.state
        s.yaw_rate += dt * (self.yaw_gain * yaw_demand - self.damping * s.yaw_rate)
        s.pitch_rate += dt * (self.pitch_gain * pitch_demand - self.damping * s.pitch_rate - self.restoring * s.pitch)
        s.yaw = (s.yaw + dt * s.yaw_rate + math.pi) % (2 * math.pi) - math.pi
        s.pitch += dt * s.pitch_rate
        return s


@dataclass(frozen=True)
class CommandRecord:
    time_s: float
    seq: int
    pwm_us: tuple[int, int, int, int]
    armed: bool


class MainControllerSim:
    """Run in a background thread; ``port`` is the link to the pseudo-terminal the bridge opens.

    ``link``: where to put that link (replaced if it is one already); default a private
    temporary folder.
    """

    def __init__(
        self,
        vehicle: VehicleModel | None = None,
        telemetry_hz: float = 50.0,
        watchdog_s: float = 0.5,
        clock: Callable[[], float] = time.monotonic,
        link: Path | None = None,
    ) -> None:
        self.vehicle = vehicle or SimpleVehicle()
        self.telemetry_hz = telemetry_hz
        self.watchdog_s = watchdog_s
        self.clock = clock
        self.decoder = StreamDecoder()
        self.log: list[CommandRecord] = []
        self.applied: tuple[int, int, int, int] = NEUTRAL
        self.armed = False
        self.state = VehicleState()
        self.heartbeats = 0
        self._last_command_time = -math.inf
        self._last_seq = 0
        self._seq = 0
        self._failsafe = False
        self._silent_until = -math.inf
        self._unplug_for: float | None = None  # requested by unplug(), done by the controller thread
        self._replug_at: float | None = None
        self._own_folder = None if link is not None else tempfile.mkdtemp(prefix="main-controller-")
        self._link = link if link is not None else Path(self._own_folder, "main_controller")  # type: ignore[arg-type]
        if self._link.exists() and not self._link.is_symlink():
            raise FileExistsError(f"{self._link} exists and is not a symbolic link; not replacing it")
        self.port = str(self._link)
        self._master = self._slave = -1
        self._fd_lock = threading.Lock()  # inject() writes from other threads while the terminal may change
        self._plug_in()
        self._stop = threading.Event()
        self._lock = threading.Lock()
        self._thread: threading.Thread | None = None

    def _plug_in(self) -> None:
        """A new pseudo-terminal behind the link."""
        master, slave = os.openpty()  # the slave stays open so the pty survives reconnects
        tty.setraw(master)
        tty.setraw(slave)
        os.set_blocking(master, False)
        with self._fd_lock:
            self._master, self._slave = master, slave
        self.pty_name = os.ttyname(slave)
        if self._link.is_symlink():
            self._link.unlink()
        try:
            os.symlink(self.pty_name, self._link)
        except OSError:  # no folder there, or not ours to write: the terminal goes with the error
            self._pull_out()
            raise

    def _pull_out(self) -> None:
        """The terminal and its link vanish: the bridge's reads and writes fail."""
        if self._link.is_symlink():
            self._link.unlink()
        with self._fd_lock:
            for fd in (self._master, self._slave):
                if fd >= 0:
                    os.close(fd)
            self._master = self._slave = -1

    def start(self) -> MainControllerSim:
        self._thread = threading.Thread(target=self._run, name="main-controller-sim", daemon=True)
        self._thread.start()
        return self

    def stop(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=2.0)
        self._pull_out()
        if self._own_folder is not None:
            shutil.rmtree(self._own_folder, ignore_errors=True)

    def __enter__(self) -> MainControllerSim:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()

    def pause_telemetry(self, seconds: float) -> None:
        """Fault injection: send no telemetry for a while (the navigation system hangs)."""
        self._silent_until = self.clock() + seconds

    def unplug(self, seconds: float) -> None:
        """Fault injection: the cable is pulled for ``seconds``, then put back (a new terminal, same link).

        The controller keeps running meanwhile: its watchdog sets neutral, as a real one would.
        """
        self._unplug_for = seconds

    @property
    def plugged(self) -> bool:
        return self._master >= 0

    def inject(self, data: bytes) -> None:
        """Fault injection: raw bytes on the line (noise, a corrupt or implausible frame)."""
        self._write(data)

    def records(self) -> list[CommandRecord]:
        with self._lock:
            return list(self.log)

    def _run(self) -> None:
        period = 1.0 / self.telemetry_hz
        last = self.clock()
        next_telemetry = last
        while not self._stop.is_set():
            now = self.clock()
            if self._unplug_for is not None:
                self._pull_out()
                self._replug_at, self._unplug_for = now + self._unplug_for, None
            if self._replug_at is not None and now >= self._replug_at:
                self._plug_in()
                self._replug_at = None
            self._read()
            if now - self._last_command_time > self.watchdog_s and self.applied != NEUTRAL:
                self.applied, self._failsafe = NEUTRAL, True
            self.state = self.vehicle.step(self.applied if self.armed else NEUTRAL, now - last)
            last = now
            if now >= next_telemetry:
                next_telemetry = now + period
                if now >= self._silent_until:
                    self._write(self._telemetry(now))
            time.sleep(0.001)

    def _read(self) -> None:
        """Only when bytes wait: a read of an empty terminal waits for the kernel's input worker
        (see link.transport.SerialTransport.read), and this loop keeps the telemetry's rate."""
        if self._master < 0:
            return  # unplugged
        try:
            waiting = array.array("i", [0])
            fcntl.ioctl(self._master, termios.FIONREAD, waiting)
            data = os.read(self._master, waiting[0]) if waiting[0] else b""
        except (BlockingIOError, OSError):
            return
        now = self.clock()
        for frame in self.decoder.feed(data):
            msg = frame.message
            if isinstance(msg, ThrusterCommandMsg):
                with self._lock:
                    self.log.append(CommandRecord(now, frame.seq, msg.pwm_us, msg.armed))
                self._last_command_time = now
                self._last_seq = frame.seq
                self.applied = msg.pwm_us if (msg.armed and self.armed) else NEUTRAL
                self._failsafe = False
            elif isinstance(msg, ArmMsg):
                self.armed = msg.arm
            elif isinstance(msg, HeartbeatMsg):
                self.heartbeats += 1

    def _telemetry(self, now: float) -> bytes:
        s = self.state
        status = (Status.ARMED if self.armed else 0) | (Status.FAILSAFE if self._failsafe else 0)
        status |= Status.DOCKED if s.docked else 0
        msg = TelemetryMsg(
            int(now * 1000), s.roll, s.pitch, s.yaw, s.depth, s.roll_rate, s.pitch_rate, s.yaw_rate,
            int(status), self.applied, self._last_seq,
        )
        self._seq = (self._seq + 1) & 0xFF
        return encode(msg, self._seq)

    def _write(self, data: bytes) -> None:
        with self._fd_lock:
            if self._master < 0:
                return  # unplugged
            try:
                os.write(self._master, data)
            except (BlockingIOError, OSError):
                pass  # nobody reading: a real UART drops bytes too
