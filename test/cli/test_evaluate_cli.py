"""`auv-dock evaluate --population`: the real-dock population beside the paper's."""

import json

import pytest

from auv_dock_guidance.cli.main import main


def test_real_dock_population_reports_whole_cut_and_corner_figures(capsys):
    assert main(["evaluate", "--population", "real-dock", "--frames", "4", "--workers", "1", "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["population"] == "real-dock" and report["frames"] == 4
    for key in ("detection_rate_whole", "detection_rate_cut", "detection_rate_corner", "range_error_rel_p95_whole",
                "range_error_rel_p95_cut", "false_positives", "corner_frames"):
        assert key in report


@pytest.mark.parametrize("option", [["--plain"], ["--range-sweep"], ["--camera-info", "camera.yaml"]])
def test_options_of_the_paper_population_are_refused_with_real_dock(option, capsys):
    with pytest.raises(SystemExit) as info:
        main(["evaluate", "--population", "real-dock", "--frames", "2", *option])
    assert info.value.code == 2
    err = capsys.readouterr().err
    assert option[0] in err and "paper population" in err and "\n" == err[-1] and err.count("\n") == 1


def test_text_report_shows_cut_rings_and_corners_only_where_there_are_any(capsys):
    assert main(["evaluate", "--population", "real-dock", "--frames", "12", "--seed", "2", "--workers", "1"]) == 0
    text = capsys.readouterr().out
    assert "cut by the frame" in text and "corners found" in text and "cut ring" in text
    assert main(["evaluate", "--frames", "2", "--workers", "1"]) == 0
    text = capsys.readouterr().out
    assert "with the marker" in text and "corners" not in text and "cut" not in text
