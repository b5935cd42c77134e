"""The ros2 run / ros2 launch layout, built with colcon from PyPI (no ROS install needed)."""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
NODES = ["dock_camera_ingest", "dock_detector", "dock_guidance", "dock_serial_bridge", "dock_vision_pipeline"]


@pytest.fixture(scope="module")
def install(tmp_path_factory):
    colcon = Path(sys.executable).parent / "colcon"
    if not colcon.exists():
        pytest.fail("colcon is not installed in this environment (make venv installs it)")
    workspace = tmp_path_factory.mktemp("ws")
    source = workspace / "src" / "auv_dock_guidance"
    shutil.copytree(REPO, source, ignore=shutil.ignore_patterns(".venv", ".git", "build", "install", "log",
                                                                  "*.egg-info", "__pycache__", ".pytest_cache"))
    env = dict(os.environ, PATH=f"{colcon.parent}:{os.environ['PATH']}")
    result = subprocess.run(
        [str(colcon), "build", "--base-paths", "src"], cwd=workspace, env=env, capture_output=True, text=True,
        timeout=300,
    )
    assert result.returncode == 0, result.stdout + result.stderr
    return workspace / "install" / "auv_dock_guidance"


def test_executables_and_share_files_are_where_ros2_looks(install):
    for name in NODES:
        assert (install / "lib" / "auv_dock_guidance" / name).is_file(), name
    assert (install / "share" / "ament_index" / "resource_index" / "packages" / "auv_dock_guidance").is_file()
    share = install / "share" / "auv_dock_guidance"
    assert (share / "package.xml").is_file()
    assert (share / "launch" / "dock_guidance.launch.py").is_file()
    for name in ("dock_guidance.yaml", "camera_info.yaml", "thrusters.yaml", "fastdds_shm.xml", "fastdds_udp_only.xml"):
        assert (share / "config" / name).is_file(), name


def test_an_installed_node_starts_and_stops_cleanly(install, domain_id):
    site = next((install / "lib").glob("python3*/site-packages"))
    env = dict(os.environ, PYTHONPATH=f"{site}:{os.environ.get('PYTHONPATH', '')}", ROS_DOMAIN_ID=str(domain_id),
               AMENT_PREFIX_PATH=str(install), RCUTILS_LOGGING_BUFFERED_STREAM="0")
    process = subprocess.Popen([sys.executable, str(install / "lib" / "auv_dock_guidance" / "dock_guidance")],
                               env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT)
    time.sleep(4.0)
    assert process.poll() is None, process.stdout.read().decode()
    process.send_signal(signal.SIGINT)
    assert process.wait(timeout=10) == 0
    output = process.stdout.read().decode()
    assert "Traceback" not in output, output
