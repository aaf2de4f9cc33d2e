"""The runner's protocol side without ROS: the wire navigator (base cells <-> robot metres,
one motion at a time in a worker, the bumper fault) under fleet_common's command executor."""
from __future__ import annotations

import math
import threading
import time
from typing import Callable, List, Optional, Tuple

import pytest

from agv_package.geometry import Pose2D
from agv_package.grid_frame import GridFrame
from agv_package.navigator import DONE, BlockingNavigator
from agv_package.wire_navigator import BUMPER, NOT_LOCALIZED, WireNavigator
from fleet_common.lab import node_table
from fleet_common.wire import (Accepted, CommandExecutor, Completed, DriveToPosition, Failed,
                               GetStatus, MotionOutcome, Stop, Turn)
from fleet_common.wire.command_check import CommandCheck


class FakeNavigator(BlockingNavigator):
    """Records the calls in robot metres; a motion lasts until `finish()` or `stop()`."""

    def __init__(self) -> None:
        self.calls: List[Tuple[str, Tuple[float, ...]]] = []
        self.workers: List[threading.Thread] = []
        self.where: Optional[Pose2D] = Pose2D(0.7, 2.1, 0.0)  # base cell (0, 0)
        self._end = threading.Event()
        self._result = DONE
        self.clock = 100.0

    def now(self) -> float:
        return self.clock

    def drive_to_position(self, x: float, y: float, arrival: float, hold=None) -> MotionOutcome:
        self.calls.append(("drive", (x, y, arrival) if hold is None else (x, y, arrival) + tuple(hold)))
        return self._wait()

    def release(self, x: float, y: float) -> None:
        self.calls.append(("release", (x, y)))

    def turn(self, heading: float) -> MotionOutcome:
        self.calls.append(("turn", (heading,)))
        return self._wait()

    def _wait(self) -> MotionOutcome:
        self.workers.append(threading.current_thread())  # the thread a motion runs in
        self._end.wait(5.0)
        self._end.clear()
        return self._result

    def stop(self, reason: str) -> None:
        self.calls.append(("stop", ()))
        self._result = MotionOutcome(False, reason)
        self._end.set()

    def finish(self, result: MotionOutcome = DONE) -> None:
        self._result = result
        self._end.set()

    def pose(self) -> Optional[Pose2D]:
        return self.where


def wait_until(condition: Callable[[], bool], what: str, timeout: float = 2.0) -> None:
    """Wait for `condition` (the worker thread's doing), at most `timeout` seconds."""
    deadline = time.monotonic() + timeout
    while not condition():
        if time.monotonic() > deadline:
            raise AssertionError("timed out waiting for " + what)
        time.sleep(0.002)


def settle(executor: CommandExecutor, timeout: float = 2.0) -> list:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        replies = executor.poll()
        if replies:
            return [reply for _, reply in replies]
        time.sleep(0.005)
    raise AssertionError("no outcome")


@pytest.fixture
def robot() -> Tuple[FakeNavigator, WireNavigator, CommandExecutor]:
    fake = FakeNavigator()
    wire = WireNavigator(fake, GridFrame())
    return fake, wire, CommandExecutor(wire, check=CommandCheck(node_table().grid()))


def test_commands_in_cells_reach_the_navigator_in_metres(robot: tuple) -> None:
    fake, wire, executor = robot
    fake.where = Pose2D(2.1, 3.5, 0.0)  # cell (2, 2)
    assert executor.handle("e", DriveToPosition(1, 2.0, 3.0, 4.5)) == [("e", Accepted(1))]
    wait_until(lambda: len(fake.calls) == 1, "the drive to reach the navigator")
    kind, (x, y, arrival) = fake.calls[0]
    assert kind == "drive" and (x, y) == pytest.approx((2.1, 4.2)) and arrival == 104.5
    fake.finish()
    assert settle(executor) == [Completed(1)]
    executor.handle("e", Turn(2, math.pi / 2))
    wait_until(lambda: len(fake.calls) == 2, "the turn to reach the navigator")
    assert fake.calls[1] == ("turn", (pytest.approx(math.pi / 2),))
    fake.finish(MotionOutcome(False, "timed out"))
    assert settle(executor) == [Failed(2, "timed out")]
    fake.where = Pose2D(2.1, 4.2, math.pi)  # cell (2, 3)
    status = executor.handle("e", GetStatus(3))[0][1]
    assert (status.pose.x, status.pose.y) == pytest.approx((2.0, 3.0))
    assert status.pose.theta == pytest.approx(math.pi) and status.faults == ()


def test_a_command_sent_twice_moves_the_robot_once(robot: tuple) -> None:
    fake, wire, executor = robot
    executor.handle("e", DriveToPosition(7, 1.0, 0.0, 0.0))
    again = executor.handle("e", DriveToPosition(7, 1.0, 0.0, 0.0))
    assert again == [("e", Accepted(7, duplicate=True))]
    fake.finish()
    assert settle(executor) == [Completed(7)]
    assert executor.handle("e", DriveToPosition(7, 1.0, 0.0, 0.0))[-1][1] == Completed(7)
    assert [kind for kind, _ in fake.calls] == ["drive"]


def test_targets_off_the_free_grid_are_refused(robot: tuple) -> None:
    fake, wire, executor = robot
    fake.where = Pose2D(4.2, 2.8, 0.0)  # cell (5, 1), beside the lab's blocked cell (4, 1)
    reply = executor.handle("e", DriveToPosition(1, 4.0, 1.0, 0.0))[0][1]
    assert reply == Failed(1, "target (4, 1) is on the blocked cell (4, 1)")
    reply = executor.handle("e", DriveToPosition(2, 20.0, 1.0, 0.0))[0][1]
    assert reply == Failed(2, "target (20, 1) is off the 13x14 map")
    reply = executor.handle("e", DriveToPosition(3, 3.0, 1.0, 0.0))[0][1]
    assert isinstance(reply, Failed) and "one drive goes at most 1.5" in reply.reason
    assert fake.calls == []
    assert executor.handle("e", DriveToPosition(4, 5.0, 2.0, 0.0)) == [("e", Accepted(4))]
    fake.finish()


def test_stop_abandons_the_motion_and_reports_it_once(robot: tuple) -> None:
    fake, wire, executor = robot
    executor.handle("e", DriveToPosition(1, 1.0, 0.0, 0.0))
    wait_until(lambda: fake.calls, "the drive to reach the navigator")
    replies = [reply for _, reply in executor.handle("e", Stop(2))]
    assert replies == [Failed(1, "stopped by command 2"), Accepted(2), Completed(2)]
    wait_until(lambda: not any(t.is_alive() for t in fake.workers), "the stopped motion's worker to end")
    assert executor.poll() == [] and wire.poll() is None  # the worker's result is dropped


def test_bumper_stops_the_robot_and_holds_a_fault_until_released_and_stopped(
        robot: tuple) -> None:
    fake, wire, executor = robot
    executor.handle("e", DriveToPosition(1, 1.0, 0.0, 0.0))
    wait_until(lambda: fake.calls, "the drive to reach the navigator")
    wire.bumper(True)
    assert ("stop", ()) in fake.calls
    assert settle(executor) == [Failed(1, "bumper pressed: stopped on contact")]
    assert wire.faults() == [BUMPER] and wire.interlock() is not None
    refused = executor.handle("e", DriveToPosition(2, 1.0, 0.0, 0.0))[0][1]
    assert isinstance(refused, Failed) and "faults: bumper" in refused.reason
    executor.handle("e", Stop(3))  # still pressed: the stop does not clear it
    assert wire.faults() == [BUMPER]
    wire.bumper(False)
    assert wire.faults() == [BUMPER]  # released, not yet acknowledged
    executor.handle("e", Stop(4))
    assert wire.faults() == [] and wire.interlock() is None
    assert executor.handle("e", DriveToPosition(5, 1.0, 0.0, 0.0)) == [("e", Accepted(5))]
    fake.finish()


def test_no_pose_is_a_fault_and_feedback_keeps_the_last_pose(robot: tuple) -> None:
    fake, wire, executor = robot
    assert wire.pose().x == pytest.approx(0.0)
    fake.where = None
    assert wire.faults() == [NOT_LOCALIZED]
    assert wire.pose().y == pytest.approx(0.0)  # the last known, in cells
    reply = executor.handle("e", Turn(1, 0.0))[0][1]
    assert isinstance(reply, Failed) and NOT_LOCALIZED in reply.reason
