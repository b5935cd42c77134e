"""The paper's pool (or open water) as a world: where the dock, the surface and the vehicle's camera are.

World frame: x along the pool towards the dock, y to the left, z up; the water surface
is z = 0. In the pool the dock's entrance faces -x; in open water its axis may point in
any horizontal direction (``dock_axis_yaw_rad``, the direction a vehicle travels to
enter, counter-clockwise from +x) and there are no walls. The vehicle's attitude is
given as its navigation reports it (pitch nose up +, yaw to starboard +); its camera
sits on the nose looking forward (optical frame: x right, y down, z forward).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from auv_dock_guidance.sim.scene import SceneSpec


@dataclass(frozen=True)
class VehiclePose:
    x: float
    y: float
    z: float
    roll: float = 0.0
    pitch: float = 0.0
    yaw: float = 0.0

    def body_to_world(self) -> np.ndarray:
        """Rotation of body (x forward, y left, z up) into world axes."""
        return _rz(-self.yaw) @ _ry(-self.pitch) @ _rx(self.roll)


HULL_RADIUS_M = 0.12  # the simulated vehicle's


@dataclass(frozen=True)
class PoolWorld:
    length_m: float = 30.0
    width_m: float = 5.0
    depth_m: float = 5.0
    dock_x_m: float = 28.0
    dock_depth_m: float = 2.0
    entrance_radius_m: float = 0.35
    camera_offset_m: float = 0.9  # camera ahead of the vehicle's reference point (the nose)
    reflection: bool = False
    scene: SceneSpec = SceneSpec()  # LED, water and sensor properties; geometry is set per frame
    dock_axis_yaw_rad: float = 0.0  # direction of travel into the dock (world, counter-clockwise from +x)
    walls: bool = True  # the pool's side walls, floor and surface bound the vehicle; open water: surface only

    @property
    def dock_center(self) -> np.ndarray:
        return np.array([self.dock_x_m, 0.0, -self.dock_depth_m])

    @property
    def dock_axis(self) -> np.ndarray:
        """Unit vector along which a vehicle enters the dock (world frame)."""
        return np.array([math.cos(self.dock_axis_yaw_rad), math.sin(self.dock_axis_yaw_rad), 0.0])

    def past_entrance_m(self, pose: VehiclePose) -> float:
        """How far the nose is past the entrance plane (negative: still in front of it)."""
        return float((self.camera_position(pose) - self.dock_center) @ self.dock_axis)

    def off_axis_m(self, pose: VehiclePose) -> float:
        """Distance of the nose from the dock's axis line."""
        rel = self.camera_position(pose) - self.dock_center
        return float(np.linalg.norm(rel - (rel @ self.dock_axis) * self.dock_axis))

    def heading_off_axis_rad(self, pose: VehiclePose) -> float:
        """Angle between the hull's axis and the dock's axis."""
        return math.acos(max(-1.0, min(1.0, float(pose.body_to_world()[:, 0] @ self.dock_axis))))

    def side_room_m(self, hull_radius_m: float = HULL_RADIUS_M) -> float:
        """Room beside the dock's axis to a side wall, each side (guidance's ``side_room_m``); open water: inf."""
        return self.width_m / 2 - hull_radius_m if self.walls else math.inf

    def collides(self, pose: VehiclePose, hull_radius_m: float) -> bool:
        """The hull leaves the water or, in the pool, touches a side wall or the floor."""
        if pose.z > -0.1:
            return True
        return self.walls and (abs(pose.y) > self.width_m / 2 - hull_radius_m or pose.z < -self.depth_m)

    def camera_position(self, pose: VehiclePose) -> np.ndarray:
        return np.array([pose.x, pose.y, pose.z]) + pose.body_to_world() @ np.array([self.camera_offset_m, 0.0, 0.0])

    def to_camera(self, pose: VehiclePose) -> tuple[np.ndarray, np.ndarray]:
        """(rotation world -> optical frame, camera position in world)."""
        body_to_optical = np.array([[0.0, -1.0, 0.0], [0.0, 0.0, -1.0], [1.0, 0.0, 0.0]])
        return body_to_optical @ pose.body_to_world().T, self.camera_position(pose)

    def scene_for(self, pose: VehiclePose, seed: int = 0) -> SceneSpec:
        """What the camera sees from this pose."""
        rotation, position = self.to_camera(pose)
        center = rotation @ (self.dock_center - position)
        normal = rotation @ -self.dock_axis
        up = rotation @ np.array([0.0, 0.0, 1.0])
        in_front_of_dock = float((position - self.dock_center) @ self.dock_axis) < 0  # the LEDs face out
        visible = center[2] > 0.2 and in_front_of_dock
        return replace(
            self.scene,
            marker_center_m=(float(center[0]), float(center[1]), float(center[2])) if visible else None,
            marker_normal=(float(normal[0]), float(normal[1]), float(normal[2])),
            marker_radius_m=self.entrance_radius_m,
            surface_height_m=float(-position[2]) if self.reflection else None,
            surface_up=(float(up[0]), float(up[1]), float(up[2])),
            seed=seed,
        )


def _rx(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])


def _ry(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])


def _rz(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])
