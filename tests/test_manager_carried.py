"""Robots moved by hand while a run is under way (`fleet_manager.carried`), over the in-memory
manager: lab staff carry a robot they disabled onto the path of another, or put it back; the
run halts, names it, refuses to drive on until it is back or a replan has it where it stands, and
no two robots really come closer than the safe distance (the fleet's true poses). The control
takes the check out: the next robot drives into the carried one."""
from __future__ import annotations

import math
from typing import Optional, Tuple

from fleet_common.robot_size import TURTLEBOT2
from fleet_manager import carried as carried_module
from fleet_manager import core, operator
from fleet_manager.settings import ManagerSettings
from memory_fleet import MemoryFleet
from test_manager_core import answered
from test_manager_resume import carry, lab, started_run

SAFE = TURTLEBOT2.safe_cells


def disabled_in_the_way(paused: bool) -> Tuple[MemoryFleet, int, Tuple[int, int], Tuple[int, int]]:
    """The lab plan, ten moves made; the operator disables robot 1 (pausing first if `paused`),
    and staff carry it onto the cell robot 3 enters next but one, ahead of it. The fleet, the
    robot carried, where the run has it, and where it was put."""
    f = started_run(lab(), settings=ManagerSettings(step_time=0.5, size=TURTLEBOT2))
    ops = f.console()
    assert f.run_until(lambda: sum(f.core.run.engine.run.completed) >= 10)
    if paused:
        assert f.ask(ops, "pause").ok
    assert f.run_until(lambda: f.robots[1].executor.current is None and not f.robots[1].navigator.moving, 10)
    assert f.ask(ops, "disable", robot=1).ok
    f.advance(0.3)
    engine = f.core.run.engine
    here = tuple(f.core.run.positions()[0])
    agent = f.core.fleet.by_id[3].agent
    nxt = engine.run.next_incomplete(agent)
    cell = tuple(engine.table.coord(engine.run.dst[nxt + 1]))  # two moves on: not in its way yet
    f.closest = None
    carry(f, 1, *cell)
    return f, 1, here, cell


def worst(f: MemoryFleet) -> float:
    return math.inf if f.closest is None else f.closest[0]


def test_a_robot_carried_into_the_way_of_others_while_paused_stops_the_run_until_replanned() -> None:
    f, rid, here, cell = disabled_in_the_way(paused=True)
    ops = f.console()
    f.advance(0.5)
    answer = f.ask(ops, "start")
    shown = f.core.run.loaded.show
    assert not answer.ok
    assert "robot 1 stands at {}, away from {} where the run has it".format(
        "({}, {})".format(*shown(cell)), shown(here)) in answer.reason
    assert "put it back where it was, or on a free cell and replan" in answer.reason
    assert not f.ask(ops, "step").ok
    enable = f.ask(ops, "enable", robot=rid)
    assert not enable.ok and "then enable it" in enable.reason
    assert f.ask(ops, "replan").ok
    answered(f, ops)
    assert tuple(f.core.run.positions()[0]) == cell, "the replan plans from where it stands"
    assert f.ask(ops, "start").ok
    assert f.ask(ops, "enable", robot=rid).ok
    f.advance(0.3)
    if f.core.run.replanner.proposal_id is not None or f.core.run.stranded:
        assert f.ask(ops, "replan").ok
        answered(f, ops)
        f.ask(ops, "start")
    assert f.run_until(lambda: f.phase == "done", 120) and f.at_goals()
    assert worst(f) >= SAFE - 1e-3, f.closest


def test_a_robot_carried_while_the_run_runs_halts_it_and_nobody_drives_into_it() -> None:
    f, rid, here, cell = disabled_in_the_way(paused=False)
    ops = f.console()
    assert f.run_until(lambda: f.phase == "paused", 2), "the run halts by itself"
    assert "halted: robot 1 stands at" in f.core.run.phase.reason
    assert any("halted: robot 1 stands at" in n.text for n in ops.notices())
    f.advance(5.0)  # the others finish their moves, or stop short of it
    assert worst(f) >= SAFE - 1e-3, f.closest
    assert not f.ask(ops, "start").ok
    carry(f, rid, *here)  # put back where the run has it
    f.advance(0.3)
    assert f.ask(ops, "start").ok, "back where the run has it: the run goes on"
    assert f.ask(ops, "enable", robot=rid).ok
    assert f.run_until(lambda: f.phase == "done", 120) and f.at_goals()
    assert worst(f) >= SAFE - 1e-3, f.closest


def test_a_robot_put_down_between_two_cells_is_to_be_put_on_one_before_a_replan() -> None:
    f, rid, here, cell = disabled_in_the_way(paused=True)
    ops = f.console()
    carry(f, rid, cell[0] + 0.5, float(cell[1]))
    f.advance(0.5)
    replan = f.ask(ops, "replan")
    assert not replan.ok and "not on a free cell's centre: put it on one (or back), then replan" in replan.reason
    carry(f, rid, *cell)
    f.advance(0.3)
    assert f.ask(ops, "replan").ok


def test_a_robot_carried_and_not_noticed_is_driven_into(monkeypatch) -> None:
    """The control: without the check the run goes on with robot 1 where it last saw it, and
    robot 3 drives into it."""
    for module in (carried_module, core, operator):
        monkeypatch.setattr(module, "carried", lambda run: [])
    f, rid, here, cell = disabled_in_the_way(paused=True)
    ops = f.console()
    f.advance(0.5)
    assert f.ask(ops, "start").ok
    f.run_until(lambda: worst(f) < SAFE - 1e-3, 30)
    assert worst(f) < SAFE - 1e-3


def moved(f: MemoryFleet) -> Optional[str]:
    return carried_module.carried_words(f.core.run, carried_module.carried(f.core.run)) or None


def test_robots_the_run_halted_between_cells_are_where_the_run_has_them() -> None:
    """What the run itself leaves between cells is where the run has it: a fleet halted in the
    middle of its moves drives on at Start. (Random operator sessions check the rest: bumpers,
    replans that leave robots between cells, restarts.)"""
    f = started_run(lab(), settings=ManagerSettings(step_time=0.5, size=TURTLEBOT2))
    ops = f.console()

    def between() -> bool:
        return any(math.hypot(p.x - round(p.x), p.y - round(p.y)) > 0.35
                   for p in (r.navigator.true_pose() for r in f.robots.values()))
    assert f.run_until(between)
    assert f.ask(ops, "halt").ok
    f.advance(1.0)
    assert between(), "a robot stands between two cells"
    assert moved(f) is None
    assert f.ask(ops, "start").ok
    assert f.run_until(lambda: f.phase == "done", 120) and f.at_goals()


def pushed_off_its_goal() -> MemoryFleet:
    """The lab plan; robot 3 is home early, and a visitor pushes it 0.45 cells off its goal towards
    the cell robot 5 will drive through later."""
    f = started_run(lab(), settings=ManagerSettings(step_time=0.5, size=TURTLEBOT2))
    robot = f.core.fleet.by_id[3]
    goal = f.core.run.loaded.goals[robot.agent]
    navigator = f.robots[3].navigator
    assert f.run_until(lambda: f.core.run.engine.run.finished_agent(robot.agent) and not navigator.moving
                       and robot.flight is None, 60)
    f.closest = None
    carry(f, 3, goal[0], goal[1] - 0.45)
    return f


def test_a_robot_pushed_half_a_cell_towards_a_neighbour_others_pass_halts_the_run() -> None:
    """Between its cell and a neighbour is where the run has a robot only when the run put it
    there (a move it was sent, failed or halted in; one it is planned to finish first; a cell a
    replan walled off around it): pushed there, robot 3 halts the run, the replan walls that cell
    off, and robot 5 drives round it (before, robot 5 passed 0.55 cells from it, the safe distance
    0.65)."""
    f = pushed_off_its_goal()
    ops = f.console()
    assert f.run_until(lambda: f.phase == "paused", 2), "the run halts by itself"
    assert "halted: robot 3 stands at" in f.core.run.phase.reason
    assert not f.ask(ops, "start").ok
    assert f.ask(ops, "replan").ok  # planned from where it stands: the cell it leans into walled off
    answered(f, ops)
    assert f.ask(ops, "start").ok
    assert f.run_until(lambda: f.phase == "done", 120)
    goals = f.core.run.loaded.goals
    assert all(math.hypot(f.robots[rid].navigator.true_pose().x - goals[rid - 1][0],
                          f.robots[rid].navigator.true_pose().y - goals[rid - 1][1]) < 0.3 for rid in (1, 2, 4, 5))
    assert worst(f) >= SAFE - 1e-3, f.closest


def test_a_robot_pushed_towards_a_neighbour_and_taken_as_stopped_in_a_move_is_driven_past(monkeypatch) -> None:
    """The control: the rule before 2026-11-27, anywhere between a robot's cell and a neighbour is
    where the run has it; the run goes on and robot 5 passes too close."""
    where = carried_module.where_the_run_has_it

    def between_is_fine(run, robot, pose, here, holding):
        far = carried_module.towards(pose, here)
        if (carried_module.to_segment(pose, here, far) <= carried_module.AT_CELL
                and math.hypot(pose[0] - far[0], pose[1] - far[1]) > carried_module.AT_CELL):
            return True
        return where(run, robot, pose, here, holding)
    monkeypatch.setattr(carried_module, "where_the_run_has_it", between_is_fine)
    f = pushed_off_its_goal()
    f.run_until(lambda: f.phase == "done", 60)
    assert worst(f) < SAFE - 1e-3
