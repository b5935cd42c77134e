import json

from auv_dock_guidance.cli import bench


def test_detector_bench_reports_every_mode_on_the_same_frames():
    report = bench.detector_bench(4)
    for mode in ("baseline", "full_frame", "tracking"):
        assert report[f"{mode}_fps"] > 0 and report[f"{mode}_ms_p95"] >= report[f"{mode}_ms_p50"]
    assert report["full_frame_detection_rate"] == 1.0
    json.dumps(report)
