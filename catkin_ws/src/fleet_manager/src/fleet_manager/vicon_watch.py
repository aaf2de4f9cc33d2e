"""The manager's Vicon: poses from the provider into `Positions`, changes told to consoles.

`ViconWatch` is what the manager's loop calls when the Vicon socket is
readable (`readable`) and on its pose timer (`check`). It feeds every fresh
Vicon pose to `Positions`, asks it to compare each robot's own pose with
Vicon's, and reports, as `vicon` run-log records and console events, a robot
that starts or stops disagreeing and one that Vicon loses (stale) or sees again.
"""
from __future__ import annotations

import logging
from pathlib import Path
from typing import Callable, Dict, Optional, Sequence

from fleet_common.robots import RobotDefinition
from fleet_common.vicon.base_grid import load_vicon_to_base

from .positions import VICON, Positions
from .vicon_provider import ViconProvider

__all__ = ["ViconWatch"]


class ViconWatch:
    def __init__(self, robots: Sequence[RobotDefinition], positions: Positions, port: int,
                 bind: str, frames: Optional[Path], now: Callable[[], float],
                 note: Callable[..., None], tell: Callable[[str, Optional[int], str], None],
                 clock: Callable[[], float], log: Optional[logging.Logger] = None) -> None:
        self.positions = positions
        self.now, self.note, self.tell = now, note, tell
        self.provider = ViconProvider(robots, load_vicon_to_base(frames), port=port, bind=bind,
                                      stale_after=positions.stale_after, clock=clock, log=log)
        self.lost: Dict[int, bool] = {}  # robot id -> Vicon has lost it (seen before)
        positions.vicon_enabled = True

    def readable(self) -> None:
        now = self.now()
        for fix in self.provider.handle_readable():
            self.positions.from_vicon(fix.robot_id, fix.pose, now)
        for robot, disagrees, distance in self.positions.compare(now):
            self.note("vicon", robot=robot, event="disagree" if disagrees else "agree",
                      distance=round(distance, 3))
            self.tell("vicon", robot, "robot {}: {} ({:.2f} cells apart)".format(
                robot, "its own pose and Vicon's disagree: is it lost?" if disagrees
                else "its own pose agrees with Vicon again", distance))

    def check(self, now: float) -> None:
        """Tell when Vicon loses a robot (no pose for the stale time) or sees it again."""
        for robot in self.positions.vicon:
            age = self.positions.age(robot, now, VICON)
            if age is None:
                continue
            lost = age > self.positions.stale_after
            if lost != self.lost.get(robot, False):
                self.lost[robot] = lost
                self.note("vicon", robot=robot, event="stale" if lost else "seen",
                          distance=None)
                self.tell("vicon", robot, "robot {}: {}".format(
                    robot, "Vicon does not see it ({:.1f} s)".format(age) if lost
                    else "Vicon sees it again"))

    def close(self) -> None:
        self.provider.close()
