import json

from auv_dock_guidance.cli.main import main


def test_link_selftest_reports_round_trip_and_failsafe(capsys):
    assert main(["link-selftest", "--seconds", "0.5", "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["frames_received"] > 0 and report["crc_errors"] == 0
    assert report["roundtrip_ms_p50"] is not None
    assert report["failsafe_ms"] > 0  # neutral reached the controller once commands stopped (the time is a figure)
