"""A robot Vicon loses while the run takes its poses from Vicon: the run never plans from the last
pose Vicon had of it, which is moves old.

Vicon sees the robots from outside (`memory_fleet.MemoryVicon`: a hundred frames a second of their
true poses, 5-30 ms late). When the cameras lose a robot (occluded, out of view), its last Vicon
pose stays where Vicon last saw it while the robot drives on on its own. A pose that reached the
manager before the robot's last reply shows where it was, not where it is (`Robot.pose_settled`);
before, Vicon's poses were taken as they came, and the way back to the starts was planned from
where Vicon had last seen robot 3.
"""
from __future__ import annotations

import random

from fleet_common.robot_size import TURTLEBOT2
from fleet_manager import operator
from fleet_manager.robot import VICON
from fleet_manager.settings import ManagerSettings
from memory_fleet import MemoryFleet, MemoryVicon, lab_fleet
from test_manager_core import lab

FOR_EVER = 1e9


def with_vicon() -> MemoryFleet:
    """The lab at the TurtleBot's size, Vicon on and the position source of every robot."""
    f = MemoryFleet(lab(), lab_fleet(), ManagerSettings(step_time=0.5, size=TURTLEBOT2),
                    vicon=MemoryVicon(random.Random(1), drops=0.0))
    f.core.fleet.choose(VICON)
    return f


def started_with_vicon(robot_3_moves: int):
    """`with_vicon`, the first poses in, started, until robot 3 has made `robot_3_moves` moves."""
    f = with_vicon()
    ops = f.console()
    f.link_up()
    f.advance(0.5)
    assert f.ask(ops, "start").ok
    assert f.run_until(lambda: completed(f, 3) >= robot_3_moves, 30)
    return f, ops


def completed(f: MemoryFleet, rid: int) -> int:
    return f.core.run.engine.run.completed[f.core.fleet.by_id[rid].agent]


def test_the_way_to_the_starts_is_planned_from_where_a_robot_vicon_lost_really_stands():
    """Vicon loses robot 3 after its second move; it drives on. The operator stops the run and
    resets it (the robots drive back to their starts first): the way starts from the cell robot
    3's replies put it on, not from the one Vicon last saw it on, and every robot reaches its start
    at a safe distance."""
    f, ops = started_with_vicon(robot_3_moves=2)
    last_seen = f.core.fleet.by_id[3].vicon.pose
    f.vicon.occlude(3, FOR_EVER)
    assert f.run_until(lambda: completed(f, 3) >= 5, 30)
    assert f.ask(ops, "stop").ok
    assert f.run_until(lambda: not f.core.run.driver.moving, 10)
    f.advance(0.3)
    truth = f.robots[3].navigator.true_pose()
    assert abs(truth.x - last_seen.x) + abs(truth.y - last_seen.y) >= 1.0  # Vicon's pose is moves old
    assert f.ask(ops, "reset").ok
    assert f.run_until(lambda: f.core.run.purpose == "plan" and not f.core.run.driver.moving, 60)
    for rid, start in zip(f.core.fleet.ids, f.loaded.starts):
        at = f.robots[rid].navigator.true_pose()
        assert abs(at.x - start[0]) < 0.05 and abs(at.y - start[1]) < 0.05, (rid, at, start)
    assert f.closest[0] >= TURTLEBOT2.safe_cells - 0.01, f.closest


def test_start_waits_for_vicon_to_see_a_robot_it_lost_and_says_so():
    """After a reset drove the robots back to their starts, Vicon has not seen robot 3 since before
    its last move: Start says so and what the operator can do, and goes once Vicon sees robot 3
    again."""
    f, ops = started_with_vicon(robot_3_moves=3)
    assert f.ask(ops, "stop").ok
    f.vicon.occlude(3, FOR_EVER)
    assert f.run_until(lambda: not f.core.run.driver.moving, 10)
    assert f.ask(ops, "reset").ok
    assert f.run_until(lambda: f.core.run.purpose == "plan" and not f.core.run.driver.moving, 60)
    f.advance(1.0)  # Vicon's pose of robot 3 goes stale: Vicon has lost it
    answer = f.ask(ops, "start")
    assert not answer.ok and answer.reason == (
        "Vicon has not seen robot 3 since its last move: wait until it does, or choose the robot's own "
        "pose (position source)"), answer.reason
    assert "start" not in ops.state.run.allowed
    f.vicon.occluded[3] = f.now  # seen again
    assert f.run_until(lambda: "start" in operator.allowed(f.core.run, f.now), 1.0)
    assert f.ask(ops, "start").ok
    assert f.run_until(lambda: f.phase == "done", 60) and f.at_goals()
    assert f.closest[0] >= TURTLEBOT2.safe_cells - 0.01, f.closest


def replan_waiting_for_robot_3():
    """The run on Vicon; robot 3 occluded for 8 s and a replan asked for, 3 s ago (the robots
    stand, the replan waits for a pose of robot 3 taken since its last move)."""
    camera = MemoryVicon(random.Random(3))
    f = MemoryFleet(lab(), lab_fleet(5), settings=ManagerSettings(step_time=0.5, size=TURTLEBOT2), vicon=camera)
    ops = f.console()
    f.link_up()
    f.advance(0.1)
    assert f.ask(ops, "source", source="vicon").ok and f.ask(ops, "start").ok
    assert f.run_until(lambda: sum(f.core.run.engine.run.completed) >= 4, 20)
    camera.occlude(3, f.now + 8.0)
    assert f.ask(ops, "replan").ok
    f.advance(3.0)
    return f, ops


def test_a_replan_waiting_for_vicon_says_so_in_its_line_and_what_to_do() -> None:
    """Robot 3 is occluded while a replan waits for the robots to stop. The robots stand, and the
    replan waits for a pose of robot 3 taken since its last move. Its line said "waiting for every
    robot to finish its move" all along (a live Vicon session, 1023: 33 s). It names the robot
    now, and what to do; choosing robot 3's own pose lets the replan go on, and the line says
    what comes of it: the proposal. The control keeps the old line."""
    f, ops = replan_waiting_for_robot_3()
    assert ops.state.run.reason == ("replanning: Vicon has not seen robot 3 since its last move: wait until it "
                                    "does, or choose the robot's own pose (position source)"), ops.state.run.reason
    assert f.ask(ops, "source", source="robot", robot=3).ok
    assert f.run_until(lambda: f.core.run.replanner.proposal_id is not None, 10)
    f.advance(0.1)
    assert ops.state.run.reason.startswith("replan {} proposed (".format(f.core.run.replanner.proposal_id))
    assert ops.state.run.reason.endswith("): accept or reject it")


def test_a_replan_line_that_does_not_name_the_robot_vicon_lost_is_caught(monkeypatch) -> None:
    from fleet_manager import core
    monkeypatch.setattr(core.RunCore, "_say_replan_waits", lambda self: None)
    f, ops = replan_waiting_for_robot_3()
    assert "Vicon has not seen robot 3" not in ops.state.run.reason
