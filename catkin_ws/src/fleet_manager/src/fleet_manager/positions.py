"""Where each robot is: its own localization, Vicon's view, and which one the run uses.

Every robot has up to two position sources: its own pose feedback (AprilTag
localization fused with odometry, or the virtual robot's kinematics) and the
Vicon motion capture. The operator chooses the source per robot or for all
(thesis 5.4); the chosen one is what the console draws and what the manager
measures distances with. A source that has not been heard from for
`stale_after` seconds is stale: the robot stays on the map, greyed, with the
age of its last pose (never silently dropped).

When both sources see a robot, they are compared: a robot whose own pose and
Vicon's differ by more than `disagree_after` cells is flagged (a lost robot
is caught before it drives into another), and cleared again under
`agree_below` (hysteresis, so a robot at the threshold does not flicker).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Dict, Iterable, List, Optional, Tuple

from fleet_common.wire import Pose

__all__ = ["Positions", "Seen", "ROBOT", "VICON"]

ROBOT = "robot"
VICON = "vicon"


@dataclass
class Seen:
    pose: Pose
    at: float  # when it arrived (the manager's clock)


class Positions:
    """Poses by robot id, from each source, and the source chosen for each robot."""

    def __init__(self, robots: Iterable[int], stale_after: float = 1.0,
                 disagree_after: float = 0.5, agree_below: float = 0.3) -> None:
        self.robot: Dict[int, Optional[Seen]] = {r: None for r in robots}
        self.vicon: Dict[int, Optional[Seen]] = {r: None for r in self.robot}
        self.source: Dict[int, str] = {r: ROBOT for r in self.robot}
        self.stale_after = stale_after
        self.disagree_after = disagree_after
        self.agree_below = agree_below
        self.disagreeing: Dict[int, bool] = {r: False for r in self.robot}
        self.vicon_enabled = False

    def from_robot(self, robot: int, pose: Pose, now: float) -> None:
        if robot in self.robot:
            self.robot[robot] = Seen(pose, now)

    def from_vicon(self, robot: int, pose: Pose, now: float) -> None:
        if robot in self.vicon:
            self.vicon[robot] = Seen(pose, now)

    def choose(self, source: str, robot: Optional[int] = None) -> List[int]:
        """Use `source` for `robot` (None: every robot); the robots whose source changed."""
        changed = [r for r in (self.source if robot is None else [robot])
                   if self.source.get(r) != source]
        for r in changed:
            self.source[r] = source
        return changed

    def seen(self, robot: int) -> Optional[Seen]:
        """The chosen source's last pose of `robot`."""
        return (self.vicon if self.source[robot] == VICON else self.robot)[robot]

    def pose(self, robot: int) -> Optional[Pose]:
        seen = self.seen(robot)
        return seen.pose if seen is not None else None

    def age(self, robot: int, now: float, source: Optional[str] = None) -> Optional[float]:
        table = self.vicon if (source or self.source[robot]) == VICON else self.robot
        seen = table[robot]
        return None if seen is None else max(0.0, now - seen.at)

    def stale(self, robot: int, now: float) -> bool:
        age = self.age(robot, now)
        return age is None or age > self.stale_after

    def compare(self, now: float) -> List[Tuple[int, bool, float]]:
        """Robots whose agreement changed: (robot, disagrees now, distance in cells)."""
        changes = []
        for r, own in self.robot.items():
            seen = self.vicon[r]
            if own is None or seen is None or now - own.at > self.stale_after \
                    or now - seen.at > self.stale_after:
                continue
            d = math.hypot(own.pose.x - seen.pose.x, own.pose.y - seen.pose.y)
            was = self.disagreeing[r]
            now_disagrees = d > self.disagree_after if not was else d >= self.agree_below
            if now_disagrees != was:
                self.disagreeing[r] = now_disagrees
                changes.append((r, now_disagrees, d))
        return changes
