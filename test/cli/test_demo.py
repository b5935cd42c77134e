"""The README's main job, end to end: four node processes docking a simulated vehicle."""

import json

from PIL import Image

from auv_dock_guidance.cli.main import main


def test_demo_docks_and_writes_its_report(tmp_path, capsys):
    report = tmp_path / "report"
    assert main(["demo", "--report", str(report)]) == 0
    out = capsys.readouterr().out
    assert "docked in" in out
    summary = json.loads((report / "summary.json").read_text())
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
