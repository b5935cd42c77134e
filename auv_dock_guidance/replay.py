"""Offline replay of recorded runs: the detector and guidance over a ROS 2 bag, no ROS needed.

Reads the camera topic (sensor_msgs/Image or CompressedImage), camera info from the bag
(the one beside the image topic) or a file, and the vehicle's attitude (sensor_msgs/Imu)
when recorded; runs the detector and guidance deterministically, as fast as possible, in
message-time order; writes their outputs under ``/replay/...`` into a new MCAP bag, with
the input topics copied beside them unless asked not to. ROS 2 bags (MCAP, sqlite3) and
ROS 1 bags are read. A damaged bag is processed up to the damage and the damage
reported; frames that cannot be decoded are counted and skipped; frames without a stamp
are timed by the bag.
"""

from __future__ import annotations

import math
import sqlite3
import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np
from rosbags.highlevel import AnyReader
from rosbags.rosbag2 import StoragePlugin, Writer, WriterError
from rosbags.typesys import Stores, get_typestore

from auv_dock_guidance.control.cascade import Attitude, Target
from auv_dock_guidance.control.guidance import Guidance, GuidanceConfig, State
from auv_dock_guidance.errors import CameraModelError, DockGuidanceError
from auv_dock_guidance.geometry.camera import ApproximateLens, CameraModel
from auv_dock_guidance.geometry.rotations import navigation_attitude, navigation_yaw_rate
from auv_dock_guidance.salvage import SalvagedBag
from auv_dock_guidance.vision.detector import Detector, DetectorConfig
from auv_dock_guidance.vision.image_input import decode_compressed, image_from_fields

IMAGE_TYPES = ("sensor_msgs/msg/Image", "sensor_msgs/msg/CompressedImage")
OUTPUT_TOPICS = {
    "/replay/dock/target": "geometry_msgs/msg/PointStamped",
    "/replay/dock/center_px": "geometry_msgs/msg/PointStamped",  # x u, y v, z radius (pixels)
    "/replay/dock/detected": "std_msgs/msg/Bool",
    "/replay/guidance/state": "std_msgs/msg/String",
    "/replay/thrusters/command": "std_msgs/msg/UInt16MultiArray",
}


class BagError(DockGuidanceError):
    """A bag that cannot be replayed (missing, no camera topic, no camera model...)."""


@dataclass
class ReplaySummary:
    frames: int = 0
    detections: int = 0
    bad_frames: int = 0
    transitions: list[str] = field(default_factory=list)
    command_min_us: list[int] = field(default_factory=lambda: [65535] * 4)
    command_max_us: list[int] = field(default_factory=lambda: [0] * 4)
    seconds: float = 0.0
    damage: str | None = None  # the first problem met, with the frame it came at
    truncated: str | None = None  # the bag was cut short: what could be recovered
    frames_expected: int | None = None  # as the bag's index counts them (None: no index)
    skipped_topics: list[str] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)  # what was adapted (a scaled camera model...)
    output: str | None = None

    @property
    def frames_lost(self) -> int:
        """Frames the index promised that could not be read (damage, a cut)."""
        return max(0, self.frames_expected - self.frames) if self.frames_expected is not None else 0

    @property
    def processed(self) -> int:
        return self.frames - self.bad_frames

    def problems(self) -> list[str]:
        """What a person must know about the data: damage, what was lost, what was refused."""
        lines = [text for text in (self.truncated, self.damage) if text]
        if self.frames_lost:
            lines.append(f"{self.frames_lost} of {self.frames_expected} frames could not be read "
                         f"(the bag is damaged or cut after frame {self.frames})")
        if self.bad_frames:
            lines.append(f"{self.bad_frames} of {self.frames} frames read were rejected")
        return lines

    def as_dict(self) -> dict[str, Any]:
        return {
            "frames": self.frames,
            "detections": self.detections,
            "detection_rate": self.detections / self.frames if self.frames else 0.0,
            "bad_frames": self.bad_frames,
            "frames_expected": self.frames_expected,
            "frames_lost": self.frames_lost,
            "fps": self.frames / self.seconds if self.seconds > 0 else None,
            "transitions": self.transitions,
            "command_range_us": [[lo, hi] for lo, hi in zip(self.command_min_us, self.command_max_us, strict=True)]
            if self.processed else None,
            "damage": self.damage,
            "truncated": self.truncated,
            "problems": self.problems(),
            "skipped_topics": self.skipped_topics,
            "notes": self.notes,
            "output": self.output,
        }


def _pick_image_topic(reader: AnyReader, wanted: str | None) -> Any:
    images = [c for c in reader.connections if c.msgtype in IMAGE_TYPES]
    if wanted:
        images = [c for c in images if c.topic == wanted or c.topic.lstrip("/") == wanted.lstrip("/")]
    if not images:
        topics = ", ".join(f"{c.topic} ({c.msgtype})" for c in reader.connections) or "none"
        raise BagError(f"no camera topic (sensor_msgs/Image or CompressedImage){' named ' + wanted if wanted else ''}"
                       f" in the bag; it has: {topics}")
    # Prefer the raw image when both are recorded: no JPEG loss.
    images.sort(key=lambda c: (c.msgtype != "sensor_msgs/msg/Image", c.topic))
    return images[0]


def _camera_info_topics(reader: AnyReader, image_topic: str) -> list:
    """The camera_info connections beside the image topic (the longest shared namespace)."""
    infos = [c for c in reader.connections if c.msgtype == "sensor_msgs/msg/CameraInfo"]
    image = image_topic.strip("/").split("/")

    def shared(topic: str) -> int:
        namespace = topic.strip("/").split("/")[:-1]
        differ = (i for i, (a, b) in enumerate(zip(namespace, image, strict=False)) if a != b)
        return next(differ, min(len(namespace), len(image)))

    best = max((shared(c.topic) for c in infos), default=0)
    return [c for c in infos if shared(c.topic) == best]


def _input_copies(reader: AnyReader, writer: Writer, typestore: Any, summary: ReplaySummary) -> dict[int, Any]:
    """Output connections for the input topics, by input connection id (one per topic and type).

    ROS 1 messages are copied as their ROS 2 types (the same layout but for the header's
    seq, which the conversion drops); a topic whose type cannot be written is left out and
    named in the summary.
    """
    store = reader.typestore if reader.is2 else typestore
    by_topic: dict[tuple[str, str], Any] = {}
    copies: dict[int, Any] = {}
    for c in reader.connections:
        key = (c.topic, c.msgtype)
        if key not in by_topic:
            try:
                by_topic[key] = writer.add_connection(c.topic, c.msgtype, typestore=store)
            except Exception:  # a type rosbags cannot describe or ROS 2 does not have
                summary.skipped_topics.append(c.topic)
                continue
        copies[c.id] = by_topic[key]
    return copies


def _camera_from_info(msg: Any) -> CameraModel:
    """A camera model from a CameraInfo of ROS 2 (fields k, d) or ROS 1 (K, D)."""
    k, d = (msg.k, msg.d) if hasattr(msg, "k") else (msg.K, msg.D)
    return CameraModel.from_camera_info(msg.width, msg.height, k, d, msg.distortion_model or "plumb_bob")


def replay(
    bag: Path,
    output: Path | None,
    camera_file: Path | None = None,
    image_topic: str | None = None,
    copy_inputs: bool = True,
    detector_config: DetectorConfig = DetectorConfig(),
    guidance_config: GuidanceConfig = GuidanceConfig(),
    progress: Callable[[int, int], None] | None = None,
    lens: ApproximateLens | None = None,
) -> ReplaySummary:
    """``lens``: an approximate camera for a bag recorded without calibration (camera_info ignored)."""
    if not bag.exists():
        raise BagError(f"{bag}: no such bag")
    if output is not None and output.exists():
        raise BagError(f"{output} exists; replay never writes over a bag")
    camera = CameraModel.from_yaml(camera_file) if camera_file else None
    summary = ReplaySummary(output=str(output) if output else None)
    reader, summary.truncated = _open_bag(bag)
    writer = None
    try:
        picked = _pick_image_topic(reader, image_topic)
        image_ids = {c.id for c in reader.connections if (c.topic, c.msgtype) == (picked.topic, picked.msgtype)}
        info_conns = _camera_info_topics(reader, picked.topic)
        imu_conns = [c for c in reader.connections if c.msgtype == "sensor_msgs/msg/Imu"]
        if lens is not None:
            info_conns = []
        if camera is None and lens is None and not info_conns:
            raise BagError("the bag has no sensor_msgs/CameraInfo; give the camera with --camera-info")
        info_ids, imu_ids = {c.id for c in info_conns}, {c.id for c in imu_conns}
        needed = image_ids | info_ids | imu_ids
        if camera is None and lens is None:
            camera = _first_camera(reader, info_conns)
        if camera is not None:
            _check_frame_size(reader, image_ids, camera, str(camera_file) if camera_file else "the bag's camera_info")
        typestore = get_typestore(Stores.ROS2_JAZZY)
        copies: dict[int, Any] = {}
        if output is not None:
            writer = _new_bag(output)
            outputs = {t: writer.add_connection(t, m, typestore=typestore) for t, m in OUTPUT_TOPICS.items()}
            if copy_inputs:
                copies = _input_copies(reader, writer, typestore, summary)
        calibrated = camera  # the detector's model may be scaled to the frames
        detector = Detector(camera, detector_config, lens=lens)
        guidance = Guidance(guidance_config)
        attitude: Attitude | None = None
        messages = reader.messages(connections=[c for c in reader.connections if c.id in needed or c.id in copies])
        total = sum(c.msgcount for c in reader.connections if c.id in image_ids)
        summary.frames_expected = None if summary.truncated else total
        start = time.perf_counter()
        while True:
            try:
                connection, timestamp, raw = next(messages)
            except StopIteration:
                break
            except Exception as exc:  # truncated or corrupt data: keep what came before
                summary.damage = f"bag damaged after {summary.frames} frames: {exc.__class__.__name__}: {exc}"
                break
            if writer is not None and connection.id in copies:
                writer.write(copies[connection.id], timestamp,
                             raw if reader.is2 else typestore.ros1_to_cdr(raw, connection.msgtype))
            try:
                msg: Any = reader.deserialize(raw, connection.msgtype)
            except Exception as exc:
                summary.damage = f"undecodable {connection.topic} message after {summary.frames} frames: {exc}"
                continue
            if connection.id in info_ids:
                if camera_file is None:
                    try:
                        model = _camera_from_info(msg)
                    except CameraModelError as exc:
                        summary.damage = f"camera_info rejected: {exc}"
                        continue
                    if model != calibrated:
                        calibrated = detector.camera = model
                continue
            if connection.id in imu_ids:
                q = msg.orientation
                roll, pitch, yaw = navigation_attitude(q.x, q.y, q.z, q.w)
                yaw_rate = navigation_yaw_rate(msg.angular_velocity.z, msg.angular_velocity_covariance[0])
                attitude = Attitude(_stamp(msg.header.stamp), roll, pitch, yaw, 0.0, yaw_rate)
                continue
            if connection.id not in image_ids:
                continue
            stamp = _stamp(msg.header.stamp) or timestamp * 1e-9  # an unstamped camera: the bag's time
            summary.frames += 1
            if progress is not None:
                progress(summary.frames, total)
            try:
                frame = _decode(msg, connection)
                if detector.camera is None and detector.lens is None:
                    raise DockGuidanceError("no camera_info before the first frame")
                note = detector.fit_camera(frame.shape[1], frame.shape[0])
                if note is not None and note not in summary.notes:
                    summary.notes.append(note)
                detection = detector.detect(frame)
            except DockGuidanceError as exc:
                summary.bad_frames += 1
                summary.damage = summary.damage or f"frame {summary.frames} rejected: {exc}"
                continue
            # Without recorded navigation, a level vehicle holding its heading stands in.
            nav = attitude if attitude is not None else Attitude(stamp, 0.0, 0.0, 0.0)
            nav = replace(nav, stamp_s=stamp)
            target = None
            pose = detection.pose
            guidance.frame_processed(stamp)
            if detection.found and pose is not None:
                summary.detections += 1
                target = Target(stamp, pose.range_m, pose.offset_x_m, pose.offset_y_m)
            else:
                guidance.marker_missed()
            out = guidance.update(stamp, target, nav)
            if out.transition is not None:
                t = out.transition
                summary.transitions.append(f"{t.time_s:.3f}: {t.previous.value} -> {t.state.value}: {t.reason}")
            for i, p in enumerate(out.command.pwm_us):
                summary.command_min_us[i] = min(summary.command_min_us[i], p)
                summary.command_max_us[i] = max(summary.command_max_us[i], p)
            if writer is not None:
                _write_outputs(writer, outputs, typestore, timestamp, msg.header, detection, out.state,
                               out.command.pwm_us)
        summary.seconds = time.perf_counter() - start
    finally:
        if writer is not None:
            writer.close()
        reader.close()
    return summary


def _open_bag(bag: Path) -> tuple[Any, str | None]:
    """rosbags' reader; for a bag it cannot open (cut short: no footer, no metadata.yaml) what can
    be salvaged from its data file, with an account of what was lost."""
    try:
        reader = AnyReader([bag])
        reader.open()
        return reader, None
    except Exception as exc:  # rosbags raises many kinds for unreadable files
        problem = exc
    data = _data_file(bag)
    if data is not None and data != bag:  # a bag folder whose metadata.yaml is missing or wrong
        try:
            reader = AnyReader([data])
            reader.open()
            return reader, None
        except Exception:
            pass
    if data is not None:
        try:
            salvaged = SalvagedBag(data)
        except (OSError, ValueError, sqlite3.Error):
            salvaged = None
        if salvaged is not None:
            if any(c.msgcount for c in salvaged.connections):
                return salvaged, salvaged.account
            salvaged.close()
    raise BagError(f"{bag}: cannot open as a ROS bag (ROS 2 folder, .mcap or .db3; ROS 1 .bag): {problem}")


def _data_file(bag: Path) -> Path | None:
    """The one .mcap or .db3 file of a bag (the file itself, or alone in the bag's folder)."""
    if bag.is_file():
        return bag if bag.suffix in (".mcap", ".db3") else None
    files = [p for p in bag.iterdir() if p.suffix in (".mcap", ".db3")] if bag.is_dir() else []
    return files[0] if len(files) == 1 else None


def _new_bag(output: Path) -> Writer:
    """An open writer for the output bag, or a BagError that names it."""
    writer = Writer(output, version=9, storage_plugin=StoragePlugin.MCAP)
    try:
        writer.open()
    except (OSError, WriterError) as exc:
        raise BagError(f"cannot create the output bag {output}: {getattr(exc, 'strerror', None) or exc}") from exc
    return writer


def _check_frame_size(reader: Any, image_ids: set[int], camera: CameraModel, source: str) -> None:
    """Refuse before any work a camera model the bag's frames cannot come from (another resolution,
    not a uniform resize): every frame would be rejected. Frames that cannot be decoded are left to the
    replay, which counts them."""
    for checked, (connection, _, raw) in enumerate(reader.messages(connections=[
            c for c in reader.connections if c.id in image_ids])):
        if checked == 5:
            return
        try:
            msg: Any = reader.deserialize(raw, connection.msgtype)
            height, width = _decode(msg, connection).shape[:2]
        except Exception:  # undecodable or damaged: the replay counts and reports it
            continue
        try:
            camera.for_image(width, height)
        except CameraModelError as exc:
            raise BagError(f"{source} does not fit the frames on {connection.topic}: {exc}") from exc
        return


def _decode(msg: Any, connection: Any) -> np.ndarray:
    """The frame of an Image or CompressedImage message."""
    if connection.msgtype.endswith("CompressedImage"):
        return decode_compressed(msg.data, connection.topic)
    return image_from_fields(msg.height, msg.width, msg.encoding, msg.step, msg.data, bool(msg.is_bigendian))


def _first_camera(reader: AnyReader, info_conns: list) -> CameraModel:
    """The camera from the bag's first usable camera_info (it may be recorded after the first frame)."""
    problem = "no camera_info message"
    try:
        for connection, _, raw in reader.messages(connections=info_conns):
            msg: Any = reader.deserialize(raw, connection.msgtype)
            try:
                return _camera_from_info(msg)
            except CameraModelError as exc:
                problem = str(exc)
    except Exception as exc:
        problem = f"camera_info unreadable ({exc})"
    raise BagError(f"the bag's camera_info cannot be used ({problem}); give the camera with --camera-info")


def _stamp(stamp: Any) -> float:
    return stamp.sec + stamp.nanosec * 1e-9


def _write_outputs(writer: Writer, outputs: dict, typestore: Any, timestamp: int, header: Any, detection: Any,
                   state: State, pwm: tuple[int, int, int, int]) -> None:
    t = typestore.types
    header_out = t["std_msgs/msg/Header"](stamp=t["builtin_interfaces/msg/Time"](
        sec=header.stamp.sec, nanosec=header.stamp.nanosec), frame_id=header.frame_id)

    def put(topic: str, message: Any) -> None:
        writer.write(outputs[topic], timestamp, typestore.serialize_cdr(message, OUTPUT_TOPICS[topic]))

    point = t["geometry_msgs/msg/Point"]
    stamped = t["geometry_msgs/msg/PointStamped"]
    if detection.found and detection.pose is not None:
        p = detection.pose
        put("/replay/dock/target", stamped(header=header_out, point=point(x=p.offset_x_m, y=p.offset_y_m, z=p.range_m)))
        put("/replay/dock/center_px", stamped(header=header_out, point=point(
            x=float(detection.u), y=float(detection.v), z=float(detection.radius_px))))
    put("/replay/dock/detected", t["std_msgs/msg/Bool"](data=bool(detection.found)))
    put("/replay/guidance/state", t["std_msgs/msg/String"](data=state.value))
    layout = t["std_msgs/msg/MultiArrayLayout"](dim=[], data_offset=0)
    put("/replay/thrusters/command", t["std_msgs/msg/UInt16MultiArray"](
        layout=layout, data=np.array(pwm, dtype=np.uint16)))


@dataclass
class Comparison:
    frames_a: int
    frames_b: int
    matched: int
    center_px_max: float
    range_rel_max: float
    command_us_max: int
    detection_mismatches: int
    problems: list[str]


def _outputs_by_time(bag: Path) -> dict[str, dict[int, Any]]:
    """Replay outputs per topic, keyed by the bag time of the camera frame they came from."""
    if not bag.exists():
        raise BagError(f"{bag}: no such bag")
    found: dict[str, dict[int, Any]] = {t: {} for t in OUTPUT_TOPICS}
    try:
        with AnyReader([bag]) as reader:
            conns = [c for c in reader.connections if c.topic in OUTPUT_TOPICS]
            if not conns:
                raise BagError(f"{bag} holds no /replay/ topics: is it the output of auv-dock replay?")
            for connection, timestamp, raw in reader.messages(connections=conns):
                found[connection.topic][timestamp] = reader.deserialize(raw, connection.msgtype)
    except BagError:
        raise
    except Exception as exc:
        raise BagError(f"{bag}: cannot read ({exc})") from exc
    if not found["/replay/dock/detected"]:
        raise BagError(f"{bag} holds no replayed frames (its /replay/dock/detected is empty): nothing to compare")
    return found


def compare(a: Path, b: Path, center_px: float = 1.0, range_pct: float = 2.0, command_us: int = 10) -> Comparison:
    """Two replay outputs frame by frame: detections, centre, range and thruster command."""
    oa, ob = _outputs_by_time(a), _outputs_by_time(b)
    problems: list[str] = []
    da, db = oa["/replay/dock/detected"], ob["/replay/dock/detected"]
    keys = sorted(set(da) & set(db))
    mismatches = [k for k in keys if da[k].data != db[k].data]
    for k in mismatches[:5]:
        problems.append(f"t={k * 1e-9:.3f}: detected {da[k].data} vs {db[k].data}")
    centre_max = range_max = 0.0
    for k in sorted(set(oa["/replay/dock/center_px"]) & set(ob["/replay/dock/center_px"])):
        pa, pb = oa["/replay/dock/center_px"][k].point, ob["/replay/dock/center_px"][k].point
        d = math.hypot(pa.x - pb.x, pa.y - pb.y)
        centre_max = max(centre_max, d)
        if d > center_px and len(problems) < 20:
            problems.append(f"t={k * 1e-9:.3f}: centre differs by {d:.2f} px")
    for k in sorted(set(oa["/replay/dock/target"]) & set(ob["/replay/dock/target"])):
        ra, rb = oa["/replay/dock/target"][k].point.z, ob["/replay/dock/target"][k].point.z
        rel = abs(ra - rb) / max(abs(ra), 1e-9)
        range_max = max(range_max, rel)
        if 100 * rel > range_pct and len(problems) < 20:
            problems.append(f"t={k * 1e-9:.3f}: range {ra:.3f} vs {rb:.3f} m")
    command_max = 0
    ca, cb = oa["/replay/thrusters/command"], ob["/replay/thrusters/command"]
    for k in sorted(set(ca) & set(cb)):
        diff = int(np.max(np.abs(ca[k].data.astype(int) - cb[k].data.astype(int))))
        command_max = max(command_max, diff)
        if diff > command_us and len(problems) < 20:
            problems.append(f"t={k * 1e-9:.3f}: thruster command differs by {diff} us")
    if len(da) != len(db):
        problems.append(f"frame counts differ: {len(da)} vs {len(db)}")
    return Comparison(len(da), len(db), len(keys), centre_max, range_max, command_max, len(mismatches), problems)
