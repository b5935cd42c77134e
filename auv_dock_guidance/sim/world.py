"""The paper's pool as a world: where the dock, the surface and the vehicle's camera are.

World frame: x along the pool towards the dock, y to the left, z up; the water surface
is z = 0. The dock's entrance faces -x. The vehicle's attitude is given as its
navigation reports it (pitch nose up +, yaw to starboard +); its camera sits on the
nose looking forward (optical frame: x right, y down, z forward).
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

    @property
    def dock_center(self) -> np.ndarray:
        return np.array([self.dock_x_m, 0.0, -self.dock_depth_m])

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
        normal = rotation @ np.array([-1.0, 0.0, 0.0])
        up = rotation @ np.array([0.0, 0.0, 1.0])
        visible = center[2] > 0.2
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
