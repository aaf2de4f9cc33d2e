"""The robot's command executor: ids run at most once, one command at a time, stop preempts."""
from __future__ import annotations

from typing import List, Optional, Tuple

import pytest
from hypothesis import given
from hypothesis import strategies as st

from fleet_common.wire import (Accepted, CommandExecutor, Completed, Connection, DriveToPosition,
                               Failed, GetStatus, Hello, MotionOutcome, MotionRefused, Pose, Role,
                               Release, Status, Stop, Turn, Welcome)


class FakeNavigator:
    """Records what it was asked to do; a motion ends when the test says so."""

    def __init__(self) -> None:
        self.started: List[Tuple] = []
        self.halts = 0
        self.outcome: Optional[MotionOutcome] = None
        self.fault_list: List[str] = []
        self.refuse: Optional[str] = None

    def start_drive(self, x: float, y: float, time: float, hold=None) -> None:
        if self.refuse:
            raise MotionRefused(self.refuse)
        self.started.append(("drive", x, y, time) if hold is None else ("drive", x, y, time, hold))

    def release(self, x: float, y: float) -> None:
        self.started.append(("release", x, y))

    def start_turn(self, angle: float) -> None:
        self.started.append(("turn", angle))

    def halt(self) -> None:
        self.halts += 1
        self.outcome = None

    def poll(self) -> Optional[MotionOutcome]:
        outcome, self.outcome = self.outcome, None
        return outcome

    def pose(self) -> Pose:
        return Pose(1.0, 2.0, 0.5)

    def faults(self) -> List[str]:
        return self.fault_list


def replies(routed: list) -> list:
    return [reply for _, reply in routed]


@pytest.fixture
def nav() -> FakeNavigator:
    return FakeNavigator()


def test_a_duplicate_is_acknowledged_again_but_not_executed(nav: FakeNavigator) -> None:
    ex = CommandExecutor(nav)
    assert replies(ex.handle("e", DriveToPosition(1, 2, 3, 4))) == [Accepted(1)]
    assert replies(ex.handle("e", DriveToPosition(1, 2, 3, 4))) == [Accepted(1, duplicate=True)]
    nav.outcome = MotionOutcome(True)
    assert ex.poll() == [("e", Completed(1))]
    # after it finished, a copy gets the whole story again
    assert replies(ex.handle("e", DriveToPosition(1, 2, 3, 4))) == [
        Accepted(1, duplicate=True), Completed(1)]
    assert nav.started == [("drive", 2, 3, 4)]
    assert ex.executed == 1


def test_the_same_id_from_another_manager_epoch_is_a_new_command(nav: FakeNavigator) -> None:
    ex = CommandExecutor(nav)
    ex.handle("old", Turn(1, 0.5))
    nav.outcome = MotionOutcome(True)
    ex.poll()
    assert replies(ex.handle("new", Turn(1, 1.0))) == [Accepted(1)]
    assert nav.started == [("turn", 0.5), ("turn", 1.0)]


def test_one_command_at_a_time(nav: FakeNavigator) -> None:
    ex = CommandExecutor(nav)
    ex.handle("e", Turn(1, 0.5))
    assert replies(ex.handle("e", DriveToPosition(2, 1, 1, 0))) == [
        Failed(2, "busy with command 1; send stop first or wait for it")]
    assert ex.current == 1 and len(nav.started) == 1
    # a refused command stays refused when sent again, and is still not run
    nav.outcome = MotionOutcome(True)
    ex.poll()
    assert replies(ex.handle("e", DriveToPosition(2, 1, 1, 0))) == [
        Failed(2, "busy with command 1; send stop first or wait for it")]
    assert len(nav.started) == 1


def test_stop_preempts_and_a_repeated_stop_does_not_stop_a_later_command(nav: FakeNavigator) -> None:
    ex = CommandExecutor(nav)
    ex.handle("e", DriveToPosition(1, 2, 2, 10))
    assert ex.handle("e", Stop(2)) == [
        ("e", Failed(1, "stopped by command 2")), ("e", Accepted(2)), ("e", Completed(2))]
    assert ex.current is None and nav.halts == 1
    ex.handle("e", Turn(3, 1.0))
    assert replies(ex.handle("e", Stop(2))) == [Accepted(2, duplicate=True), Completed(2)]
    assert ex.current == 3 and nav.halts == 1


def test_a_failed_motion_is_reported_with_the_navigators_reason(nav: FakeNavigator) -> None:
    ex = CommandExecutor(nav)
    ex.handle("e", DriveToPosition(1, 2, 2, 10))
    assert ex.poll() == []
    nav.outcome = MotionOutcome(False, "bumper pressed")
    nav.fault_list = ["bumper"]
    assert ex.poll() == [("e", Failed(1, "bumper pressed"))]
    assert ex.status(9) == Status(9, Pose(1.0, 2.0, 0.5), None, ("bumper",))
    assert replies(ex.handle("e", Turn(2, 0))) == [Failed(2, "robot has faults: bumper")]


def test_refusals_by_the_navigator_and_bad_times(nav: FakeNavigator) -> None:
    ex = CommandExecutor(nav)
    nav.refuse = "cell (2, 2) is taken"
    assert replies(ex.handle("e", DriveToPosition(1, 2, 2, 0))) == [
        Failed(1, "cell (2, 2) is taken")]
    assert replies(ex.handle("e", DriveToPosition(2, 1, 1, -1))) == [
        Failed(2, "time must be 0 (as fast as allowed) or more seconds, got -1")]
    assert ex.current is None


def test_status_reports_the_running_command(nav: FakeNavigator) -> None:
    ex = CommandExecutor(nav)
    ex.handle("e", Turn(4, 1.0))
    assert replies(ex.handle("e", GetStatus(5))) == [Status(5, Pose(1.0, 2.0, 0.5), 4, ())]


def test_an_id_too_old_to_remember_is_refused_not_run(nav: FakeNavigator) -> None:
    ex = CommandExecutor(nav, memory=2)
    for i in range(1, 4):
        ex.handle("e", Turn(i, 0.1 * i))
        nav.outcome = MotionOutcome(True)
        ex.poll()
    assert replies(ex.handle("e", Turn(1, 0.1))) == [
        Failed(1, "command id 1 is older than the last 2 remembered; it is not executed again")]
    assert len(nav.started) == 3


@given(st.lists(st.tuples(st.sampled_from(["a", "b"]), st.integers(0, 6),
                          st.sampled_from(["turn", "stop", "finish"])), max_size=40))
def test_no_command_id_is_ever_executed_twice(script: list) -> None:
    nav = FakeNavigator()
    ex = CommandExecutor(nav)
    executed: List[Tuple[str, int]] = []  # (epoch, id) of each turn started or stop carried out
    for epoch, cid, what in script:
        if what == "finish":
            nav.outcome = MotionOutcome(True)
            ex.poll()
            continue
        before = (len(nav.started), nav.halts)
        routed = ex.handle(epoch, Turn(cid, float(cid)) if what == "turn" else Stop(cid))
        if (len(nav.started), nav.halts) != before:
            executed.append((epoch, cid))
        # the sender always hears about its command, first or again
        assert any(r.id == cid for _, r in routed)
    assert len(executed) == len(set(executed))
    assert ex.executed == len(executed)


def test_a_command_resent_over_a_new_connection_runs_once(nav: FakeNavigator) -> None:
    """The manager loses its connection mid-command and sends the command again."""
    ex = CommandExecutor(nav)
    for attempt in range(2):
        manager, robot = Connection(Role.MANAGER, 1), Connection(Role.ROBOT, 1)
        robot.receive(manager.send(Hello(1, "epoch-7")))
        manager.receive(robot.send(Welcome(1, "s", 9980)))
        command = robot.receive(manager.send(DriveToPosition(10, 2, 2, 3)))
        got = [manager.receive(robot.send(r)) for _, r in ex.handle(robot.epoch, command)]
        assert got == [Accepted(10, duplicate=attempt == 1)]
    nav.outcome = MotionOutcome(True)
    [(epoch, done)] = ex.poll()
    assert manager.receive(robot.send(done)) == Completed(10)
    assert len(nav.started) == 1 and manager.in_flight == {}


def test_a_release_moves_the_running_drives_hold_point_and_is_done_at_once(nav: FakeNavigator) -> None:
    ex = CommandExecutor(nav)
    assert replies(ex.handle("e", DriveToPosition(1, 2, 3, 0, (2.0, 2.4)))) == [Accepted(1)]
    assert nav.started == [("drive", 2, 3, 0, (2.0, 2.4))]
    # it never waits behind the drive it releases, and the drive goes on running
    assert replies(ex.handle("e", Release(2, 1, 2.0, 2.8))) == [Accepted(2), Completed(2)]
    assert nav.started[-1] == ("release", 2.0, 2.8) and ex.current == 1
    # a release sent again is acknowledged, not applied twice; one for another drive does nothing
    assert replies(ex.handle("e", Release(2, 1, 2.0, 2.8))) == [Accepted(2, duplicate=True), Completed(2)]
    assert replies(ex.handle("e", Release(3, 9, 2.0, 3.0))) == [Accepted(3), Completed(3)]
    assert [c for c in nav.started if c[0] == "release"] == [("release", 2.0, 2.8)]
    nav.outcome = MotionOutcome(True)
    assert ex.poll() == [("e", Completed(1))]
    assert replies(ex.handle("e", Release(4, 1, 2.0, 3.0))) == [Accepted(4), Completed(4)]  # too late: nothing
    assert len([c for c in nav.started if c[0] == "release"]) == 1


def test_the_last_motion_ended_is_named_whatever_ended_it(nav: FakeNavigator) -> None:
    """Pose feedback names it (`PoseFeedback.ended`): a manager tells an idle pose taken before a
    motion began from one taken after it ended. Completed and stopped motions end; a refused one
    never began (refused while another runs, the running one ends after it); a stop, a release
    and a status question are not motions."""
    ex = CommandExecutor(nav)
    assert ex.ended is None
    ex.handle("m", DriveToPosition(1, 1.0, 3.0, 2.0))  # (the robot stands at (1, 2))
    ex.handle("m", Release(2, 1, 1.0, 3.0))
    ex.handle("m", GetStatus(3))
    assert ex.ended is None and ex.current == 1  # running
    nav.outcome = MotionOutcome(True)
    ex.poll()
    assert ex.ended == 1 and ex.current is None
    ex.handle("m", Turn(4, 1.0))
    ex.handle("m", Stop(5))  # stops the turn
    assert ex.ended == 4
    ex.handle("m", Stop(6))  # nothing to stop
    assert ex.ended == 4
    ex.handle("m", DriveToPosition(7, 2.0, 2.0, 2.0))
    assert replies(ex.handle("m", Turn(8, 0.5)))[0].reason.startswith("busy with command 7")
    nav.outcome = MotionOutcome(True)
    ex.poll()
    assert ex.ended == 7  # the last to end, not the one refused meanwhile
    nav.refuse = "blocked"
    assert replies(ex.handle("m", DriveToPosition(9, 2.0, 2.0, 2.0)))[0] == Failed(9, "blocked")
    assert ex.ended == 7
