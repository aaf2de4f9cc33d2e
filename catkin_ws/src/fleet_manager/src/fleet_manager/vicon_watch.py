"""Vicon's view of the fleet: poses in, robots that disagree with it or that it lost, told.

The manager's loop reads Vicon's stream (`vicon_provider`) and gives the
core each fresh pose (`ViconWatch.poses`); on its pose timer it asks which
robots Vicon lost or sees again (`check`). Each robot's own pose is compared
with Vicon's (`pose_disagreement`), and a robot that starts or stops
disagreeing, that Vicon loses (no pose for the stale time) or sees again, is
reported as a `vicon` run-log record and a console notice.
"""
from __future__ import annotations

from typing import Iterable

from fleet_common.vicon.base_grid import ViconFix

from .outbox import Outbox
from .pose_disagreement import DisagreementDetector
from .robot import VICON, Fleet, Seen

__all__ = ["ViconWatch"]


class ViconWatch:
    def __init__(self, fleet: Fleet, out: Outbox, disagree_after: float = 0.5,
                 agree_below: float = 0.3) -> None:
        self.fleet = fleet
        self.out = out
        self.detector = DisagreementDetector(disagree_after, agree_below)
        fleet.vicon_enabled = True

    def poses(self, fixes: Iterable[ViconFix], now: float) -> None:
        for fix in fixes:
            robot = self.fleet.by_id.get(fix.robot_id)
            if robot is not None:
                robot.vicon = Seen(fix.pose, now - fix.age)  # when it arrived: it may wait a poll
        stale = self.fleet.stale_after
        for robot in self.fleet:
            own, seen = robot.own, robot.vicon
            if own is None or seen is None or now - own.at > stale or now - seen.at > stale:
                continue
            event = self.detector.update(robot.id, own.pose, own.at, seen.pose, seen.at, now)
            if event is None:
                continue
            robot.disagreeing = event.disagree
            self.out.record("vicon", robot=robot.id, event="disagree" if event.disagree else "agree",
                            distance=round(event.distance, 3))
            self.out.tell("vicon", robot.id, "robot {}: {} ({:.2f} cells apart)".format(
                robot.id, "its own pose and Vicon's disagree: is it lost?" if event.disagree
                else "its own pose agrees with Vicon again", event.distance))

    def check(self, now: float) -> None:
        """Tell when Vicon loses a robot (no pose for the stale time) or sees it again."""
        for robot in self.fleet:
            age = robot.age(now, VICON)
            if age is None:
                continue
            lost = age > self.fleet.stale_after
            if lost != robot.vicon_lost:
                robot.vicon_lost = lost
                self.out.record("vicon", robot=robot.id, event="stale" if lost else "seen", distance=None)
                self.out.tell("vicon", robot.id, "robot {}: {}".format(
                    robot.id, "Vicon does not see it ({:.1f} s)".format(age) if lost
                    else "Vicon sees it again"))
