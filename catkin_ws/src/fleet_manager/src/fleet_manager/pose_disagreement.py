"""A second pair of eyes: does a robot's own localization agree with Vicon?

A robot that has lost its localization still reports a confident pose; Vicon
sees where it really is. `DisagreementDetector.update` takes both poses of one
robot (base-grid cells, each with the time it was received) and returns an
event when the robot starts or stops disagreeing. Pure: the manager feeds it
and turns the events into its own.

Hysteresis, so one noisy sample or a robot hovering at the threshold does not
make a stream of events: a robot starts disagreeing when the distance stays
above `threshold` for `hold` seconds, and agrees again when it stays below
`clear_below` for `hold` seconds. Two poses are compared only when they were
received within `max_skew` of each other (a moving robot's old pose is
somewhere else). A comparison that cannot be made says nothing either way and
leaves the hold as it is: on a loaded PC or a jittery link, the robot's own
poses come late often enough that restarting the hold at every gap would
never let a lost robot be reported. Only a comparison on the other side of
the threshold restarts it.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Dict, Optional, Set

from fleet_common.wire.messages import Pose

__all__ = ["DisagreementDetector", "DisagreementEvent"]


@dataclass(frozen=True)
class DisagreementEvent:
    """Robot `robot_id` started (`disagree`) or stopped disagreeing, at time `time`."""

    robot_id: int
    disagree: bool
    distance: float  # cells between the two poses when it was decided
    own: Pose
    vicon: Pose
    time: float

    def describe(self) -> str:
        if self.disagree:
            return ("robot {}: its own pose ({:.2f}, {:.2f}) and Vicon's ({:.2f}, {:.2f}) are "
                    "{:.2f} cells apart: is it lost?".format(
                        self.robot_id, self.own.x, self.own.y, self.vicon.x, self.vicon.y,
                        self.distance))
        return "robot {}: its own pose agrees with Vicon again ({:.2f} cells)".format(
            self.robot_id, self.distance)


@dataclass
class _State:
    disagree: bool = False
    since: Optional[float] = None  # when the condition for switching began to hold


class DisagreementDetector:
    """See the module's docstring. Distances in cells, times in seconds."""

    def __init__(self, threshold: float = 0.5, clear_below: Optional[float] = None,
                 hold: float = 0.3, max_skew: float = 0.25) -> None:
        clear = 0.6 * threshold if clear_below is None else clear_below
        if not (threshold > 0 and 0 <= clear <= threshold and hold >= 0 and max_skew > 0):
            raise ValueError("need threshold > 0, 0 <= clear_below <= threshold, hold >= 0, "
                             "max_skew > 0")
        self.threshold = threshold
        self.clear_below = clear
        self.hold = hold
        self.max_skew = max_skew
        self._robots: Dict[int, _State] = {}

    def update(self, robot_id: int, own: Pose, own_time: float, vicon: Pose,
               vicon_time: float, now: float) -> Optional[DisagreementEvent]:
        """Compare one robot's two poses at time `now`; an event if its state changed."""
        state = self._robots.setdefault(robot_id, _State())
        distance = math.hypot(own.x - vicon.x, own.y - vicon.y)
        if not (abs(own_time - vicon_time) <= self.max_skew and math.isfinite(distance)):
            return None  # no evidence either way: the hold goes on
        switching = (distance < self.clear_below) if state.disagree else (
            distance > self.threshold)
        if not switching:
            state.since = None
            return None
        if state.since is None:
            state.since = now
        if now - state.since < self.hold:
            return None
        state.disagree = not state.disagree
        state.since = None
        return DisagreementEvent(robot_id, state.disagree, distance, own, vicon, now)

    def disagreeing(self) -> Set[int]:
        return {rid for rid, s in self._robots.items() if s.disagree}

    def forget(self, robot_id: int) -> None:
        """Start afresh for this robot (disabled, restarted, or Vicon lost it)."""
        self._robots.pop(robot_id, None)
