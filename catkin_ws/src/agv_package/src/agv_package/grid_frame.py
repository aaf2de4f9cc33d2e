"""Base grid <-> robot frame: the one place on the robot where the two meet (thesis 5.5).

Commands and feedback on the wire are in base-grid cells (origin bottom-left,
y up); the robot drives, localizes and simulates in its own frame, metres
(the lab's `base_to_robot`: 0.7 m a cell, shifted). Every conversion between
the two goes through a `GridFrame`; nothing else on the robot knows the
transform. Headings follow the transform's linear part, so a mirror or a
rotation in `base_to_robot` turns headings too.
"""
from __future__ import annotations

import math
from typing import Optional, Tuple

from fleet_common.angles import wrap_angle
from fleet_common.lab import base_to_robot
from fleet_common.transform2d import Transform2D

from .geometry import Pose2D

Point = Tuple[float, float]


class GridFrame:
    """Converts points, headings and poses between base cells and robot metres."""

    def __init__(self, to_robot: Optional[Transform2D] = None) -> None:
        self.to_robot_transform = to_robot if to_robot is not None else base_to_robot()
        self.to_base_transform = self.to_robot_transform.inverse()

    def cell_size(self) -> float:
        """Metres per cell along base x (the lab's grid is square: 0.7 m)."""
        linear = self.to_robot_transform.matrix[:2, :2]
        return float(math.hypot(linear[0, 0], linear[1, 0]))

    def point_to_robot(self, x: float, y: float) -> Point:
        return self.to_robot_transform.apply((x, y))

    def point_to_base(self, x: float, y: float) -> Point:
        return self.to_base_transform.apply((x, y))

    def heading_to_robot(self, theta: float) -> float:
        return _turn_heading(self.to_robot_transform, theta)

    def heading_to_base(self, theta: float) -> float:
        return _turn_heading(self.to_base_transform, theta)

    def pose_to_robot(self, pose: Pose2D) -> Pose2D:
        return Pose2D(*self.point_to_robot(pose.x, pose.y), self.heading_to_robot(pose.theta))

    def pose_to_base(self, pose: Pose2D) -> Pose2D:
        return Pose2D(*self.point_to_base(pose.x, pose.y), self.heading_to_base(pose.theta))


def _turn_heading(transform: Transform2D, theta: float) -> float:
    linear = transform.matrix[:2, :2]
    dx = linear[0, 0] * math.cos(theta) + linear[0, 1] * math.sin(theta)
    dy = linear[1, 0] * math.cos(theta) + linear[1, 1] * math.sin(theta)
    return wrap_angle(math.atan2(dy, dx))
