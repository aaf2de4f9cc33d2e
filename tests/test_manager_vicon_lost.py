"""A robot Vicon loses while the run takes its poses from Vicon: the run never plans from the last
pose Vicon had of it, which is moves old.

Vicon sees the robots from outside, 20 times a second here, each pose the robot's true one. When
the cameras lose a robot (occluded, out of view), its last Vicon pose stays where Vicon last saw
it while the robot drives on on its own. A pose that reached the manager before the robot's last
reply shows where it was, not where it is (`Robot.pose_settled`); before, Vicon's poses were
taken as they came, and the way to the starts was planned from where Vicon had last seen robot 3.
"""
from __future__ import annotations

from typing import List, Set

from fleet_common.robot_size import TURTLEBOT2
from fleet_common.vicon.base_grid import ViconFix
from fleet_manager import operator
from fleet_manager.robot import VICON
from fleet_manager.settings import ManagerSettings
from fleet_manager.vicon_watch import ViconWatch
from memory_fleet import MemoryFleet
from test_manager_core import closest_truth, fleet


def with_vicon() -> MemoryFleet:
    """The lab at the TurtleBot's size, Vicon on and the position source of every robot."""
    f = fleet(settings=ManagerSettings(step_time=0.5, size=TURTLEBOT2))
    f.core.vicon_watch = ViconWatch(f.core.fleet, f.core.out)
    f.core.fleet.choose(VICON)
    return f


def advance(f: MemoryFleet, seconds: float, hidden: Set[int], seen: List[float]) -> None:
    """Let `seconds` pass, Vicon reporting every robot but the `hidden` ones after each 0.05 s
    (their true poses), and the closest approach of true centres recorded in `seen`."""
    end = f.now + seconds
    while f.now < end - 1e-9:
        f.advance(0.05, step=0.05)
        fixes = [ViconFix("turtlebot{}".format(rid), r.navigator.true_pose(), 0, 0.0, False, rid)
                 for rid, r in f.robots.items() if rid not in hidden]
        f.core.vicon(fixes, f.now)
        closest_truth(f, seen)


def until(f: MemoryFleet, condition, limit: float, hidden: Set[int], seen: List[float]) -> bool:
    end = f.now + limit
    while not condition() and f.now < end:
        advance(f, 0.05, hidden, seen)
    return condition()


def test_the_way_to_the_starts_is_planned_from_where_a_robot_vicon_lost_really_stands():
    """Vicon loses robot 3 after its second move; it drives on. The operator stops the run and
    resets it (the robots drive back to their starts first): the way starts from the cell robot 3's replies put it on,
    not from the one Vicon last saw it on, and every robot reaches its start at a safe distance."""
    f = with_vicon()
    ops = f.console()
    f.link_up()
    seen: List[float] = []
    advance(f, 0.5, set(), seen)
    assert f.ask(ops, "start").ok
    robot3 = f.core.fleet.by_id[3]
    assert until(f, lambda: f.core.run.engine.run.completed[robot3.agent] >= 2, 30, set(), seen)
    last_seen = robot3.vicon.pose
    hidden = {3}
    assert until(f, lambda: f.core.run.engine.run.completed[robot3.agent] >= 5, 30, hidden, seen)
    assert f.ask(ops, "stop").ok
    assert until(f, lambda: not f.core.run.driver.moving, 10, hidden, seen)
    advance(f, 0.3, hidden, seen)
    truth = f.robots[3].navigator.true_pose()
    assert abs(truth.x - last_seen.x) + abs(truth.y - last_seen.y) >= 1.0  # Vicon's pose is moves old
    assert f.ask(ops, "reset").ok
    assert until(f, lambda: f.core.run.purpose == "plan" and not f.core.run.driver.moving, 60, hidden, seen)
    for rid, start in zip(f.core.fleet.ids, f.loaded.starts):
        at = f.robots[rid].navigator.true_pose()
        assert abs(at.x - start[0]) < 0.05 and abs(at.y - start[1]) < 0.05, (rid, at, start)
    assert min(seen) >= TURTLEBOT2.safe_cells - 0.01


def test_start_waits_for_vicon_to_see_a_robot_it_lost_and_says_so():
    """After a reset drove the robots back to their starts, Vicon has not seen robot 3 since before its last move: Start
    says so and what the operator can do, and goes once Vicon sees robot 3 again."""
    f = with_vicon()
    ops = f.console()
    f.link_up()
    seen: List[float] = []
    advance(f, 0.5, set(), seen)
    assert f.ask(ops, "start").ok
    robot3 = f.core.fleet.by_id[3]
    assert until(f, lambda: f.core.run.engine.run.completed[robot3.agent] >= 3, 30, set(), seen)
    assert f.ask(ops, "stop").ok
    hidden = {3}
    assert until(f, lambda: not f.core.run.driver.moving, 10, hidden, seen)
    assert f.ask(ops, "reset").ok
    assert until(f, lambda: f.core.run.purpose == "plan" and not f.core.run.driver.moving, 60, hidden, seen)
    advance(f, 1.0, hidden, seen)  # Vicon's pose of robot 3 goes stale: Vicon has lost it
    answer = f.ask(ops, "start")
    assert not answer.ok and answer.reason == (
        "Vicon has not seen robot 3 since its last move: wait until it does, or choose the robot's own "
        "pose (position source)"), answer.reason
    assert "start" not in ops.state.run.allowed
    assert until(f, lambda: "start" in operator.allowed(f.core.run, f.now), 1.0, set(), seen)
    assert f.ask(ops, "start").ok
    assert until(f, lambda: f.phase == "done", 60, set(), seen) and f.at_goals()
    assert min(seen) >= TURTLEBOT2.safe_cells - 0.01
