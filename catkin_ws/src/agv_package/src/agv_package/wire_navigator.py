"""The wire protocol's `PollingNavigator`, on top of the robot's `BlockingNavigator`.

`fleet_common.wire`'s executor drives a non-blocking interface in base-grid
cells (`start_drive`, `start_turn`, `halt`, `poll`, `pose`, `faults`). This
adapter gives it one:

- it converts between base cells and robot metres with the `GridFrame` (the
  only conversion on the robot, thesis 5.5), so commands and feedback on the
  wire are cells and everything below is metres (whether a target is on the
  map, free and one step away, the executor's `CommandCheck` has said);
- it runs each blocking motion in a worker thread and reports its outcome
  once through `poll`;
- it owns the faults: a bumper press stops the robot at once (thesis 3.6.1:
  on contact it stops all execution), fails the motion under way and latches
  the "bumper" fault, which refuses new motions until the bumper is released
  and the manager acknowledges with a `stop` command. "not localized" is a
  fault while the robot has no pose estimate.

Thread-safe: the protocol loop, the ROS callbacks and the worker call in.
"""
from __future__ import annotations

import math
import threading
from typing import Callable, List, Optional, Tuple

from fleet_common.wire.messages import Pose
from fleet_common.wire.navigator import MotionOutcome, MotionRefused

from .geometry import Pose2D
from .grid_frame import GridFrame
from .navigator import BlockingNavigator

BUMPER = "bumper"
NOT_LOCALIZED = "not localized"
#: How long a new motion waits for the previous (halted) one to wind down, seconds.
WIND_DOWN = 2.0


class WireNavigator:
    """Implements `fleet_common.wire.navigator.PollingNavigator` over a `BlockingNavigator`."""

    def __init__(self, navigator: BlockingNavigator, frame: GridFrame) -> None:
        self.navigator = navigator
        self.frame = frame
        self._lock = threading.Lock()
        self._worker: Optional[threading.Thread] = None
        self._outcome: Optional[MotionOutcome] = None
        self._generation = 0          # which start_* the worker's outcome belongs to
        self._bumper_latched = False
        self._bumper_pressed = False
        self._last_pose = Pose(0.0, 0.0, 0.0)

    # ---- the wire navigator interface --------------------------------------------

    def start_drive(self, x: float, y: float, time: float,
                    hold: Optional[Tuple[float, float]] = None) -> None:
        if not (math.isfinite(x) and math.isfinite(y)):
            raise MotionRefused("target ({}, {}) is not a point".format(x, y))
        goal = self.frame.point_to_robot(x, y)
        stop = None if hold is None else self.frame.point_to_robot(hold[0], hold[1])
        arrival = self.navigator.now() + time
        self._start(lambda: self.navigator.drive_to_position(goal[0], goal[1], arrival, stop))

    def release(self, x: float, y: float) -> None:
        if math.isfinite(x) and math.isfinite(y):
            point = self.frame.point_to_robot(x, y)
            self.navigator.release(point[0], point[1])

    def start_turn(self, angle: float) -> None:
        if not math.isfinite(angle):
            raise MotionRefused("heading {} is not an angle".format(angle))
        heading = self.frame.heading_to_robot(angle)
        self._start(lambda: self.navigator.turn(heading))

    def halt(self) -> None:
        with self._lock:
            self._generation += 1  # the motion under way is abandoned: no outcome for it
            if not self._bumper_pressed:
                self._bumper_latched = False  # a stop acknowledges a released bumper
        self.navigator.stop("halted")

    def poll(self) -> Optional[MotionOutcome]:
        with self._lock:
            outcome, self._outcome = self._outcome, None
        return outcome

    def pose(self) -> Pose:
        current = self.navigator.pose()
        if current is not None:
            base = self.frame.pose_to_base(current)
            with self._lock:
                self._last_pose = Pose(base.x, base.y, base.theta)
        with self._lock:
            return self._last_pose

    def faults(self) -> List[str]:
        found = []
        with self._lock:
            if self._bumper_latched:
                found.append(BUMPER)
        if self.navigator.pose() is None:
            found.append(NOT_LOCALIZED)
        return found

    # ---- events from the robot ---------------------------------------------------

    def bumper(self, pressed: bool) -> None:
        """The bumper state changed (any part pressed, or all released)."""
        with self._lock:
            self._bumper_pressed = pressed
            newly = pressed and not self._bumper_latched
            if pressed:
                self._bumper_latched = True
        if newly:
            self.navigator.stop("bumper pressed: stopped on contact")

    def interlock(self) -> Optional[str]:
        """Why the robot must not move now (for `ControlledNavigator.interlock`), or None."""
        with self._lock:
            return "bumper pressed: stopped on contact" if self._bumper_latched else None

    def robot_pose(self) -> Optional[Pose2D]:
        """The current estimate in the robot frame (metres), for local publishing."""
        return self.navigator.pose()

    # ---- internals ---------------------------------------------------------------

    def _start(self, motion: Callable[[], MotionOutcome]) -> None:
        previous = self._worker
        if previous is not None and previous.is_alive():
            previous.join(WIND_DOWN)
            if previous.is_alive():
                raise MotionRefused("the previous motion has not stopped yet")
        with self._lock:
            if self._bumper_latched:
                raise MotionRefused("bumper pressed: send stop once it is released")
            self._generation += 1
            generation = self._generation
            self._outcome = None

        def run() -> None:
            try:
                result = motion()
            except Exception as err:  # a crash must still settle the command
                result = MotionOutcome(False, "navigation failed: {}".format(err))
            with self._lock:
                if generation == self._generation:
                    self._outcome = result

        self._worker = threading.Thread(target=run, name="agv-motion", daemon=True)
        self._worker.start()
