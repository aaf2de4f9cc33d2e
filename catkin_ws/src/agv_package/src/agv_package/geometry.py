"""Planar poses (x, y, heading) and the few operations the robot needs on them.

A `Pose2D` is a rigid transform of the plane: `a.compose(b)` is "b expressed
in a's frame, seen from a's parent frame", so `world_T_robot =
world_T_odom.compose(odom_T_robot)`. Headings are radians, counter-clockwise
from +x, wrapped to (-pi, pi] (`fleet_common.angles.wrap_angle`).
"""
from __future__ import annotations

import math
from typing import NamedTuple

from fleet_common.angles import wrap_angle


class Pose2D(NamedTuple):
    """Position (x, y) and heading `theta` (radians) of a frame in its parent frame."""

    x: float
    y: float
    theta: float

    def compose(self, other: "Pose2D") -> "Pose2D":
        c, s = math.cos(self.theta), math.sin(self.theta)
        return Pose2D(self.x + c * other.x - s * other.y,
                      self.y + s * other.x + c * other.y,
                      wrap_angle(self.theta + other.theta))

    def inverse(self) -> "Pose2D":
        c, s = math.cos(self.theta), math.sin(self.theta)
        return Pose2D(-c * self.x - s * self.y, s * self.x - c * self.y, wrap_angle(-self.theta))

    def relative_to(self, base: "Pose2D") -> "Pose2D":
        """This pose seen from `base` (both in the same parent frame)."""
        return base.inverse().compose(self)

    def distance_to(self, other: "Pose2D") -> float:
        return math.hypot(other.x - self.x, other.y - self.y)

    def heading_error_to(self, other: "Pose2D") -> float:
        """Signed angle to turn from this heading to `other`'s, in (-pi, pi]."""
        return wrap_angle(other.theta - self.theta)


def interpolate(a: Pose2D, b: Pose2D, fraction: float) -> Pose2D:
    """The pose `fraction` of the way from `a` to `b` (heading along the shorter arc)."""
    return Pose2D(a.x + fraction * (b.x - a.x), a.y + fraction * (b.y - a.y),
                  wrap_angle(a.theta + fraction * wrap_angle(b.theta - a.theta)))
