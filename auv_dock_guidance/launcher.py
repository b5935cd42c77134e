"""Start the nodes as processes from one parameter file, as `ros2 launch` would, without ROS tooling.

Used by `auv-dock run`, the demo, the latency bench and the integration tests. Each node
runs as ``python -m auv_dock_guidance.nodes.<name>`` with ``--ros-args --params-file``;
overrides use the node-qualified form (``-p detector:marker_radius_m:=0.4``) so they beat
the node's own section of the file. The environment selects the shared-memory Fast DDS
profile (UDP only for guidance and serial_bridge) and, unless told otherwise,
localhost-only discovery.

Every command that starts nodes (run, demo, soak, bench --latency) owns their processes:
it stops them on SIGINT, SIGTERM and SIGHUP alike (``stop_on_signals``), announces the ROS
domain they use and how to watch it (``announce``), and lists itself in a small registry
under $XDG_RUNTIME_DIR (or /tmp) while it runs, so `auv-dock monitor` and `foxglove` find
a single running system on this machine without being told its domain (``running_systems``).
"""

from __future__ import annotations

import json
import os
import random
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator, Mapping
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO, Any, TextIO

from auv_dock_guidance.resources import config_file
from auv_dock_guidance.shared_memory import remove_zombie_segments

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
# Fast DDS port lock behind that leaves its restart deaf, or holds a publish to it for 2-3 s
# (see config/fastdds_udp_only.xml and config/fastdds_udp_localhost.xml).
UDP_ONLY = {"guidance", "serial_bridge"}
PROFILES_VARIABLE = "FASTRTPS_DEFAULT_PROFILES_FILE"
RANGE_VARIABLE = "ROS_AUTOMATIC_DISCOVERY_RANGE"
BRIDGE = "serial_bridge"  # stopped first: it leaves the thrusters neutral as it closes
# Frame work yields the CPU to the control path when the computer is short of it: a late
# frame is dropped (only the newest is processed), late telemetry aborts the approach.
VISION_NICENESS = 5
YIELDING = {"camera_ingest", "detector", "vision_pipeline"}
STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)
LAUNCHER_VARIABLE = "AUV_DOCK_LAUNCHER_PID"  # set for the nodes it starts: they end when it does
_PR_SET_PDEATHSIG = 1  # linux/prctl.h


def udp_only_environment(env: Mapping[str, str]) -> dict[str, str]:
    """What a process kept off shared memory needs set: a localhost-only system gets UDP on
    the loopback interface with the discovery range SUBNET, since under LOCALHOST rmw_fastrtps
    adds shared memory to whatever transports the profile lists."""
    if env.get(RANGE_VARIABLE) == "LOCALHOST":
        return {PROFILES_VARIABLE: str(config_file("fastdds_udp_localhost.xml")), RANGE_VARIABLE: "SUBNET"}
    return {PROFILES_VARIABLE: str(config_file("fastdds_udp_only.xml"))}


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
        env[RANGE_VARIABLE] = "LOCALHOST"
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
        nice = ["nice", "-n", str(VISION_NICENESS)] if name in YIELDING and shutil.which("nice") else []
        argv = [*self.prefix, *nice, sys.executable, "-m", NODE_MODULES[name], "--ros-args", "--params-file",
                str(self.params_file)]
        for node in NODES_OF.get(name, (name,)):
            for key, value in self.overrides.get(node, {}).items():
                argv += ["-p", f"{node}:{key}:={_format(value)}"]
        return argv

    def start(self) -> NodeGroup:
        for name in self.nodes:
            if name not in NODE_MODULES:
                raise ValueError(f"unknown node {name!r}; known: {', '.join(NODE_MODULES)}")
        remove_zombie_segments()  # what killed nodes of earlier runs left in RAM
        for name in self.nodes:
            self._spawn(name, "wb")
        return self

    def restart(self, name: str) -> None:
        """Start one node again (after it died or was killed); its log continues."""
        process = self.processes.get(name)
        if process is not None and process.poll() is None:
            raise RuntimeError(f"{name} is still running")
        remove_zombie_segments()  # the dead node's
        self._spawn(name, "ab")

    def _spawn(self, name: str, log_mode: str) -> None:
        out: Any = None
        if self.log_dir is not None:
            self.log_dir.mkdir(parents=True, exist_ok=True)
            out = open(self.log_dir / f"{name}.log", log_mode)
            self._logs.append(out)
        env = {**self.environment(name), LAUNCHER_VARIABLE: str(os.getpid())}
        self.processes[name] = subprocess.Popen(
            self.command(name), env=env, stdout=out, stderr=subprocess.STDOUT if out else None,
            stdin=subprocess.DEVNULL, start_new_session=True,
        )

    def environment(self, name: str) -> dict[str, str]:
        """The group's environment, with a UDP-only profile for UDP_ONLY nodes unless the
        user chose a profile of their own."""
        if name in UDP_ONLY and self.env.get(PROFILES_VARIABLE) == str(config_file("fastdds_shm.xml")):
            return {**self.env, **udp_only_environment(self.env)}
        return self.env

    def exited(self) -> dict[str, int]:
        return {n: p.returncode for n, p in self.processes.items() if p.poll() is not None}

    def stop(self, timeout_s: float = 5.0) -> dict[str, int | None]:
        """Ctrl-C each node (the serial bridge first: neutral before anything else), wait, then
        terminate and kill what is left."""
        for name in sorted(self.processes, key=lambda n: n != BRIDGE):
            if self.processes[name].poll() is None:
                self.processes[name].send_signal(signal.SIGINT)
        deadline = time.monotonic() + timeout_s
        for sig in (signal.SIGTERM, signal.SIGKILL):
            for p in self.processes.values():
                remaining = deadline - time.monotonic()
                try:
                    p.wait(timeout=max(0.1, remaining))
                except subprocess.TimeoutExpired:
                    if sig == signal.SIGKILL:
                        _log_where_it_hangs(p)
                    p.send_signal(sig)
            deadline = time.monotonic() + 2.0
        for p in self.processes.values():
            p.wait()  # reaped: nothing is left behind, even after SIGKILL
        for log in self._logs:
            log.close()
        return {n: p.returncode for n, p in self.processes.items()}

    def __enter__(self) -> NodeGroup:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()


def end_with_launcher() -> None:
    """In a node the launcher started: SIGTERM (its clean stop: the bridge leaves the thrusters
    neutral) when the launcher ends in any way, a SIGKILL or a crash included, instead of
    running on unsupervised. Linux only (prctl); elsewhere, and for a node a person started,
    nothing changes (a node under nohup keeps running when its terminal closes)."""
    launcher = os.environ.get(LAUNCHER_VARIABLE)
    if launcher is None or not sys.platform.startswith("linux"):
        return
    import ctypes  # here: only nodes a launcher started need it

    ctypes.CDLL(None, use_errno=True).prctl(_PR_SET_PDEATHSIG, int(signal.SIGTERM), 0, 0, 0)
    try:
        os.kill(int(launcher), 0)  # ended before the request took effect: end now
    except ProcessLookupError:
        os.kill(os.getpid(), signal.SIGTERM)
    except (PermissionError, ValueError):
        pass


def _log_where_it_hangs(process: subprocess.Popen) -> None:
    """A node that ignored SIGINT and SIGTERM writes its threads' stacks to its log
    (nodes.common registers SIGUSR1 with faulthandler) before it is killed."""
    process.send_signal(signal.SIGUSR1)
    try:
        process.wait(timeout=0.3)
    except subprocess.TimeoutExpired:
        pass


class StopRequested(KeyboardInterrupt):
    """SIGTERM or SIGHUP (a supervisor's stop, a closed terminal): handled exactly as Ctrl-C."""


@contextmanager
def stop_on_signals() -> Iterator[None]:
    """SIGINT, SIGTERM and SIGHUP (unless nohup ignores it) raise KeyboardInterrupt once
    in the main thread, so the owner of the node processes runs the same cleanup for each; a
    repeated signal while it cleans up is ignored (the cleanup is bounded: NodeGroup.stop
    kills what does not stop)."""
    stopping = False

    def handler(signum: int, _frame: object) -> None:
        nonlocal stopping
        if stopping:
            print(f"auv-dock: {signal.Signals(signum).name} again: still stopping the nodes", file=sys.stderr,
                  flush=True)
            return
        stopping = True
        if signum == signal.SIGINT:
            raise KeyboardInterrupt
        raise StopRequested(signal.Signals(signum).name)

    # A hangup ignored when we start stays ignored: under nohup, a closed terminal must not stop a soak.
    # (SIGINT is always ours: a shell starts background jobs with it ignored, and Ctrl-C must still stop.)
    previous = {sig: signal.getsignal(sig) for sig in STOP_SIGNALS
                if not (sig == signal.SIGHUP and signal.getsignal(sig) is signal.SIG_IGN)}
    for sig in previous:
        signal.signal(sig, handler)
    try:
        yield
    finally:
        for sig, old in previous.items():
            signal.signal(sig, old if old is not None else signal.SIG_DFL)


def _registry_folder() -> Path:
    runtime = os.environ.get("XDG_RUNTIME_DIR")
    base = Path(runtime) if runtime and os.access(runtime, os.W_OK) else Path(tempfile.gettempdir())
    return base / f"auv-dock-{os.getuid()}"


def _start_ticks(pid: int) -> str | None:
    """The process's start time in clock ticks since boot: with the pid, it names one process
    (a pid reused by another process after ours ended has another start time)."""
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return None
    return stat.rsplit(")", 1)[1].split()[19]


@dataclass(frozen=True)
class RunningSystem:
    pid: int
    domain_id: int
    command: str
    localhost_only: bool


def running_systems() -> list[RunningSystem]:
    """The auv-dock commands running nodes on this machine now; entries of ended ones are removed."""
    folder = _registry_folder()
    found = []
    for entry in sorted(folder.glob("*.json")) if folder.is_dir() else []:
        try:
            data = json.loads(entry.read_text())
            system = RunningSystem(int(data["pid"]), int(data["domain_id"]), str(data["command"]),
                                   bool(data["localhost_only"]))
            alive = _start_ticks(system.pid) == data["start_ticks"]
        except (OSError, ValueError, KeyError, TypeError):
            continue  # being written, or not ours
        if alive:
            found.append(system)
        else:
            entry.unlink(missing_ok=True)
    return found


@contextmanager
def registered(domain_id: int, command: str, localhost_only: bool = True) -> Iterator[None]:
    """This process is listed as running ``command`` on ``domain_id`` until the block ends."""
    folder = _registry_folder()
    entry = folder / f"{os.getpid()}.json"
    try:
        folder.mkdir(mode=0o700, parents=True, exist_ok=True)
        partial = entry.with_suffix(".tmp")
        partial.write_text(json.dumps({"pid": os.getpid(), "start_ticks": _start_ticks(os.getpid()),
                                       "domain_id": domain_id, "command": command,
                                       "localhost_only": localhost_only}))
        partial.replace(entry)  # readers never see half a file
    except OSError as exc:  # watching needs --domain-id then; the run itself goes on
        print(f"auv-dock: note: cannot list this run in {folder} ({exc.strerror})", file=sys.stderr)
    try:
        yield
    finally:
        entry.unlink(missing_ok=True)


def private_domain_id() -> int:
    """A ROS domain for a simulated system: from this process id, avoiding those of systems already
    running here, so parallel runs on one machine never hear each other."""
    taken = {s.domain_id for s in running_systems()}
    rng = random.Random(os.getpid())
    choices = [d for d in range(30, 201) if d not in taken]
    return rng.choice(choices) if choices else rng.randint(30, 200)


def command_name() -> str:
    """How to type auv-dock here: its name if the shell finds this one, else its path."""
    script = Path(sys.argv[0])
    if script.name == "auv-dock":
        on_path = shutil.which("auv-dock")
        if on_path and Path(on_path).resolve() == script.resolve():
            return "auv-dock"
        return str(script)
    return f"{sys.executable} -m auv_dock_guidance.cli.main"


def announce(domain_id: int, stream: TextIO | None = None) -> None:
    """First thing a command that starts nodes says: where they talk, and how to watch them."""
    me = command_name()
    print(f"ROS domain {domain_id}; watch it live from another terminal:\n"
          f"  {me} monitor --domain-id {domain_id}\n"
          f"  {me} foxglove --domain-id {domain_id}", file=stream or sys.stdout, flush=True)
