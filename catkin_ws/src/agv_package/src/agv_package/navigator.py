"""The robot's navigation API (thesis 3.6.1), in robot-frame metres and radians.

`BlockingNavigator` is what the runner calls: `drive_to_position(x, y, arrival)` and
`turn(heading)` block until the motion is done, stopped or failed (like the
original `int driveToPosition(double x, double y, double time)`), `stop`
interrupts them from another thread, `pose` is the current estimate. A motion
ends in a `MotionOutcome`, the type the wire's `PollingNavigator` reports too.

`ControlledNavigator` implements it with the controllers of `motion` run in a
fixed-rate loop against two callables, where the pose comes from and where
velocities go, so the same code drives a ROS base (`ros_navigator`) and a
kinematic model in tests. A drive first turns in place to face the goal.
"""
from __future__ import annotations

import abc
import math
import threading
import time
from typing import Callable, Optional, Tuple, Union

from fleet_common.angles import wrap_angle
from fleet_common.wire.navigator import MotionOutcome

from .geometry import Pose2D
from .motion import STOP, DriveController, TurnController, Twist, needs_turn
from .settings import MotionSettings

#: Seconds a motion may run beyond its arrival time plus its slowest-speed duration.
TIMEOUT_SLACK = 10.0


DONE = MotionOutcome(True)


class BlockingNavigator(abc.ABC):
    """Moves the robot on the floor; all coordinates in the robot frame (metres, radians)."""

    @abc.abstractmethod
    def drive_to_position(self, x: float, y: float, arrival: float,
                          hold: Optional[Tuple[float, float]] = None) -> MotionOutcome:
        """Turn to face (x, y), then drive there, aiming to arrive at time `arrival`
        (seconds on this navigator's `now()` clock); with `hold`, wait at that point on
        the way until `release` moves it on."""

    @abc.abstractmethod
    def release(self, x: float, y: float) -> None:
        """The drive under way may go on as far as (x, y) (from another thread)."""

    @abc.abstractmethod
    def turn(self, heading: float) -> MotionOutcome:
        """Turn in place to the absolute `heading`."""

    @abc.abstractmethod
    def stop(self, reason: str) -> None:
        """Halt now; a motion in progress returns MotionOutcome(False, reason)."""

    @abc.abstractmethod
    def pose(self) -> Optional[Pose2D]:
        """The current pose estimate, None while the robot does not know where it is."""

    def now(self) -> float:
        return time.time()


PoseSource = Callable[[], Optional[Pose2D]]
TwistSink = Callable[[Twist], None]
#: Says why the robot must not move now (a pressed bumper), or None.
Interlock = Callable[[], Optional[str]]
Controller = Union[TurnController, DriveController]


class ControlledNavigator(BlockingNavigator):
    """A `BlockingNavigator` running feedback controllers at `settings.control_rate`."""

    def __init__(self, settings: MotionSettings, pose_source: PoseSource, send: TwistSink,
                 clock: Callable[[], float] = time.time,
                 sleep: Callable[[float], None] = time.sleep,
                 interlock: Optional[Interlock] = None) -> None:
        self.settings = settings
        #: Checked on every control step, so that a fault raised just as a motion begins
        #: still stops it.
        self.interlock = interlock
        self._pose_source = pose_source
        self._send = send
        self._clock = clock
        self._sleep = sleep
        self._lock = threading.Lock()
        self._stop_reason: Optional[str] = None
        self._drive: Optional[DriveController] = None  # the drive under way, for release
        self._released: Optional[Tuple[float, float]] = None  # a release before the drive began

    def now(self) -> float:
        return self._clock()

    def pose(self) -> Optional[Pose2D]:
        return self._pose_source()

    def stop(self, reason: str) -> None:
        with self._lock:
            self._stop_reason = reason
        self._send(STOP)

    def turn(self, heading: float) -> MotionOutcome:
        self._begin()
        return self._run(TurnController(self.settings, heading), self._turn_time(heading))

    def release(self, x: float, y: float) -> None:
        with self._lock:
            if self._drive is not None:
                self._drive.release((x, y))
            else:
                self._released = (x, y)

    def drive_to_position(self, x: float, y: float, arrival: float,
                          hold: Optional[Tuple[float, float]] = None) -> MotionOutcome:
        self._begin()
        start = self._pose_source()
        if start is None:
            return self._not_localized()
        drive = DriveController(self.settings, start, (x, y), arrival, hold)
        with self._lock:
            if self._released is not None:  # a release that came while it turned to start
                drive.release(self._released)
            self._drive, self._released = drive, None
        if needs_turn(start, drive.line_heading, self.settings):
            result = self._run(TurnController(self.settings, drive.line_heading),
                               self._turn_time(drive.line_heading))
            if not result.ok:
                return result
        distance = math.hypot(x - start.x, y - start.y)
        limit = max(arrival - self._clock(), 0.0) + distance / self.settings.min_speed
        try:
            return self._run(drive, limit)
        finally:
            with self._lock:
                self._drive = None

    # ---- the loop ----------------------------------------------------------------

    def _begin(self) -> None:
        with self._lock:
            self._stop_reason = None
            self._drive = self._released = None

    def _stopped(self) -> Optional[str]:
        with self._lock:
            reason = self._stop_reason
        if reason is None and self.interlock is not None:
            reason = self.interlock()
        return reason

    def _not_localized(self) -> MotionOutcome:
        self._send(STOP)
        return MotionOutcome(False, "not localized: no pose estimate (no floor tag seen yet, "
                                "or odometry stopped)")

    def _turn_time(self, heading: float) -> float:
        pose = self._pose_source()
        angle = abs(wrap_angle(heading - pose.theta)) if pose is not None else math.pi
        return angle / self.settings.min_turn_rate

    def _run(self, controller: Controller, expected: float) -> MotionOutcome:
        period = 1.0 / self.settings.control_rate
        deadline = self._clock() + expected + TIMEOUT_SLACK
        last = self._clock()
        while True:
            reason = self._stopped()
            if reason is not None:
                self._send(STOP)
                return MotionOutcome(False, reason)
            pose = self._pose_source()
            if pose is None:
                return self._not_localized()
            now = self._clock()
            if now > deadline:
                self._send(STOP)
                return MotionOutcome(False, "timed out: the motion took {:.0f} s longer than "
                                        "expected".format(TIMEOUT_SLACK))
            command = controller.step(pose, now, max(now - last, 1e-3))
            if getattr(controller, "holding", False):
                deadline += now - last  # waiting at a hold point is not slowness
            last = now
            if command is None:
                self._send(STOP)
                return DONE
            self._send(command)
            self._sleep(period)
