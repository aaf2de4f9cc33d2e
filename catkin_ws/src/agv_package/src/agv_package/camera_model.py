"""The robot's downward camera: where it is mounted and how it sees the floor.

Frames (right-handed, metres): robot (x forward, y left, z up, origin on the
floor under the wheel axle centre); camera (optical convention: x right, y
down in the image, z along the optical axis). The camera hangs at height `z`
above the floor at (`x`, `y`) in the robot frame and looks straight down, with
the top of the image towards the robot's front, turned by `yaw` about the
vertical. Pinhole intrinsics are (fx, fy, cx, cy) as in CameraInfo's K.
The simulator draws the floor with the same model the runner inverts.
"""
from __future__ import annotations

import math
from typing import Any, Mapping, NamedTuple, Tuple

import numpy as np

from .geometry import Pose2D
from .settings import SettingsError, number

Intrinsics = Tuple[float, float, float, float]

# Camera axes in the robot frame for yaw 0: image right = robot right (-y),
# image down = robot backward (-x), optical axis = down (-z).
_DOWNWARD = np.array([[0.0, -1.0, 0.0],
                      [-1.0, 0.0, 0.0],
                      [0.0, 0.0, -1.0]])


class CameraMount(NamedTuple):
    """Camera position on the robot (metres) and turn about the vertical (radians)."""

    x: float
    y: float
    z: float
    yaw: float = 0.0

    @classmethod
    def from_dict(cls, data: Mapping[str, Any], where: str = "camera mount") -> "CameraMount":
        unknown = sorted(set(data) - {"x", "y", "z", "yaw_deg"})
        if unknown:
            raise SettingsError("{}: unknown key {!r}; expected x, y, z, yaw_deg".format(
                where, unknown[0]))
        height = number(data, "z", where, low=0.01)
        return cls(number(data, "x", where, default=0.0), number(data, "y", where, default=0.0),
                   height, math.radians(number(data, "yaw_deg", where, default=0.0)))

    def rotation(self) -> np.ndarray:
        """3x3 rotation whose columns are the camera axes in the robot frame."""
        c, s = math.cos(self.yaw), math.sin(self.yaw)
        turn = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
        return turn @ _DOWNWARD

    def robot_from_camera(self) -> np.ndarray:
        """4x4 homogeneous transform: camera coordinates -> robot coordinates."""
        out = np.eye(4)
        out[:3, :3] = self.rotation()
        out[:3, 3] = (self.x, self.y, self.z)
        return out


def floor_to_pixels(robot: Pose2D, mount: CameraMount, intrinsics: Intrinsics) -> np.ndarray:
    """2x3 affine map from floor points (world x, y; metres) to pixel (u, v).

    The camera looks straight down at a flat floor, so the projection of the
    floor is affine: every floor point is at the same depth, `mount.z`.
    """
    fx, fy, cx, cy = intrinsics
    c, s = math.cos(robot.theta), math.sin(robot.theta)
    world_from_robot = np.array([[c, -s, 0.0, robot.x], [s, c, 0.0, robot.y],
                                 [0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 1.0]])
    camera_from_world = np.linalg.inv(world_from_robot @ mount.robot_from_camera())
    # Camera coordinates of a floor point (X, Y, 0): columns for X, Y and 1.
    rows = camera_from_world[:3][:, [0, 1, 3]]
    depth = rows[2]  # (0, 0, z): constant over the floor
    scale = np.array([[fx, 0.0, cx], [0.0, fy, cy]])
    return scale @ np.vstack([rows[0] / depth[2], rows[1] / depth[2], [0.0, 0.0, 1.0]])
