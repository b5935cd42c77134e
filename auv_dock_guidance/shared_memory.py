"""Fast DDS shared-memory segments that no live process holds: removed before nodes start.

Each Fast DDS participant on shared memory keeps a segment in /dev/shm (35 MB for one that
carries 1080p frames) with a lock file its process holds while it lives. A process that is
killed or crashes leaves both behind, and nothing in Fast DDS removes them: after a day of
soaks that killed nodes a few hundred times, 37 of them held 185 MB of RAM. A segment whose
lock no process holds is a zombie; `remove_zombie_segments` removes those, as
`fastdds shm clean` does (that tool is not on every machine: the PyPI wheels keep it out of
PATH). Ports (small, about 3 MB in all there) are left to Fast DDS.

A participant creates its lock file and only then locks it (Fast DDS's RobustExclusiveLock:
open, then flock), and a probe of ours in between would take a starting participant's segment
for a zombie, or make its own flock fail. Lock files younger than ``SETTLE_S`` are therefore
left alone: a live participant's lock is taken microseconds after the file is made, a zombie's
is as old as the process that left it.
"""

from __future__ import annotations

import fcntl
import os
import re
import time
from pathlib import Path

SHARED_MEMORY_DIR = Path("/dev/shm")
SETTLE_S = 30.0  # a lock file younger than this may belong to a participant still starting
_SEGMENT_LOCK = re.compile(r"^fastrtps_[0-9a-z]{16}_el$")


def remove_zombie_segments(directory: Path = SHARED_MEMORY_DIR) -> int:
    """Remove the segments (and their lock files) whose lock no process holds and is older than
    SETTLE_S; how many were removed. Files that cannot be read or removed (another user's) stay."""
    try:
        names = os.listdir(directory)
    except OSError:
        return 0
    removed = 0
    for name in names:
        lock = directory / name
        if not _SEGMENT_LOCK.match(name) or not _settled(lock) or _held(lock):
            continue
        try:
            (directory / name[: -len("_el")]).unlink(missing_ok=True)
            lock.unlink()
        except OSError:
            continue
        removed += 1
    return removed


def _settled(lock: Path) -> bool:
    """Whether the lock file is older than SETTLE_S (one that cannot be read is not)."""
    try:
        return time.time() - lock.stat().st_mtime > SETTLE_S
    except OSError:
        return False


def _held(lock: Path) -> bool:
    """Whether a live process holds the lock (or it cannot be told: then it is taken as held)."""
    try:
        with open(lock, "ab") as file:
            fcntl.flock(file, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError:
        return True
    return False
