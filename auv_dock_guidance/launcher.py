"""Start the nodes as processes from one parameter file, as `ros2 launch` would, without ROS tooling.

Used by `auv-dock run`, the demo, the latency bench and the integration tests. Each node
runs as ``python -m auv_dock_guidance.nodes.<name>`` with ``--ros-args --params-file``;
overrides use the node-qualified form (``-p detector:marker_radius_m:=0.4``) so they beat
the node's own section of the file. The environment selects the shared-memory Fast DDS
profile (UDP only for guidance and serial_bridge) and, unless told otherwise,
localhost-only discovery.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO, Any

from auv_dock_guidance.resources import config_file

NODE_MODULES = {
    "camera_ingest": "auv_dock_guidance.nodes.camera_ingest",
    "detector": "auv_dock_guidance.nodes.detector",
    "guidance": "auv_dock_guidance.nodes.guidance",
    "serial_bridge": "auv_dock_guidance.nodes.serial_bridge",
    "vision_pipeline": "auv_dock_guidance.nodes.vision_pipeline",  # camera_ingest + detector in one process
}
NODES_OF = {"vision_pipeline": ("camera_ingest", "detector")}  # parameter sections a process reads
# Process layouts. Combined: 1080p frames never leave the process that captured them
# (measured: no drops and about half the latency on two cores); separate: one node each.
VISION_COMBINED = ["vision_pipeline", "guidance", "serial_bridge"]
VISION_SEPARATE = ["camera_ingest", "detector", "guidance", "serial_bridge"]
# Processes that never carry frames stay off shared memory: a killed process can leave a
# Fast DDS port lock behind that leaves its restart deaf (see config/fastdds_udp_only.xml).
UDP_ONLY = {"guidance", "serial_bridge"}
PROFILES_VARIABLE = "FASTRTPS_DEFAULT_PROFILES_FILE"


def rss_mb(pid: int) -> float:
    """Resident memory of a process in MiB (0 when it is gone)."""
    try:
        for line in Path(f"/proc/{pid}/status").read_text().splitlines():
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024.0
    except OSError:
        pass
    return 0.0


def ros_environment(domain_id: int | None = None, localhost_only: bool = True) -> dict[str, str]:
    env = dict(os.environ)
    env.setdefault(PROFILES_VARIABLE, str(config_file("fastdds_shm.xml")))
    if localhost_only:
        env["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    if domain_id is not None:
        env["ROS_DOMAIN_ID"] = str(domain_id)
    env["PYTHONUNBUFFERED"] = "1"
    env.setdefault("RCUTILS_LOGGING_BUFFERED_STREAM", "0")  # log lines reach files as they happen
    return env


def _format(value: Any) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    return str(value)


@dataclass
class NodeGroup:
    nodes: list[str]
    params_file: Path = field(default_factory=lambda: config_file("dock_guidance.yaml"))
    overrides: dict[str, dict[str, Any]] = field(default_factory=dict)
    env: dict[str, str] = field(default_factory=ros_environment)
    log_dir: Path | None = None  # None: output goes to this process's stdout/stderr
    prefix: list[str] = field(default_factory=list)  # e.g. ["ip", "netns", "exec", "vehicle"]
    processes: dict[str, subprocess.Popen] = field(default_factory=dict)
    _logs: list[IO[bytes]] = field(default_factory=list)

    def command(self, name: str) -> list[str]:
        argv = [*self.prefix, sys.executable, "-m", NODE_MODULES[name], "--ros-args", "--params-file",
                str(self.params_file)]
        for node in NODES_OF.get(name, (name,)):
            for key, value in self.overrides.get(node, {}).items():
                argv += ["-p", f"{node}:{key}:={_format(value)}"]
        return argv

    def start(self) -> NodeGroup:
        for name in self.nodes:
            if name not in NODE_MODULES:
                raise ValueError(f"unknown node {name!r}; known: {', '.join(NODE_MODULES)}")
            self._spawn(name, "wb")
        return self

    def restart(self, name: str) -> None:
        """Start one node again (after it died or was killed); its log continues."""
        process = self.processes.get(name)
        if process is not None and process.poll() is None:
            raise RuntimeError(f"{name} is still running")
        self._spawn(name, "ab")

    def _spawn(self, name: str, log_mode: str) -> None:
        out: Any = None
        if self.log_dir is not None:
            self.log_dir.mkdir(parents=True, exist_ok=True)
            out = open(self.log_dir / f"{name}.log", log_mode)
            self._logs.append(out)
        self.processes[name] = subprocess.Popen(
            self.command(name), env=self.environment(name), stdout=out, stderr=subprocess.STDOUT if out else None,
            stdin=subprocess.DEVNULL, start_new_session=True,
        )

    def environment(self, name: str) -> dict[str, str]:
        """The group's environment, with the UDP-only profile for UDP_ONLY nodes unless the
        user chose a profile of their own."""
        if name in UDP_ONLY and self.env.get(PROFILES_VARIABLE) == str(config_file("fastdds_shm.xml")):
            return {**self.env, PROFILES_VARIABLE: str(config_file("fastdds_udp_only.xml"))}
        return self.env

    def exited(self) -> dict[str, int]:
        return {n: p.returncode for n, p in self.processes.items() if p.poll() is not None}

    def stop(self, timeout_s: float = 5.0) -> dict[str, int | None]:
        """Ctrl-C each node, wait, then terminate and kill what is left."""
        for p in self.processes.values():
            if p.poll() is None:
                p.send_signal(signal.SIGINT)
        deadline = time.monotonic() + timeout_s
        for sig in (signal.SIGTERM, signal.SIGKILL):
            for p in self.processes.values():
                remaining = deadline - time.monotonic()
                try:
                    p.wait(timeout=max(0.1, remaining))
                except subprocess.TimeoutExpired:
                    p.send_signal(sig)
            deadline = time.monotonic() + 2.0
        for log in self._logs:
            log.close()
        return {n: p.returncode for n, p in self.processes.items()}

    def __enter__(self) -> NodeGroup:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()
