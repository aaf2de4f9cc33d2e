"""A virtual robot's motion: turn in place, then drive straight, at set speeds.

`VirtualNavigator` implements fleet_common.wire's `PollingNavigator` without ROS. A
move is laid out when it starts as a few timed segments (wait, turn, drive,
stall) and the pose is read off them whenever asked, so a robot costs nothing
between questions. Time is the fleet's own: wall time since start times
`time_scale`, so a fleet at --time-scale 10 finishes a 5 s move in 0.5 s.

drive_to_position(x, y, time) takes max(time, turn + distance/speed) seconds,
and longer if the delay model slows or stalls the move; turn(angle) goes the
short way round to an absolute heading.

A drive with a hold point stops there, short of the robot it follows, and
stays until `release` moves the hold point on: the laid-out segments from that
moment are put off by as long as it waited (`_put_off`), so a stall the fate
drew further on still happens where it was drawn.
"""
from __future__ import annotations

import dataclasses
import math
import random
import time as _time
from dataclasses import dataclass
from typing import Callable, Dict, List, Optional, Set, Tuple

from fleet_common.angles import wrap_angle
from fleet_common.wire.messages import Pose
from fleet_common.wire.navigator import MotionOutcome

from .delays import FleetDelays, MoveFate

__all__ = ["VirtualNavigator", "SPEED", "TURN_SPEED", "QUARTER_OF_A_MOVE"]

SPEED = 0.5        # cells/s: a move of 2 s, about 0.35 m/s on the lab's 0.7 m cells
TURN_SPEED = 1.5   # rad/s in place
#: A quarter turn's time in moves (about a half): what a plan's turns cost these robots.
QUARTER_OF_A_MOVE = (math.pi / 2) / TURN_SPEED * SPEED


@dataclass(frozen=True)
class _Segment:
    start: float   # fleet seconds
    end: float
    a: Pose        # pose at start
    b: Pose        # pose at end


class VirtualNavigator:
    """Kinematic robot; `speed` in cells/s, `turn_speed` in rad/s (fleet seconds)."""

    def __init__(self, pose: Pose, *, speed: float = SPEED, turn_speed: float = TURN_SPEED,
                 time_scale: float = 1.0, model: Optional[FleetDelays] = None,
                 rng: Optional[random.Random] = None,
                 clock: Callable[[], float] = _time.monotonic) -> None:
        if speed <= 0 or turn_speed <= 0 or time_scale <= 0:
            raise ValueError("speed, turn_speed and time_scale must be positive")
        self.speed = speed
        self.turn_speed = turn_speed
        self.time_scale = time_scale
        self.model = model or FleetDelays()
        self.rng = rng or random.Random(0)
        self.clock = clock
        self._t0 = clock()
        self._rest = pose
        self._segments: List[_Segment] = []
        self.dropout_time: Optional[float] = None  # fleet seconds; the fleet acts on it
        #: (cells/s along x, along y, since fleet second): the robot's own localization drifts
        #: away from the truth at this rate (a lost robot, for tests of the Vicon cross-check)
        self.drift: Optional[Tuple[float, float, float]] = None
        #: drives (1-based) during which the bumper is pressed halfway, as by a visitor's foot
        self.bumps: Set[int] = set()
        self.bump_seconds = 1.0
        #: drives (1-based) that halt halfway for so many fleet seconds (`virtual_fleet.stalls`)
        self.stalls: Dict[int, float] = {}
        self._drives = 0
        self._bump_at: Optional[float] = None       # fleet second the bumper is hit in this drive
        self._pressed_until: Optional[float] = None  # fleet second the foot goes away
        self._fault = False
        #: the drive's line: its start point, unit direction and the distance it may go along
        #: it (None: no hold point), and the fleet second it gets there (None: never)
        self._line: Optional[Tuple[float, float, float, float]] = None
        self._hold: Optional[float] = None
        self._held_at: Optional[float] = None
        #: the exact path, for the ground truth: (fleet second, x, y) wherever the motion changed
        self._knots: List[Tuple[float, float, float]] = [(self.now(), pose.x, pose.y)]
        self._knotted = self.now()  # fleet second up to which knots are written

    def now(self) -> float:
        """Fleet seconds since this navigator was made."""
        return (self.clock() - self._t0) * self.time_scale

    # ---- PollingNavigator ------------------------------------------------------------

    def start_drive(self, x: float, y: float, time: float,
                    hold: Optional[Tuple[float, float]] = None) -> None:
        self._mark()
        start = self.true_pose()
        dx, dy = x - start.x, y - start.y
        dist = math.hypot(dx, dy)
        heading = math.atan2(dy, dx) if dist > 1e-9 else start.theta
        turn = abs(wrap_angle(heading - start.theta)) / self.turn_speed
        drive = max(dist / self.speed, time - turn)
        self._lay_out(start, heading, turn, Pose(x, y, heading), drive, self.stalls.get(self._drives + 1, 0.0))
        self._drives += 1
        if self._drives in self.bumps and self._segments:
            first, last = self._segments[0].start, self._segments[-1].end
            self._bump_at = first + 0.5 * (last - first)
        self._line = (start.x, start.y, math.cos(heading), math.sin(heading)) if dist > 1e-9 else None
        self._hold = self._held_at = None
        if hold is not None:
            self._set_hold(hold, dist)

    def release(self, x: float, y: float) -> None:
        if self._hold is None or self._line is None or not self._segments:
            return
        self._mark()
        now = self.now()
        if self._held_at is not None and now > self._held_at:
            self._put_off(self._held_at, now - self._held_at)  # it waited there until now
        goal = self._segments[-1].b
        self._set_hold((x, y), self._along(goal.x, goal.y))

    def _along(self, x: float, y: float) -> float:
        x0, y0, ux, uy = self._line  # type: ignore[misc]
        return (x - x0) * ux + (y - y0) * uy

    def _set_hold(self, point: Tuple[float, float], length: float) -> None:
        """Stop at `point` (projected on the drive's line; only ever further on)."""
        if self._line is None:
            return
        hold = max(self._along(point[0], point[1]), self._hold if self._hold is not None else -math.inf)
        if hold >= length - 1e-9:
            self._hold = self._held_at = None  # nothing left to hold it
            return
        self._hold = max(hold, 0.0)
        self._held_at = self._reaches(self._hold)

    def _reaches(self, distance: float) -> Optional[float]:
        """The fleet second, from now on, the laid-out drive gets `distance` along its line."""
        now = self.now()
        for seg in self._segments:
            if seg.end < now:
                continue
            a, b = self._along(seg.a.x, seg.a.y), self._along(seg.b.x, seg.b.y)
            if a >= distance - 1e-12:
                return max(seg.start, now)  # there already
            if b >= distance - 1e-12 and b > a:
                return max(now, seg.start + (distance - a) / (b - a) * (seg.end - seg.start))
        return None

    def _put_off(self, at: float, delay: float) -> None:
        """Everything laid out from fleet second `at` on happens `delay` later (the robot
        stands where it is meanwhile)."""
        out: List[_Segment] = []
        for seg in self._segments:
            if seg.end <= at:
                out.append(seg)
            elif seg.start >= at:
                out.append(_Segment(seg.start + delay, seg.end + delay, seg.a, seg.b))
            else:
                mid = self._pose_on(seg, at)
                out += [_Segment(seg.start, at, seg.a, mid), _Segment(at, at + delay, mid, mid),
                        _Segment(at + delay, seg.end + delay, mid, seg.b)]
        self._segments = out
        if self.dropout_time is not None and self.dropout_time >= at:
            self.dropout_time += delay
        if self._bump_at is not None and self._bump_at >= at:
            self._bump_at += delay

    def start_turn(self, angle: float) -> None:
        self._mark()
        self._hold = self._held_at = None
        start = self.true_pose()
        turn = abs(wrap_angle(angle - start.theta)) / self.turn_speed
        # the delay model is per move (a plan step, as the engine draws it); a turn on its own
        # is the manager readying the robot for its next move, which draws the fate
        self._lay_out(start, wrap_angle(angle), turn, None, 0.0, fate=MoveFate())

    def halt(self) -> None:
        self._mark()
        self._rest = self.true_pose()
        self._segments = []
        self._hold = self._held_at = None
        self.dropout_time = None
        self._bump_at = None
        if not self._pressed():
            self._fault = False  # a stop clears the fault once the bumper is free, as on the robot

    def poll(self) -> Optional[MotionOutcome]:
        if self._bump_at is not None and self._segments and self.now() >= self._bump_at:
            self._mark(self._bump_at)
            self._rest = self._pose_at(self._bump_at)  # stops where the foot hit it, mid-move
            self._segments = []
            self._bump_at = None
            self.dropout_time = None
            self._fault = True
            self._pressed_until = self.now() + self.bump_seconds
            return MotionOutcome(False, "bumper pressed")
        if not self._segments or self.now() < self._segments[-1].end or self._held_at is not None:
            return None  # under way, or waiting at its hold point
        self._mark()
        self._rest = self._segments[-1].b
        self._segments = []
        self.dropout_time = None
        return MotionOutcome(True)

    def drain_knots(self) -> List[Tuple[float, float, float]]:
        """The path since the last call, exactly: (fleet second, x, y) at every change of its
        motion, and now if it is under way (for the ground truth). A robot at rest adds none:
        its path stays where its last knot put it (every stop is marked), and the fleet, which
        asks 20 times a second, would otherwise write a knot a robot each time."""
        if self._segments:
            self._mark()
        knots, self._knots = self._knots, []
        return knots

    def _mark(self, at: Optional[float] = None) -> None:
        """Knots for every segment boundary passed up to `at` (default now), and `at` itself."""
        t = self.now() if at is None else at
        stop = t if self._held_at is None else min(t, self._held_at)
        for seg in self._segments:
            for b, p in ((seg.start, seg.a), (seg.end, seg.b)):
                if self._knotted < b <= stop:
                    self._knots.append((b, p.x, p.y))
        if t > self._knotted:
            truth = self._pose_at(t)
            self._knots.append((t, truth.x, truth.y))
            self._knotted = t

    def pose(self) -> Pose:
        """Where the robot believes it is: the truth, unless its localization drifts."""
        truth = self.true_pose()
        if self.drift is None:
            return truth
        vx, vy, since = self.drift
        dt = max(0.0, self.now() - since)
        return Pose(truth.x + vx * dt, truth.y + vy * dt, truth.theta)

    def start_drifting(self, vx: float, vy: float = 0.0) -> None:
        self.drift = (vx, vy, self.now())

    def true_pose(self) -> Pose:
        """Where the robot really is."""
        return self._pose_at(self.now())

    def _pose_at(self, t: float) -> Pose:
        if not self._segments:
            return self._rest
        if self._held_at is not None:
            t = min(t, self._held_at)  # it stands at its hold point
        if self._bump_at is not None:
            t = min(t, self._bump_at)  # the bumper stopped it there, whenever `poll` comes to say so
            # (a robot whose link is down is polled once it is back: until then it drove on, and
            # then jumped back half a cell, towards a robot following it; big session 2378)
        for seg in self._segments:
            if t < seg.end:
                return self._pose_on(seg, t)
        return self._segments[-1].b

    @staticmethod
    def _pose_on(seg: _Segment, t: float) -> Pose:
        if t <= seg.start:
            return seg.a
        f = (t - seg.start) / (seg.end - seg.start)
        return Pose(seg.a.x + (seg.b.x - seg.a.x) * f, seg.a.y + (seg.b.y - seg.a.y) * f,
                    wrap_angle(seg.a.theta + wrap_angle(seg.b.theta - seg.a.theta) * f))

    @property
    def moving(self) -> bool:
        return bool(self._segments)

    def faults(self) -> Tuple[str, ...]:
        return ("bumper",) if self._fault else ()

    def _pressed(self) -> bool:
        return self._pressed_until is not None and self.now() < self._pressed_until

    def seconds_to_change(self) -> float:
        """Wall seconds until poll() or the dropout may change (the loop sleeps that long)."""
        if not self._segments:
            return 1.0
        due = self._segments[-1].end if self._held_at is None else self.now() + 1.0
        if self.dropout_time is not None:
            due = min(due, self.dropout_time)
        if self._bump_at is not None:
            due = min(due, self._bump_at)
        return max(0.0, (due - self.now()) / self.time_scale)

    # ---- internals -------------------------------------------------------------------

    def _lay_out(self, start: Pose, heading: float, turn: float, goal: Optional[Pose],
                 drive: float, planned_stall: float = 0.0, fate: Optional[MoveFate] = None) -> None:
        if fate is None:
            fate = self.model.draw(self.rng)
        if planned_stall > 0:  # halfway, whatever the model drew (the draw still happens)
            fate = dataclasses.replace(fate, stall=fate.stall + planned_stall, stall_at=0.5)
        t = self.now()
        turned = Pose(start.x, start.y, heading)
        plan: List[Tuple[float, Pose]] = [(fate.start_delay, start),
                                          (turn * fate.slowdown, turned)]
        if goal is not None:
            plan.append((drive * fate.slowdown, goal))
        if fate.stall > 0:  # pause where the robot is at `stall_at` of the moving part
            moving = sum(d for d, _ in plan[1:])
            cut, done = fate.stall_at * moving, 0.0
            for i in range(1, len(plan)):
                d, target = plan[i]
                if done + d >= cut:
                    a = plan[i - 1][1]
                    f = (cut - done) / d if d > 0 else 1.0
                    mid = Pose(a.x + (target.x - a.x) * f, a.y + (target.y - a.y) * f,
                               wrap_angle(a.theta + wrap_angle(target.theta - a.theta) * f))
                    plan[i:i + 1] = [(cut - done, mid), (fate.stall, mid), (d - (cut - done), target)]
                    break
                done += d
        segments, pose = [], start
        for duration, target in plan:
            segments.append(_Segment(t, t + duration, pose, target))
            t, pose = t + duration, target
        self._segments = segments
        total = t - segments[0].start
        self.dropout_time = (None if fate.dropout_at is None
                             else segments[0].start + fate.dropout_at * total)
