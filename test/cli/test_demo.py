"""The README's main job, end to end: four node processes docking a simulated vehicle, watched
live from another terminal with the command the demo prints."""

import json
import shlex
import signal
import subprocess
import sys
import threading

from PIL import Image


def test_demo_docks_writes_its_report_and_the_printed_monitor_command_watches_it(tmp_path, monkeypatch):
    monkeypatch.setenv("XDG_RUNTIME_DIR", str(tmp_path))  # its own registry of running systems
    report = tmp_path / "report"
    demo = subprocess.Popen([sys.executable, "-m", "auv_dock_guidance.cli.main", "demo", "--report", str(report)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        first = demo.stdout.readline()
        assert first.startswith("ROS domain "), first
        domain = int(first.split()[2].rstrip(";"))
        watch = demo.stdout.readline().strip()
        assert watch.endswith(f"monitor --domain-id {domain}"), watch
        assert demo.stdout.readline().strip().endswith(f"foxglove --domain-id {domain}")
        monitor = subprocess.Popen(shlex.split(watch), stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        seen: list[str] = []
        reader = threading.Thread(target=lambda: seen.extend(monitor.stdout), daemon=True)
        reader.start()
        out, err = demo.communicate(timeout=240)
    finally:
        if demo.poll() is None:
            demo.kill()
    monitor.send_signal(signal.SIGTERM)
    monitor.wait(timeout=20)
    reader.join(timeout=5)
    assert demo.returncode == 0, out + err
    assert "docked in" in out
    states = [line.split("guidance state: ")[1].strip() for line in seen if "guidance state: " in line]
    assert {"TRACK", "TERMINAL"} <= set(states), seen  # it changed, live
    assert states.index("TRACK") < states.index("TERMINAL"), seen
    assert monitor.returncode == 0 and "Traceback" not in monitor.stderr.read()
    summary = json.loads((report / "summary.json").read_text())
    assert summary["ros_domain_id"] == domain
    assert summary["docked"] and summary["entry_lateral_error_m"] < 0.23
    assert summary["messages"]["/thrusters/command"] > 100
    assert summary["messages"]["/dock/debug_image/compressed"] > 0
    assert all(code == 0 for code in summary["node_exit_codes"].values())
    for name in ("trajectories_top.png", "trajectories_side.png", "bearing_errors.png", "camera_strip.png"):
        assert (report / name).stat().st_size > 1000
    with Image.open(report / "approach.gif") as animation:
        assert animation.n_frames > 20  # the overlay, twice a second, over the whole approach
    assert str(report / "camera_strip.png") in summary["plots"]
    assert any((report / "debug_bag").glob("*.mcap"))
