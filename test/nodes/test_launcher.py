"""The launcher: which Fast DDS transports each node process gets, the registry of running
systems, and stopping on SIGTERM and SIGHUP as on Ctrl-C."""

import contextlib
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from auv_dock_guidance.launcher import (
    PROFILES_VARIABLE,
    VISION_COMBINED,
    VISION_NICENESS,
    NodeGroup,
    RunningSystem,
    StopRequested,
    private_domain_id,
    registered,
    ros_environment,
    running_systems,
    stop_on_signals,
)
from auv_dock_guidance.resources import config_file


@pytest.mark.parametrize("localhost_only", [True, False])
def test_only_processes_that_carry_frames_use_shared_memory(localhost_only):
    env = ros_environment(localhost_only=localhost_only)
    group = NodeGroup(["vision_pipeline", "guidance", "serial_bridge"], env=env)
    shm = str(config_file("fastdds_shm.xml"))
    udp = str(config_file("fastdds_udp_localhost.xml" if localhost_only else "fastdds_udp_only.xml"))
    assert group.environment("vision_pipeline")[PROFILES_VARIABLE] == shm
    assert group.environment("detector")[PROFILES_VARIABLE] == shm
    assert group.environment("guidance")[PROFILES_VARIABLE] == udp
    assert group.environment("serial_bridge")[PROFILES_VARIABLE] == udp


def test_a_udp_only_node_of_a_localhost_only_system_maps_no_shared_memory():
    """Measured, not assumed: under the discovery range LOCALHOST rmw_fastrtps adds shared memory to
    the profile's transports, so the running process is checked for Fast DDS segments."""
    group = NodeGroup(["guidance"], env=ros_environment(private_domain_id())).start()
    try:
        pid = group.processes["guidance"].pid
        end = time.monotonic() + 60.0

        def sockets() -> int:
            count = 0
            for fd in Path(f"/proc/{pid}/fd").iterdir():
                with contextlib.suppress(FileNotFoundError):  # closed between the listing and the look
                    count += os.readlink(fd).startswith("socket:")
            return count

        while sockets() < 3:
            assert time.monotonic() < end and group.processes["guidance"].poll() is None, "guidance did not start"
            time.sleep(0.2)
        time.sleep(1.0)  # transports are set up with the participant's sockets; give it a moment
        with open(f"/proc/{pid}/maps") as maps:
            shared = {line.split()[-1] for line in maps if "/dev/shm/fastrtps" in line}
    finally:
        group.stop()
    assert not shared


def test_frame_work_is_niced_below_guidance_and_the_bridge():
    group = NodeGroup(VISION_COMBINED, env=ros_environment())
    assert group.command("vision_pipeline")[:3] == ["nice", "-n", str(VISION_NICENESS)]
    assert group.command("guidance")[0] == sys.executable and group.command("serial_bridge")[0] == sys.executable


def test_a_profile_the_user_chose_is_kept_for_every_process(monkeypatch, tmp_path):
    mine = str(tmp_path / "my_profile.xml")
    monkeypatch.setenv(PROFILES_VARIABLE, mine)
    group = NodeGroup(["guidance"], env=ros_environment())
    assert group.environment("guidance")[PROFILES_VARIABLE] == mine


def test_a_running_system_is_listed_while_it_runs_and_not_after(monkeypatch, tmp_path):
    monkeypatch.setenv("XDG_RUNTIME_DIR", str(tmp_path))
    assert running_systems() == []
    with registered(42, "demo"):
        assert running_systems() == [RunningSystem(os.getpid(), 42, "demo", True)]
        assert private_domain_id() != 42
    assert running_systems() == [] and not list(tmp_path.glob("auv-dock-*/*"))


def test_entries_of_ended_processes_are_dropped(monkeypatch, tmp_path):
    monkeypatch.setenv("XDG_RUNTIME_DIR", str(tmp_path))
    ended = subprocess.Popen([sys.executable, "-c", "pass"])
    ended.wait()
    folder = tmp_path / f"auv-dock-{os.getuid()}"
    folder.mkdir()
    for pid, ticks in ((ended.pid, "1"), (os.getpid(), "0")):  # gone; our pid with another start time (reused)
        (folder / f"{pid}.json").write_text(json.dumps({"pid": pid, "start_ticks": ticks, "domain_id": 50,
                                                        "command": "demo", "localhost_only": True}))
    (folder / "999999.json").write_text("{half a fi")  # being written, or not ours
    assert running_systems() == []
    assert [p.name for p in folder.iterdir()] == ["999999.json"]


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGHUP])
def test_sigterm_and_sighup_end_the_work_as_ctrl_c_does(sig):
    previous = signal.signal(sig, signal.SIG_DFL)  # as a terminal starts us (pytest may run under nohup)
    try:
        with pytest.raises(KeyboardInterrupt, match=sig.name) as stopped, stop_on_signals():
            os.kill(os.getpid(), sig)
            time.sleep(2.0)
        assert isinstance(stopped.value, StopRequested)
        assert signal.getsignal(sig) is signal.SIG_DFL  # the process's own handling is back
    finally:
        signal.signal(sig, previous)


def test_a_hangup_ignored_as_under_nohup_stays_ignored():
    previous = signal.signal(signal.SIGHUP, signal.SIG_IGN)
    try:
        with stop_on_signals():
            os.kill(os.getpid(), signal.SIGHUP)
            time.sleep(0.2)  # nothing is raised: the work goes on
        assert signal.getsignal(signal.SIGHUP) is signal.SIG_IGN
    finally:
        signal.signal(signal.SIGHUP, previous)


def test_a_second_signal_does_not_cut_the_cleanup_short():
    cleaned = False
    with pytest.raises(KeyboardInterrupt), stop_on_signals():
        try:
            os.kill(os.getpid(), signal.SIGINT)
            time.sleep(2.0)
        finally:
            os.kill(os.getpid(), signal.SIGTERM)  # a supervisor's stop while the nodes are being stopped
            time.sleep(0.2)
            cleaned = True
    assert cleaned


def test_a_node_that_ignores_every_stop_signal_is_killed_and_its_stack_is_in_its_log(tmp_path):
    """As run_nodes registers it: SIGUSR1 dumps the stacks before the kill, so the log says where it hung."""
    stuck = ("import faulthandler, signal, time\n"
             "faulthandler.register(signal.SIGUSR1, all_threads=True)\n"
             "for s in (signal.SIGINT, signal.SIGTERM): signal.signal(s, signal.SIG_IGN)\n"
             "print('up', flush=True)\n"
             "def hung_in_teardown(): time.sleep(60)\n"
             "hung_in_teardown()\n")
    log = open(tmp_path / "stuck.log", "wb")
    group = NodeGroup([], env=ros_environment())
    group.processes["stuck"] = subprocess.Popen([sys.executable, "-c", stuck], stdout=log, stderr=subprocess.STDOUT)
    group._logs.append(log)
    while b"up" not in (tmp_path / "stuck.log").read_bytes():
        time.sleep(0.05)
    assert group.stop(timeout_s=0.3) == {"stuck": -signal.SIGKILL}
    assert "hung_in_teardown" in (tmp_path / "stuck.log").read_text()
