"""A serial port that survives being unplugged: reconnect with exponential back-off.

Works with a real UART (/dev/ttyUSB0, 115200 8N1) and with a pseudo-terminal. Reads and
writes never block; while the port is away they return nothing / report False and the
next attempt to open it waits longer each time, up to ``backoff_max_s``.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import serial

log = logging.getLogger(__name__)

WRITE_TIMEOUTS_LOST = 3  # write timeouts in a row that mean the device is gone


@dataclass
class TransportStats:
    opens: int = 0
    open_failures: int = 0
    write_errors: int = 0
    write_timeouts: int = 0  # writes that did not finish within the write timeout (not all are errors)
    read_errors: int = 0
    bytes_written: int = 0
    bytes_read: int = 0


class SerialTransport:
    def __init__(
        self,
        port: str,
        baudrate: int = 115200,
        backoff_initial_s: float = 0.05,
        backoff_max_s: float = 2.0,
        clock: Callable[[], float] = time.monotonic,
        opener: Callable[..., Any] = serial.serial_for_url,
    ) -> None:
        self.port = port
        self.baudrate = baudrate
        self.stats = TransportStats()
        self._backoff_initial = backoff_initial_s
        self._backoff_max = backoff_max_s
        self._backoff = backoff_initial_s
        self._clock = clock
        self._opener = opener
        self._serial: Any = None
        self._next_attempt = 0.0
        self._timeouts_in_row = 0

    @property
    def connected(self) -> bool:
        return self._serial is not None

    def ensure_open(self) -> bool:
        """Open the port if it is closed and the back-off has passed."""
        if self._serial is not None:
            return True
        now = self._clock()
        if now < self._next_attempt:
            return False
        try:
            self._serial = self._opener(self.port, baudrate=self.baudrate, timeout=0, write_timeout=0.05)
        except (serial.SerialException, OSError, ValueError) as exc:
            self.stats.open_failures += 1
            self._next_attempt = now + self._backoff
            if self.stats.open_failures == 1 or self._backoff >= self._backoff_max:
                log.warning("serial port %s unavailable (%s); retrying every <= %.1f s",
                            self.port, exc, self._backoff_max)
            self._backoff = min(self._backoff * 2.0, self._backoff_max)
            return False
        self.stats.opens += 1
        self._backoff = self._backoff_initial
        if self.stats.opens > 1:
            log.warning("serial port %s reopened", self.port)
        return True

    def write(self, data: bytes) -> bool:
        if not self.ensure_open():
            return False
        try:
            self._serial.write(data)
        except serial.SerialTimeoutException as exc:
            # pyserial raises this after a complete write when the process was paused longer than
            # the timeout (pyserial issue #281): only a device that takes no bytes for several
            # writes in a row is gone; one timeout is a busy machine, and the frame may be out.
            self.stats.write_timeouts += 1
            self._timeouts_in_row += 1
            if self._timeouts_in_row >= WRITE_TIMEOUTS_LOST:
                self.stats.write_errors += 1
                self._lost(exc)
            return False
        except (serial.SerialException, OSError) as exc:
            self.stats.write_errors += 1
            self._lost(exc)
            return False
        self._timeouts_in_row = 0
        self.stats.bytes_written += len(data)
        return True

    def read(self) -> bytes:
        """What has arrived, without waiting: a terminal is read only when it holds bytes, because
        Linux makes a read or poll of an empty terminal wait for its input worker (a kernel thread)
        to run, which on a busy computer took up to 0.45 s (measured on a pseudo-terminal)."""
        if not self.ensure_open():
            return b""
        try:
            waiting = self._serial.in_waiting  # also how a vanished device shows: the call fails
            if not waiting:
                return b""
            data = self._serial.read(waiting)
        except (serial.SerialException, OSError, TypeError) as exc:
            self.stats.read_errors += 1
            self._lost(exc)
            return b""
        self.stats.bytes_read += len(data)
        return bytes(data)

    def close(self) -> None:
        if self._serial is not None:
            try:
                self._serial.close()
            except (serial.SerialException, OSError):
                pass
            self._serial = None

    def _lost(self, exc: Exception) -> None:
        log.warning("serial port %s lost (%s); reconnecting", self.port, exc)
        self.close()
        self._next_attempt = self._clock() + self._backoff
