import json

import auv_dock_guidance.cli.soak as soak
from auv_dock_guidance.cli.main import main
from auv_dock_guidance.cli.soak import FAULTS, judge_abort


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


FRAMES_30HZ = [i / 30 for i in range(300)]  # 10 s of frames


def test_an_abort_for_a_camera_the_soak_saw_silent_too_is_a_camera_gap_not_a_wrong_reaction():
    starved = [t for t in FRAMES_30HZ if not 5.0 < t < 6.3]  # the vision process got no CPU for 1.3 s
    outcome = judge_abort("line_noise", 6.1, "TRACK -> ABORT: no camera frame for 1.0 s", starved)
    assert outcome.wrong is None and "1.1 s" in outcome.camera_gap


def test_an_abort_while_frames_flowed_is_a_wrong_reaction():
    flowing = judge_abort("line_noise", 6.1, "TRACK -> ABORT: no camera frame for 1.0 s", FRAMES_30HZ)
    assert flowing.camera_gap is None and "0.03 s apart" in flowing.wrong
    other = judge_abort("line_noise", 6.1, "TRACK -> ABORT: telemetry from the main controller is stale or invalid",
                        [t for t in FRAMES_30HZ if not 5.0 < t < 6.3])
    assert other.camera_gap is None and other.wrong.startswith("line_noise: TRACK -> ABORT: telemetry")


class _StatesAfterFault:
    """Stands in for the simulated system: each spin delivers the next state guidance publishes."""

    def __init__(self, states: list[str], seen: set[str]) -> None:
        self.states, self.seen = list(states), seen
        self.group = self

    def spin(self, seconds: float) -> None:
        if self.states:
            self.seen.add(self.states.pop(0))

    def exited(self) -> dict[str, int]:
        return {}


def test_a_restarted_guidance_already_in_retry_has_recovered_but_one_still_searching_has_not(monkeypatch):
    monkeypatch.setattr(soak, "RECOVERY_S", 0.5)
    seen = {"TRACK"}  # the killed guidance's last word: cleared, it does not count
    assert soak._recovered(_StatesAfterFault(["SEARCH", "RETRY"], seen), seen)  # TRACK came and went unseen
    seen = {"TRACK"}
    assert not soak._recovered(_StatesAfterFault(["SEARCH", "SEARCH"], seen), seen)
