"""Odometry, corrected by AprilTag fixes: the robot's best idea of where it is.

Odometry is smooth but drifts (wheel slip); a tag fix is exact but comes only
where a tag is in view, and late (a camera frame is processed after it was
taken). So the fused pose is odometry seen through a correction,

    world_T_robot(now) = world_T_odom . odom_T_robot(now)

and each fix moves the correction: the odometry pose at the frame's own
timestamp (interpolated from a short history) is compared with the fix, and
the estimate at that instant is pulled `gain` of the way to the fix. A fix
further than `max_jump` from the estimate is refused once the robot is
localized (a misread tag must not teleport it); until the first fix, or an
explicit `reset`, the robot is not localized.
"""
from __future__ import annotations

import bisect
from typing import List, Optional, Tuple

from .geometry import Pose2D, interpolate

#: How far (seconds) outside the odometry history a fix's stamp may lie.
STAMP_SLACK = 0.05


class PoseFusion:
    """Fuses timestamped odometry poses (odom frame) with world-frame tag fixes."""

    def __init__(self, gain: float = 0.5, max_jump: float = 0.3, history: float = 2.0) -> None:
        self.gain = gain
        self.max_jump = max_jump
        self.history = history
        self._stamps: List[float] = []
        self._poses: List[Pose2D] = []
        self._world_from_odom: Optional[Pose2D] = None
        self.accepted = 0
        self.refused = 0

    @property
    def localized(self) -> bool:
        return self._world_from_odom is not None

    def add_odometry(self, stamp: float, pose: Pose2D) -> None:
        """Record the odometry pose at `stamp` (seconds; stamps must not go back)."""
        if self._stamps and stamp < self._stamps[-1]:
            # A restarted odometry source: its history no longer matches its poses.
            self._stamps.clear()
            self._poses.clear()
        self._stamps.append(stamp)
        self._poses.append(pose)
        cut = bisect.bisect_left(self._stamps, stamp - self.history)
        if cut:
            del self._stamps[:cut]
            del self._poses[:cut]

    def odometry_at(self, stamp: float) -> Optional[Pose2D]:
        """Odometry pose at `stamp`, interpolated; None outside the history (with slack)."""
        if not self._stamps:
            return None
        if stamp <= self._stamps[0]:
            return self._poses[0] if self._stamps[0] - stamp <= STAMP_SLACK else None
        if stamp >= self._stamps[-1]:
            return self._poses[-1] if stamp - self._stamps[-1] <= STAMP_SLACK else None
        i = bisect.bisect_right(self._stamps, stamp)
        t0, t1 = self._stamps[i - 1], self._stamps[i]
        fraction = (stamp - t0) / (t1 - t0) if t1 > t0 else 1.0
        return interpolate(self._poses[i - 1], self._poses[i], fraction)

    def reset(self, world_pose: Pose2D) -> bool:
        """Declare the robot to be at `world_pose` now; False without any odometry yet."""
        if not self._poses:
            return False
        self._world_from_odom = world_pose.compose(self._poses[-1].inverse())
        return True

    def add_fix(self, stamp: float, world_pose: Pose2D) -> Tuple[bool, str]:
        """Apply a tag fix taken at `stamp`: (accepted, why not)."""
        odom = self.odometry_at(stamp)
        if odom is None:
            self.refused += 1
            return False, "no odometry around the frame's time stamp"
        if self._world_from_odom is None:
            self._world_from_odom = world_pose.compose(odom.inverse())
            self.accepted += 1
            return True, ""
        estimate = self._world_from_odom.compose(odom)
        jump = estimate.distance_to(world_pose)
        if jump > self.max_jump:
            self.refused += 1
            return False, "{:.2f} m from the estimate (more than max_jump {:.2f} m)".format(
                jump, self.max_jump)
        pulled = interpolate(estimate, world_pose, self.gain)
        self._world_from_odom = pulled.compose(odom.inverse())
        self.accepted += 1
        return True, ""

    def pose(self) -> Optional[Pose2D]:
        """The fused pose at the latest odometry, None until localized."""
        if self._world_from_odom is None or not self._poses:
            return None
        return self._world_from_odom.compose(self._poses[-1])
