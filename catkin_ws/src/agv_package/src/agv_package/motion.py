"""Feedback controllers for the two motions of a grid robot: turn in place, drive straight.

Both are pure: `step(pose, now, dt)` takes the current pose estimate (world
frame) and returns the velocity to command, or None when the motion is done.

- `TurnController` turns to an absolute heading: rate proportional to the
  heading error, at least `min_turn_rate` (so it does not creep), at most
  `max_turn_rate`, limited in acceleration and braking.
- `DriveController` follows the straight line from where the drive began to
  the goal (line following: heading error and cross-track error steer), at the
  speed that reaches the goal at the requested arrival time (remaining
  distance over remaining time), within [min_speed, max_speed], limited in
  acceleration and braking. It is done when the goal is no more than
  `position_tolerance` ahead along the line, so it never turns back to fix an
  overshoot. With a hold point (`hold`, moved on by `release`) it brakes for
  that point instead and waits there, at rest, until the hold point moves on:
  a follower keeps its distance from the robot ahead of it.
"""
from __future__ import annotations

import math
from typing import NamedTuple, Optional, Tuple

from fleet_common.angles import wrap_angle

from .geometry import Pose2D
from .settings import MotionSettings


class Twist(NamedTuple):
    """A velocity command: forward speed (m/s) and turn rate (rad/s, counter-clockwise)."""

    linear: float
    angular: float


STOP = Twist(0.0, 0.0)


def _clamp(value: float, low: float, high: float) -> float:
    return max(low, min(high, value))


def _ramp(previous: float, wanted: float, max_step: float) -> float:
    """`wanted`, moved no further than `max_step` from `previous`."""
    return _clamp(wanted, previous - max_step, previous + max_step)


class TurnController:
    """Turns in place to `heading` (radians, world frame)."""

    def __init__(self, settings: MotionSettings, heading: float) -> None:
        self.settings = settings
        self.heading = wrap_angle(heading)
        self._rate = 0.0

    def step(self, pose: Pose2D, now: float, dt: float) -> Optional[Twist]:
        s = self.settings
        error = wrap_angle(self.heading - pose.theta)
        if abs(error) <= s.heading_tolerance:
            self._rate = 0.0
            return None
        speed = min(s.max_turn_rate, s.turn_gain * abs(error),
                    math.sqrt(2.0 * s.max_turn_accel * abs(error)))
        wanted = math.copysign(max(speed, s.min_turn_rate), error)
        self._rate = _ramp(self._rate, wanted, s.max_turn_accel * dt)
        return Twist(0.0, self._rate)


class DriveController:
    """Drives from `start` along the line to `goal` (world metres), arriving at `arrival`."""

    def __init__(self, settings: MotionSettings, start: Pose2D, goal: Tuple[float, float],
                 arrival: float, hold: Optional[Tuple[float, float]] = None) -> None:
        self.settings = settings
        self.start = (start.x, start.y)
        self.goal = (float(goal[0]), float(goal[1]))
        self.arrival = arrival
        dx, dy = self.goal[0] - start.x, self.goal[1] - start.y
        self.length = math.hypot(dx, dy)
        # A zero-length drive keeps the current heading as its line.
        self.line_heading = math.atan2(dy, dx) if self.length > 1e-9 else start.theta
        self._unit = (math.cos(self.line_heading), math.sin(self.line_heading))
        self._speed = 0.0
        #: how far along the line it may go (inf: to the goal); True while it waits there
        self.hold = math.inf
        self.holding = False
        if hold is not None:
            along = self._along(hold)
            self.hold = math.inf if along >= self.length - 1e-9 else along

    def _along(self, point: Tuple[float, float]) -> float:
        return (point[0] - self.start[0]) * self._unit[0] + (point[1] - self.start[1]) * self._unit[1]

    def release(self, point: Tuple[float, float]) -> None:
        """It may go as far as `point` (projected on the line); a hold point only moves on."""
        along = self._along(point)
        self.hold = math.inf if along >= self.length - 1e-9 else max(self.hold, along)

    def room(self, pose: Pose2D) -> float:
        """Distance it may still go before its hold point (inf without one)."""
        return self.hold - self._along((pose.x, pose.y))

    def remaining(self, pose: Pose2D) -> float:
        """Distance still to go along the line (negative once past the goal)."""
        return ((self.goal[0] - pose.x) * self._unit[0] + (self.goal[1] - pose.y) * self._unit[1])

    def cross_track(self, pose: Pose2D) -> float:
        """Distance left (+) or right (-) of the line."""
        return (-(pose.x - self.start[0]) * self._unit[1]
                + (pose.y - self.start[1]) * self._unit[0])

    def step(self, pose: Pose2D, now: float, dt: float) -> Optional[Twist]:
        s = self.settings
        remaining = self.remaining(pose)
        if remaining <= s.position_tolerance:
            self._speed = 0.0
            return None
        room = self.room(pose)
        self.holding = room <= s.position_tolerance
        if self.holding:  # at its hold point: stand still until released
            self._speed = 0.0
            return STOP
        stop_at = min(remaining, room)
        time_left = self.arrival - now
        on_time = remaining / time_left if time_left > 1e-3 else s.max_speed
        braking = math.sqrt(2.0 * s.max_accel * stop_at)
        wanted = _clamp(min(on_time, braking), s.min_speed, s.max_speed)
        heading_error = wrap_angle(pose.theta - self.line_heading)
        wanted *= max(0.0, math.cos(heading_error))  # slow down while pointing off the line
        self._speed = _ramp(self._speed, wanted, s.max_accel * dt)
        turn = -s.heading_gain * heading_error - s.lateral_gain * self.cross_track(pose)
        return Twist(self._speed, _clamp(turn, -s.max_turn_rate, s.max_turn_rate))


def needs_turn(pose: Pose2D, heading: float, settings: MotionSettings) -> bool:
    """True when `pose` points more than `align_tolerance` away from `heading`."""
    return abs(wrap_angle(heading - pose.theta)) > settings.align_tolerance
