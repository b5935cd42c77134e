import json

from auv_dock_guidance.cli.main import main
from auv_dock_guidance.cli.soak import FAULTS


def test_short_soak_survives_every_kind_of_fault(capsys):
    code = main(["soak", "--minutes", "1.5", "--fault-every", "3", "--json"])
    report = json.loads(capsys.readouterr().out)
    assert set(report["faults"]) == {f.name for f in FAULTS}, report  # every kind at least once
    assert report["faults_survived"] == report["faults_injected"], report["not_survived"]
    assert report["wrong_reactions"] == [], report
    # measured, not bounded here: the deadlines are figures of `auv-dock soak --minutes 30`
    assert set(report["worst_reaction_ms"]) >= {"guidance_killed", "detector_killed", "camera_stalled"}, report
    # frames flowed through every fault: each recovery is guidance tracking again on fresh detections
    # (how many frames a busy machine gets through in 1.5 minutes is a figure, not a behaviour)
    assert report["frames"] > 0 and report["node_exit_codes"] == {"vision_pipeline": 0, "guidance": 0,
                                                                  "serial_bridge": 0}
    assert code in (0, 1) and (code == 0) == (report["deadline_misses"] == 0)
