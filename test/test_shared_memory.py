"""Fast DDS segments left by killed processes are removed; those of live ones, and other files, stay."""

import fcntl
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

from auv_dock_guidance.launcher import PROFILES_VARIABLE, private_domain_id, ros_environment
from auv_dock_guidance.resources import config_file
from auv_dock_guidance.shared_memory import SETTLE_S, SHARED_MEMORY_DIR, remove_zombie_segments


def _age(lock: Path) -> None:
    """Make a lock file look as old as that of a process that ran for a while."""
    then = time.time() - 2 * SETTLE_S
    os.utime(lock, (then, then))


def _segment(directory: Path, name: str, settled: bool = True) -> Path:
    (directory / name).write_bytes(b"\0" * 64)
    (directory / f"{name}_el").touch()
    if settled:
        _age(directory / f"{name}_el")
    return directory / name


def test_a_segment_whose_lock_nobody_holds_goes_and_a_held_one_and_other_files_stay(tmp_path):
    zombie = _segment(tmp_path, "fastrtps_0123456789abcdef")
    alive = _segment(tmp_path, "fastrtps_fedcba9876543210")
    starting = _segment(tmp_path, "fastrtps_00112233445566aa", settled=False)  # made, not yet locked
    others = [tmp_path / "fastrtps_port17161", tmp_path / "sem.fastrtps_port17161_mutex", tmp_path / "notes_el"]
    for path in others:
        path.touch()
    with open(f"{alive}_el", "ab") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)  # as the live participant's process holds it
        assert remove_zombie_segments(tmp_path) == 1
    assert not zombie.exists() and not Path(f"{zombie}_el").exists()
    assert alive.exists() and Path(f"{alive}_el").exists()
    assert starting.exists() and Path(f"{starting}_el").exists()
    assert all(path.exists() for path in others)


def test_a_missing_folder_removes_nothing(tmp_path):
    assert remove_zombie_segments(tmp_path / "absent") == 0


def test_a_live_participants_segment_stays_and_goes_once_its_process_is_killed():
    """Fast DDS itself: its segment's lock is held while the process lives, and left when it is killed."""
    env = {**os.environ, **ros_environment(private_domain_id()),
           PROFILES_VARIABLE: str(config_file("fastdds_shm.xml"))}
    code = "import time, rclpy; rclpy.init(); node = rclpy.create_node('holder'); time.sleep(60)"
    process = subprocess.Popen([sys.executable, "-c", code], env=env)
    try:
        end = time.monotonic() + 30.0
        segments: set[str] = set()
        while not segments:
            assert time.monotonic() < end and process.poll() is None, "the participant did not start"
            time.sleep(0.2)
            with open(f"/proc/{process.pid}/maps") as maps:
                segments = {Path(line.split()[-1]).name for line in maps if "/dev/shm/fastrtps_" in line
                            and "port" not in line}
        remove_zombie_segments()
        assert all((SHARED_MEMORY_DIR / name).exists() for name in segments)
    finally:
        process.send_signal(signal.SIGKILL)
        process.wait()
    remove_zombie_segments()
    assert all((SHARED_MEMORY_DIR / name).exists() for name in segments)  # too young to judge yet
    for name in segments:
        _age(SHARED_MEMORY_DIR / f"{name}_el")
    remove_zombie_segments()
    assert not any((SHARED_MEMORY_DIR / name).exists() for name in segments)
