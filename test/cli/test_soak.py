import json

from auv_dock_guidance.cli.main import main


def test_short_soak_survives_every_injected_fault(capsys):
    code = main(["soak", "--minutes", "1.1", "--fault-every", "8", "--json"])
    report = json.loads(capsys.readouterr().out)
    assert report["faults_injected"] >= 3, report
    assert report["faults_survived"] == report["faults_injected"], report
    assert report["deadline_misses"] == 0, report
    assert report["frames"] > 500
    assert code == 0
