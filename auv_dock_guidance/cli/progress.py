"""Progress lines on stderr for long work: redrawn in place on a terminal, sparse in a log."""

from __future__ import annotations

import sys
import time


class Progress:
    def __init__(self, label: str, total: int) -> None:
        self.label = label
        self.total = max(total, 1)
        self.start = time.monotonic()
        self._last_line = 0.0
        self._tty = sys.stderr.isatty()

    def __call__(self, done: int, total: int | None = None) -> None:
        total = total or self.total
        now = time.monotonic()
        final = done >= total
        if not final and now - self._last_line < (0.2 if self._tty else 5.0):
            return
        self._last_line = now
        elapsed = now - self.start
        eta = elapsed / done * (total - done) if done else 0.0
        line = f"{self.label}: {done}/{total} ({100 * done / total:.0f} %), {elapsed:.0f} s, ~{eta:.0f} s left"
        if self._tty:
            sys.stderr.write("\r" + line + ("\n" if final else ""))
        else:
            sys.stderr.write(line + "\n")
        sys.stderr.flush()
