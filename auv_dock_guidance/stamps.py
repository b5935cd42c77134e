"""Message stamps that must move forward: repeats and out-of-order ones are refused with a reason.

A camera that resends a frame, a transport that reorders, a bag played twice: acting on an
old stamp again would feed old data to the controllers as if it were new. A stamp older
than the last by more than ``clock_step_s`` is not a late message but the sender's clock
stepping back (NTP, GPS time): it starts a new timeline instead of locking the stream out.
"""

from __future__ import annotations

import math


class StampGate:
    def __init__(self, clock_step_s: float = 1.0) -> None:
        self.clock_step_s = clock_step_s
        self._last: float | None = None

    def admit(self, stamp_s: float) -> str | None:
        """None if ``stamp_s`` may be acted on (and it becomes the last), else why not."""
        if not math.isfinite(stamp_s):
            return f"stamp {stamp_s} is not a finite time"
        last = self._last
        if last is not None and stamp_s == last:
            return "repeated stamp"
        if last is not None and last - self.clock_step_s <= stamp_s < last:
            return f"stamp {1000 * (last - stamp_s):.0f} ms older than the previous one"
        self._last = stamp_s
        return None

    def reset(self) -> None:
        self._last = None
