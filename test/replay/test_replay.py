"""Replay of the committed fixture bag against its golden output, and bags that are not right."""

from __future__ import annotations

import json
import shutil
import tempfile
from pathlib import Path

import numpy as np
import pytest
from rosbags.rosbag2 import StoragePlugin, Writer
from rosbags.typesys import Stores, get_typestore

from auv_dock_guidance.cli.main import main
from auv_dock_guidance.geometry.camera import CameraModel
from auv_dock_guidance.replay import OUTPUT_TOPICS, BagError, compare, replay
from auv_dock_guidance.sim.scene import SceneSpec, render
from auv_dock_guidance.vision.detector import DetectorConfig

FIXTURES = Path(__file__).resolve().parents[1] / "fixtures"
BAG, GOLDEN = FIXTURES / "approach_bag", FIXTURES / "approach_golden"


def test_fixture_replays_like_its_golden_output(tmp_path, capsys):
    out = tmp_path / "replay"
    assert main(["replay", str(BAG), "--output", str(out), "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["frames"] == 30 and report["detection_rate"] >= 0.9
    assert any("SEARCH -> TRACK" in t for t in report["transitions"])
    assert main(["compare", str(GOLDEN), str(out)]) == 0, capsys.readouterr().out


def test_output_keeps_the_input_topics_beside_the_replay_ones(tmp_path):
    from rosbags.highlevel import AnyReader

    replay(BAG, tmp_path / "out")
    with AnyReader([tmp_path / "out"]) as reader:
        topics = {c.topic for c in reader.connections}
    assert {"/camera/image_raw/compressed", "/replay/dock/target", "/replay/thrusters/command"} <= topics


def test_compare_flags_a_regression(tmp_path):
    replay(BAG, tmp_path / "wider", copy_inputs=False, detector_config=DetectorConfig(marker_radius_m=0.40))
    result = compare(GOLDEN, tmp_path / "wider")
    assert result.range_rel_max > 0.1
    assert any("range" in p for p in result.problems)


def test_missing_or_non_bag_paths_are_refused(tmp_path):
    with pytest.raises(BagError, match="no such bag"):
        replay(tmp_path / "nothing", None)
    junk = tmp_path / "junk.mcap"
    junk.write_bytes(b"not a bag at all" * 10)
    with pytest.raises(BagError, match="cannot open"):
        replay(junk, None)


def test_existing_output_is_never_overwritten(tmp_path):
    (tmp_path / "taken").mkdir()
    with pytest.raises(BagError, match="never writes over"):
        replay(BAG, tmp_path / "taken")


def _cut(bag: Path, folder: Path, share: float, keep_metadata: bool = True) -> tuple[Path, bytes]:
    """A copy of the bag whose data file ends at ``share`` of its size (a power cut), and the original bytes."""
    shutil.copytree(bag, folder)
    data_file = next(p for p in folder.iterdir() if p.suffix in (".mcap", ".db3"))
    original = data_file.read_bytes()
    data_file.write_bytes(original[: int(len(original) * share)])
    if not keep_metadata:
        (folder / "metadata.yaml").unlink()  # rosbag2 may not have written it before the power went
    return data_file, original


def _frames_before(original: bytes, cut_at: int) -> int:
    """Frames of the fixture whose bytes lie wholly before the cut (each JPEG is unique in the file)."""
    from rosbags.highlevel import AnyReader

    with AnyReader([BAG]) as reader:
        images = [c for c in reader.connections if c.msgtype.endswith("CompressedImage")]
        ends = [original.find(bytes(raw)) + len(raw) for _, _, raw in reader.messages(connections=images)]
    return sum(end <= cut_at for end in ends)


@pytest.mark.parametrize("keep_metadata", [True, False])
def test_an_mcap_cut_short_gives_every_frame_before_the_cut(tmp_path, keep_metadata):
    data_file, original = _cut(BAG, tmp_path / "cut", 0.5, keep_metadata)
    summary = replay(tmp_path / "cut", tmp_path / "out")
    intact = _frames_before(original, data_file.stat().st_size)
    assert 10 < intact < 30 and summary.frames == intact and summary.bad_frames == 0
    assert "cut short" in summary.truncated and f"{3 * intact} messages recovered" in summary.truncated
    assert summary.detections >= intact - 1


def test_a_sqlite3_bag_missing_its_last_pages_gives_what_sqlite_can_read(tmp_path):
    from rosbags.highlevel import AnyReader

    sqlite_bag = tmp_path / "sq"
    with AnyReader([BAG]) as reader:
        writer = Writer(sqlite_bag, version=9, storage_plugin=StoragePlugin.SQLITE3)
        writer.open()
        conns = {c.id: writer.add_connection(c.topic, c.msgtype, typestore=reader.typestore)
                 for c in reader.connections}
        for connection, timestamp, raw in reader.messages():
            writer.write(conns[connection.id], timestamp, raw)
        writer.close()
    _cut(sqlite_bag, tmp_path / "cut", 0.6)
    summary = replay(tmp_path / "cut", None)
    assert 5 < summary.frames < 30 and summary.bad_frames == 0
    assert "cut short" in summary.truncated and "header declares" in summary.truncated
    assert not list(Path(tempfile.gettempdir()).glob("auv-dock-salvage-*"))  # its private copy is gone


def test_a_bag_damaged_in_the_middle_says_how_many_frames_were_lost(tmp_path):
    shutil.copytree(BAG, tmp_path / "damaged")
    data_file = next((tmp_path / "damaged").glob("*.mcap"))
    data = bytearray(data_file.read_bytes())
    middle = len(data) // 2
    data[middle: middle + 20_000] = bytes(20_000)
    data_file.write_bytes(bytes(data))
    summary = replay(tmp_path / "damaged", None)
    assert 0 < summary.frames < 30 and summary.frames_lost == 30 - summary.frames
    assert any(f"{summary.frames_lost} of 30 frames could not be read" in p for p in summary.problems())


def test_a_camera_file_of_another_resolution_is_refused_before_any_output(tmp_path):
    camera = tmp_path / "cam.yaml"
    text = (Path(__file__).resolve().parents[2] / "config" / "camera_info.yaml").read_text()
    camera.write_text(text.replace("image_width: 1920", "image_width: 640").replace("image_height: 1080",
                                                                                     "image_height: 480"))
    with pytest.raises(BagError, match=r"cam\.yaml does not fit the frames on /camera/image_raw/compressed"):
        replay(BAG, tmp_path / "out", camera_file=camera)
    assert not (tmp_path / "out").exists()


def test_an_output_that_cannot_be_created_is_named(tmp_path):
    (tmp_path / "file").write_text("a file, not a folder")
    with pytest.raises(BagError, match="cannot create the output bag"):
        replay(BAG, tmp_path / "file" / "out")


def test_compare_refuses_outputs_without_frames(tmp_path):
    writer = Writer(tmp_path / "empty", version=9, storage_plugin=StoragePlugin.MCAP)
    writer.open()
    ts = get_typestore(Stores.ROS2_JAZZY)
    for topic, msgtype in OUTPUT_TOPICS.items():
        writer.add_connection(topic, msgtype, typestore=ts)
    writer.close()
    with pytest.raises(BagError, match="holds no replayed frames"):
        compare(tmp_path / "empty", tmp_path / "empty")


def _bag_with_images(path: Path, encoding: str) -> None:
    ts = get_typestore(Stores.ROS2_JAZZY)
    t = ts.types
    writer = Writer(path, version=9, storage_plugin=StoragePlugin.MCAP)
    writer.open()
    conn = writer.add_connection("/camera/image_raw", "sensor_msgs/msg/Image", typestore=ts)
    for i in range(3):
        header = t["std_msgs/msg/Header"](stamp=t["builtin_interfaces/msg/Time"](sec=i, nanosec=0), frame_id="cam")
        msg = t["sensor_msgs/msg/Image"](header=header, height=4, width=4, encoding=encoding, is_bigendian=0,
                                         step=8, data=np.zeros(32, np.uint8))
        writer.write(conn, i * 10**9, ts.serialize_cdr(msg, "sensor_msgs/msg/Image"))
    writer.close()


def test_bag_without_camera_info_needs_a_camera_file(tmp_path):
    _bag_with_images(tmp_path / "bag", "16UC1")
    with pytest.raises(BagError, match="--camera-info"):
        replay(tmp_path / "bag", None)


def test_wrong_image_encoding_is_counted_not_fatal(tmp_path):
    _bag_with_images(tmp_path / "bag", "32FC1")  # a float image: no camera of ours
    camera = tmp_path / "cam.yaml"
    camera.write_text((Path(__file__).resolve().parents[2] / "config" / "camera_info.yaml").read_text())
    summary = replay(tmp_path / "bag", None, camera_file=camera)
    assert summary.frames == 3 and summary.bad_frames == 3
    assert "encoding" in summary.damage


def test_bag_without_a_camera_topic_names_what_it_has(tmp_path):
    ts = get_typestore(Stores.ROS2_JAZZY)
    writer = Writer(tmp_path / "bag", version=9, storage_plugin=StoragePlugin.MCAP)
    writer.open()
    conn = writer.add_connection("/chatter", "std_msgs/msg/String", typestore=ts)
    writer.write(conn, 1, ts.serialize_cdr(ts.types["std_msgs/msg/String"](data="hi"), "std_msgs/msg/String"))
    writer.close()
    with pytest.raises(BagError, match="/chatter"):
        replay(tmp_path / "bag", None)



def _ros1_recording(path: Path, calibrated: CameraModel, frame_camera: CameraModel, frames: int) -> None:
    """A ROS 1 bag as a real-water recording may come: frames recorded at half the calibrated
    resolution with unset stamps, the camera's info, and another camera's info beside it."""
    from rosbags.rosbag1 import Writer as Ros1Writer

    ts = get_typestore(Stores.ROS1_NOETIC)
    t = ts.types
    unset = t["std_msgs/msg/Header"](seq=0, stamp=t["builtin_interfaces/msg/Time"](sec=0, nanosec=0), frame_id="cam")

    def info(camera: CameraModel) -> bytes:
        roi = t["sensor_msgs/msg/RegionOfInterest"](x_offset=0, y_offset=0, height=0, width=0, do_rectify=False)
        msg = t["sensor_msgs/msg/CameraInfo"](
            header=unset, height=camera.height, width=camera.width, distortion_model="plumb_bob",
            D=np.array(camera.distortion), K=camera.matrix.ravel(), R=np.eye(3).ravel(), P=np.zeros(12),
            binning_x=0, binning_y=0, roi=roi)
        return ts.serialize_ros1(msg, "sensor_msgs/msg/CameraInfo")

    other_camera = CameraModel(640, 480, 500.0, 500.0, 320.0, 240.0)
    with Ros1Writer(path) as writer:
        image = writer.add_connection("/cam/image_raw", "sensor_msgs/msg/Image", typestore=ts)
        ours = writer.add_connection("/cam/camera_info", "sensor_msgs/msg/CameraInfo", typestore=ts)
        other = writer.add_connection("/other/camera_info", "sensor_msgs/msg/CameraInfo", typestore=ts)
        for i in range(frames):
            when = 1000 * 10**9 + i * 10**8  # 10 frames a second
            writer.write(other, when, info(other_camera))
            writer.write(ours, when, info(calibrated))
            scene = SceneSpec(marker_center_m=(0.3, 0.1, 7.0 - 0.1 * i), brightness=3.0, seed=i)
            frame, _ = render(frame_camera, scene)
            msg = t["sensor_msgs/msg/Image"](header=unset, height=frame_camera.height, width=frame_camera.width,
                                             encoding="bgr8", is_bigendian=0, step=3 * frame_camera.width,
                                             data=frame.reshape(-1))
            writer.write(image, when, ts.serialize_ros1(msg, "sensor_msgs/msg/Image"))


def test_a_ros1_recording_with_unset_stamps_and_two_cameras_replays(tmp_path, camera):
    from rosbags.highlevel import AnyReader

    calibrated = camera.scaled(0.25)
    _ros1_recording(tmp_path / "run.bag", calibrated, calibrated.scaled(0.5), frames=8)
    summary = replay(tmp_path / "run.bag", tmp_path / "out")
    assert summary.frames == 8 and summary.bad_frames == 0 and summary.damage is None
    assert summary.detections >= 6  # with the info beside the image topic, scaled to the frames
    assert summary.notes == ["images are 240x135, the camera model 480x270: model scaled by 0.5"]
    assert any("SEARCH -> TRACK" in t for t in summary.transitions)  # timed by the bag: stamps move on
    with AnyReader([tmp_path / "out"]) as reader:  # the inputs were copied as CDR, readable again
        infos = [c for c in reader.connections if c.topic == "/cam/camera_info"]
        first = next(reader.messages(connections=infos))
        assert reader.deserialize(first[2], first[0].msgtype).width == 480
