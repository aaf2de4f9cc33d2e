"""The manager trims plans (`fleetctl manager --trim`, `ManagerSettings.trim`): its core in memory.

A plan is trimmed when its run begins and when a console loads another; the run folder records
the plan the robots run (the trimmed one), its run record says so, and a manager resuming the
folder goes on trimming. A reroute's plan is trimmed before its hand-over. Runs are judged by what
the robots did (their true centres, the drives they were sent) and what the run log and the
consoles were told.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from fleet_common.formats import default_map_dirs
from fleet_common.formats.solution import format_solution, make_solution
from fleet_common.grid import Grid
from fleet_common.lab import lab_instance_path
from fleet_common.plan import Plan
from fleet_common.plan_loading import LoadedPlan, load_plan
from fleet_common.planning.trim import moves_of
from fleet_common.robot_size import TURTLEBOT2
from fleet_common.runlog.reader import RunFolder
from fleet_manager.resume import read_resume
from fleet_manager.settings import ManagerSettings
from memory_fleet import MemoryFleet, lab_fleet
from test_manager_reroute import STALL, assert_arrived_safely, crossing, run_to_end

#: Robot 1 goes round the block to (2, 0), two cells from its start; robot 2 drives down column 3;
#: robot 3 stands at (1, 1).
WINDING = [[(0, 0), (0, 1), (0, 2), (1, 2), (2, 2), (2, 1), (2, 0)],
           [(3, 3), (3, 2), (3, 1), (3, 0)],
           [(1, 1)]]


def winding() -> LoadedPlan:
    plan = Plan.from_paths(WINDING)
    grid = Grid(np.ones((4, 4), dtype=bool), name="open4")
    sol = make_solution(grid, "open4.map", plan, plan.starts, plan.goals, "hand", True, 0)
    return LoadedPlan(plan, grid, list(plan.starts), list(plan.goals), "winding", sol, lambda c: c)


def fleet(trim: bool) -> MemoryFleet:
    f = MemoryFleet(winding(), lab_fleet(3), ManagerSettings(step_time=0.5, size=TURTLEBOT2, trim=trim))
    f.ops = f.console()  # type: ignore[attr-defined]
    f.link_up()
    return f


def test_a_winding_plan_is_trimmed_before_its_run_and_the_robot_drives_straight():
    f = fleet(trim=True)
    run = f.core.run
    assert moves_of(run.plan) == 5 and run.plan.path(0)[:3] == [(0, 0), (1, 0), (2, 0)]
    assert run.loaded.note.endswith("trimmed: 4 moves fewer (9 to 5), 1 robot")
    assert f.folder_plans[0] == run.plan  # the run folder keeps the plan the robots run
    assert f.records[0][0] == "run" and f.records[0][2]["trim"] is True
    assert f.ask(f.ops, "start").ok  # type: ignore[attr-defined]
    seen = run_to_end(f)
    assert_arrived_safely(f, seen, TURTLEBOT2)
    assert len(f.sent(1, "drive")) == 2


def test_without_trim_the_robot_drives_the_plan_as_given():
    f = fleet(trim=False)
    assert moves_of(f.core.run.plan) == 9 and f.records[0][2]["trim"] is False
    assert f.ask(f.ops, "start").ok  # type: ignore[attr-defined]
    seen = run_to_end(f)
    assert_arrived_safely(f, seen, TURTLEBOT2)
    assert len(f.sent(1, "drive")) == 6


def resumed_trim(f: MemoryFleet) -> bool:
    """Whether a manager resuming the first run folder of `f` would trim (what it reads back)."""
    records = [dict(fields, k=kind, t=t) for kind, t, fields in f.folder_records[0]]
    records[0].setdefault("started", None)
    return read_resume(RunFolder(Path("memory-run"), records, torn=False)).trim


def test_a_manager_resuming_the_folder_goes_on_trimming():
    assert resumed_trim(fleet(trim=True)) is True
    assert resumed_trim(fleet(trim=False)) is False


def lab_lacam_text() -> str:
    """The lab instance as LaCAM plans it with seed 1: one robot winds, 10 moves to spare."""
    loaded = load_plan(lab_instance_path(), 5, "the lab fleet", default_map_dirs(), solver="lacam", seed=1)
    sol = make_solution(loaded.grid, "lab.map", loaded.plan, loaded.starts, loaded.goals, "lacam", True, 0)
    return format_solution(sol)


def test_a_plan_a_console_loads_is_trimmed_and_recorded_trimmed():
    lab = load_plan(lab_instance_path(), 5, "the lab fleet", [])
    f = MemoryFleet(lab, lab_fleet(), ManagerSettings(step_time=0.5, trim=True, map_dirs=default_map_dirs()))
    ops = f.console()
    f.link_up()
    assert "trimmed" in f.core.run.loaded.note  # CBS's plan: nothing to spare, and it says so
    answer = f.ask(ops, "load", text=lab_lacam_text(), name="lacam.txt")
    assert answer.ok, answer.reason
    run = f.core.run
    assert moves_of(run.plan) == 57 and run.loaded.note.endswith("trimmed: 10 moves fewer (67 to 57), 1 robot")
    assert f.folders == 2 and f.folder_plans[1] == run.plan
    assert f.folder_records[1][0][2]["trim"] is True


def test_a_plan_a_console_loads_is_not_trimmed_without_trim():
    lab = load_plan(lab_instance_path(), 5, "the lab fleet", [])
    f = MemoryFleet(lab, lab_fleet(), ManagerSettings(step_time=0.5, map_dirs=default_map_dirs()))
    ops = f.console()
    f.link_up()
    assert f.ask(ops, "load", text=lab_lacam_text(), name="lacam.txt").ok
    assert moves_of(f.core.run.plan) == 67 and "trimmed" not in f.core.run.loaded.note


def test_a_reroute_with_trim_is_handed_over_and_the_run_ends_safely():
    """The crossing of test_manager_reroute.py (robot 1 stalls, robot 2 is held up), rerouting in
    auto mode with trim: the reroute is handed over and every robot arrives, never too close."""
    f = MemoryFleet(crossing(), lab_fleet(3), ManagerSettings(step_time=0.5, size=TURTLEBOT2, reroute="auto",
                                                               reroute_timed=False, trim=True), speed=1.0)
    assert f.core.run.rerouting.rule.trim is True
    f.robots[1].navigator.stalls = {1: STALL}
    ops = f.console()
    f.link_up()
    assert f.ask(ops, "start").ok
    seen = run_to_end(f)
    assert_arrived_safely(f, seen, TURTLEBOT2)
    assert f.kinds("reroute")


def test_trim_switched_on_before_start_trims_the_plan_waiting_and_a_resumed_manager_keeps_it():
    """The operator ticks trim before pressing Start: the plan waiting is trimmed at once, in the
    same run folder (a plan record "trim"), the robot drives it, and Reset takes it again."""
    f = fleet(trim=False)
    ops = f.ops  # type: ignore[attr-defined]
    answer = f.ask(ops, "reroute", trim=True)
    assert answer.ok, answer.reason
    f.advance(0.1)
    assert ops.state.run.trim is True and f.core.run.rerouting.rule.trim is True
    assert any(n.text == "trim on: the plan waiting for Start is trimmed: 4 moves fewer (9 to 5), 1 robot; "
               "plans loaded from now on and the held scope's reroutes' plans are trimmed of moves that bring "
               "nobody in sooner" for n in ops.notices())
    assert [r for k, _, r in f.records if k == "reroute_mode"][-1]["trim"] is True
    run = f.core.run
    assert moves_of(run.plan) == 5 and run.plan.path(0)[:3] == [(0, 0), (1, 0), (2, 0)]
    plans = [r for k, _, r in f.records if k == "plan"]
    assert f.folders == 1 and plans[-1]["reason"] == "trim" and f.replans[plans[-1]["file"]] == run.plan
    again = f.ask(ops, "reroute", trim=True)
    assert again.ok and again.reason == "trim is on already"
    assert resumed_trim(f) is True
    assert f.ask(ops, "reset").ok  # the target again: the trimmed plan, not the one given
    assert moves_of(f.core.run.plan) == 5
    assert f.ask(ops, "reroute", trim=False).ok
    f.advance(0.1)
    assert ops.state.run.trim is False and f.core.run.rerouting.rule.trim is False
    assert moves_of(f.core.run.plan) == 5  # a trimmed plan stays: it brings nobody in later
    assert any(n.text == "trim off: plans from now on run as they are made" for n in ops.notices())
    assert not f.ask(ops, "reroute", trim="yes").ok  # a request's trim is true or false
    assert f.ask(ops, "start").ok
    seen = run_to_end(f)
    assert_arrived_safely(f, seen, TURTLEBOT2)
    assert len(f.sent(1, "drive")) == 2


def test_trim_switched_on_during_a_run_leaves_the_plan_running_as_it_is():
    f = fleet(trim=False)
    ops = f.ops  # type: ignore[attr-defined]
    assert f.ask(ops, "start").ok
    f.advance(0.6)
    assert f.sent(1, "drive")  # robot 1 is on its way round the block
    assert f.ask(ops, "reroute", trim=True).ok
    f.advance(0.1)
    assert any(n.text.startswith("trim on: plans loaded from now on and the held scope's reroutes' plans")
               and n.text.endswith("(the plan running stays as it is)") for n in ops.notices())
    assert moves_of(f.core.run.plan) == 9 and not [r for k, _, r in f.records if k == "plan"]
    seen = run_to_end(f)
    assert_arrived_safely(f, seen, TURTLEBOT2)
    assert len(f.sent(1, "drive")) == 6


def test_trimming_a_loaded_plan_leaves_the_plan_given_as_it_was():
    from fleet_common.plan_loading import trim_loaded

    given = winding()
    trimmed, result = trim_loaded(given)
    assert moves_of(trimmed.plan) == 5 and trimmed.solution.plan == trimmed.plan
    assert moves_of(given.plan) == 9 and given.solution.plan == given.plan  # held elsewhere, untouched
    assert "trimmed" not in given.note and trimmed.note.endswith("1 robot")
    assert result.plan == trimmed.plan and result.robots == (0,) and trimmed.note.endswith(result.describe())
