"""Nothing is left running: a node whose teardown hangs is cut short, and every command that owns
node processes stops them on SIGTERM and SIGHUP as on Ctrl-C, the thrusters neutral first."""

import json
import signal
import subprocess
import sys
import textwrap
import threading
import time
from collections.abc import Callable
from pathlib import Path

import cv2
import pytest
import rclpy

from auv_dock_guidance.geometry.camera import paper_camera
from auv_dock_guidance.launcher import ros_environment
from auv_dock_guidance.nodes.common import TEARDOWN_EXIT_CODE, context_shutting_down
from auv_dock_guidance.resources import config_file
from auv_dock_guidance.sim.main_controller import NEUTRAL, MainControllerSim
from auv_dock_guidance.sim.scene import SceneSpec, render

STUCK_AT_EXIT = textwrap.dedent("""
    import time
    from rclpy.node import Node
    from auv_dock_guidance.nodes.common import run_nodes

    class Stuck(Node):
        def __init__(self):
            super().__init__("stuck_at_exit")
            self.create_timer(0.02, lambda: None)

        def destroy_node(self):
            time.sleep(3600)  # what a hung DDS teardown looks like from here

    raise SystemExit(run_nodes([Stuck]))
""")


def test_a_take_that_fails_while_the_signal_handler_shuts_the_context_down_is_a_clean_stop():
    """rclpy's signal handler shuts the context down from its own thread: a take can fail just before."""
    context = rclpy.Context()
    rclpy.init(context=context)
    try:
        assert not context_shutting_down(0.1, context)  # a real error: no shutdown under way
        threading.Timer(0.2, context.shutdown).start()
        assert context_shutting_down(1.0, context)
    finally:
        context.try_shutdown()


def test_a_node_whose_teardown_hangs_still_exits_and_says_so(domain_id):
    process = subprocess.Popen([sys.executable, "-c", STUCK_AT_EXIT], env=ros_environment(domain_id=domain_id),
                               stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    time.sleep(3.0)  # up and spinning
    assert process.poll() is None
    process.send_signal(signal.SIGINT)
    _, stderr = process.communicate(timeout=20)
    assert process.returncode == TEARDOWN_EXIT_CODE
    assert "shutdown did not finish within 4 s" in stderr


# Every command that owns node processes stops them on SIGTERM and SIGHUP as on Ctrl-C.

def _node_processes(owner: int) -> dict[int, str]:
    """The node processes started by ``owner``: pid -> start time (with the pid, one process)."""
    found = {}
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
            cmdline = (stat.parent / "cmdline").read_bytes()
        except OSError:
            continue
        if int(fields[1]) == owner and b"auv_dock_guidance.nodes." in cmdline:
            found[int(stat.parent.name)] = fields[19]
    return found


def _alive(processes: dict[int, str]) -> list[int]:
    alive = []
    for pid, started in processes.items():
        try:
            if Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[19] == started:
                alive.append(pid)
        except OSError:
            pass
    return alive


def _as_from_a_terminal() -> None:
    """SIGHUP handled by default even when the tests run under nohup (which the command would respect)."""
    signal.signal(signal.SIGHUP, signal.SIG_DFL)


def _stacks_of(stuck: subprocess.Popen) -> str:
    """Where a command that does not stop is stuck (cli.main registers faulthandler on SIGUSR1)."""
    stuck.send_signal(signal.SIGUSR1)
    time.sleep(1.0)
    stuck.kill()
    try:
        return stuck.communicate(timeout=10)[1][-6000:]
    except subprocess.TimeoutExpired:
        return "(its output pipe is held open by its node processes)"


def _stop_with(command: list[str], sig: signal.Signals, domain_id: int, nodes: int = 3,
               working: Callable[[], bool] = lambda: True) -> tuple[int, str, str]:
    """Start an auv-dock command, wait until its nodes run (and ``working`` holds), send ``sig``: no
    node may be left 5 s later."""
    owner = subprocess.Popen([sys.executable, "-m", "auv_dock_guidance.cli.main", *command,
                              "--domain-id", str(domain_id)], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                             text=True, start_new_session=True,
                             preexec_fn=_as_from_a_terminal)
    try:
        deadline = time.monotonic() + 60.0
        while len(children := _node_processes(owner.pid)) < nodes and time.monotonic() < deadline:
            assert owner.poll() is None, owner.communicate()
            time.sleep(0.2)
        assert len(children) == nodes, f"{command}: nodes did not start"
        time.sleep(3.0)  # spinning, discovered
        while not working() and time.monotonic() < deadline:
            time.sleep(0.2)
        owner.send_signal(sig)
        sent = time.monotonic()
        try:
            owner.wait(timeout=30)  # not its output yet: nodes left running would hold it open
        except subprocess.TimeoutExpired:
            pytest.fail(f"{command}: still running 30 s after {sig.name}; where:\n{_stacks_of(owner)}")
        time.sleep(max(0.0, 5.0 - (time.monotonic() - sent)))
        assert _alive(children) == [], f"{command}: node processes left after {sig.name}: {_alive(children)}"
        out, err = owner.communicate(timeout=30)
    finally:
        if owner.poll() is None:
            owner.kill()
            owner.communicate()
    assert "Traceback" not in err, err
    if sig != signal.SIGKILL:
        assert owner.returncode >= 0, f"{command}: killed by a signal instead of stopping ({owner.returncode})"
    return owner.returncode, out, err


@pytest.fixture(scope="module")
def marker_frames(tmp_path_factory):
    folder = tmp_path_factory.mktemp("frames")
    camera = paper_camera()
    for i in range(4):  # the dock right of and below the image centre: guidance drives
        image, _ = render(camera, SceneSpec(marker_center_m=(1.0, 0.6, 8.0), seed=i))
        cv2.imwrite(str(folder / f"frame_{i:02d}.png"), image)
    return folder


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGKILL], ids=lambda s: s.name)
def test_run_stopped_or_killed_leaves_no_node_and_the_thrusters_neutral(sig, marker_frames, domain_id, tmp_path):
    """SIGTERM: run stops its nodes. SIGKILL (or a crash): the kernel tells its nodes, which stop themselves."""
    config = tmp_path / "params.yaml"
    config.write_text(config_file("dock_guidance.yaml").read_text().replace("arm_on_start: false", "arm_on_start: true")
                      .replace("loop: false", "loop: true").replace("rate_hz: 30.0", "rate_hz: 10.0"))
    with MainControllerSim() as controller:
        code, out, _ = _stop_with(["run", "--config", str(config), "--source", "folder", "--path", str(marker_frames),
                                   "--port", controller.port], sig, domain_id,
                                  working=lambda: any(r.pwm_us != NEUTRAL for r in controller.records()))
        records = controller.records()
    assert any(r.pwm_us != NEUTRAL for r in records), "guidance never drove: nothing to stop"
    assert records[-1].pwm_us == NEUTRAL and controller.applied == NEUTRAL
    if sig == signal.SIGTERM:
        assert code == 0 and "stopping (SIGTERM)" in out and f"--domain-id {domain_id}" in out.splitlines()[1], out
    else:
        assert code == -signal.SIGKILL


@pytest.mark.parametrize(("command", "sig"), [
    (["bench", "--latency", "--seconds", "60"], signal.SIGHUP),
    (["soak", "--minutes", "5", "--json"], signal.SIGTERM),
])
def test_sighup_and_sigterm_stop_bench_and_soak(command, sig, domain_id):
    code, out, err = _stop_with(command, sig, domain_id)
    if command[0] == "soak":
        assert code == 1 and json.loads(out)["stopped_by"] == sig.name  # a partial soak reports and fails
    else:
        assert code == 130 and "interrupted" in err
