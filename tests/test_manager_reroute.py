"""The manager reroutes robots a late robot holds up (issue 28): its core in memory, on a fake clock.

The map is open, 5 x 5 cells. Robot 1 crosses row 1 from the west, robot 2
comes down column 2 to wait at (2, 2) for robot 1 to pass (2, 1), and robot 3
drives along row 4 and down, on its own. Robot 1 stalls 6 s in its first
move: robot 2 is held up, and going first pays. Every look runs in place by
the function the manager's worker thread runs (`rerouting.look`, no time
budget), so runs are repeatable. Runs are judged by what the robots did: every
robot at its goal, the true centres never closer than the safe distance, and
by what the run log, the consoles and the terminal were told.
"""
from __future__ import annotations

import math
from pathlib import Path
from typing import List, Optional, Tuple

import numpy as np
import pytest

from fleet_common.errors import FleetError
from fleet_common.execution.reroute import EVERY
from fleet_common.formats.solution import make_solution
from fleet_common.grid import Grid
from fleet_common.plan import Plan
from fleet_common.lab import lab_instance_path
from fleet_common.plan_loading import LoadedPlan, load_plan
from fleet_common.robot_size import TURTLEBOT2, RobotSize, cell_sized
from fleet_common.runlog.reader import RunFolder
from fleet_manager import driver as driver_module
from fleet_manager import resume as resume_module
from fleet_manager.resume import read_resume
from fleet_manager.settings import ManagerSettings
from memory_fleet import MemoryFleet, lab_fleet
from test_manager_resume import executions

PATHS = [[(0, 1), (1, 1), (2, 1), (3, 1), (4, 1)],
         [(2, 3), (2, 2), (2, 2), (2, 1), (2, 0)],
         [(0, 4), (1, 4), (2, 4), (3, 4), (4, 4), (4, 3), (4, 2)]]
STALL = 6.0  # s robot 1 halts in the middle of its first move


def crossing() -> LoadedPlan:
    plan = Plan.from_paths(PATHS)
    grid = Grid(np.ones((5, 5), dtype=bool), name="open5")
    sol = make_solution(grid, "open5.map", plan, plan.starts, plan.goals, "hand", True, 0)
    return LoadedPlan(plan, grid, list(plan.starts), list(plan.goals), "crossing", sol, lambda c: c)


def started(mode: str, size: RobotSize = cell_sized()) -> MemoryFleet:
    f = MemoryFleet(crossing(), lab_fleet(3), ManagerSettings(step_time=0.5, size=size, reroute=mode,
                                                              reroute_timed=False), speed=1.0)
    f.robots[1].navigator.stalls = {1: STALL}
    f.ops = f.console()  # type: ignore[attr-defined]
    f.link_up()
    assert f.ask(f.ops, "start").ok  # type: ignore[attr-defined]
    return f


def closest(f: MemoryFleet) -> float:
    poses = [r.navigator.true_pose() for r in f.robots.values()]
    return min(math.hypot(a.x - b.x, a.y - b.y) for i, a in enumerate(poses) for b in poses[i + 1:])


def run_to_end(f: MemoryFleet, limit: float = 40.0) -> List[float]:
    """Advance until the run is done; the closest pair of true centres at each tick."""
    seen: List[float] = []
    end = f.now + limit
    while f.phase != "done" and f.now < end:
        f.advance(0.05)
        seen.append(closest(f))
    return seen


def assert_arrived_safely(f: MemoryFleet, seen: List[float], size: RobotSize) -> None:
    assert f.phase == "done" and f.at_goals()
    assert min(seen) >= size.safe_cells - 0.01  # the robots' own braking tolerance aside
    summary = f.core.summary()
    assert len(summary.arrived) == 3 and summary.collisions == 0


@pytest.mark.parametrize("size", [cell_sized(), TURTLEBOT2], ids=["cell", "turtlebot2"])
def test_auto_mode_reroutes_the_held_up_robots_and_every_robot_arrives_safely(size):
    f = started("auto", size)
    seen = run_to_end(f)
    assert_arrived_safely(f, seen, size)
    (record,) = f.kinds("reroute")
    # by robot id, the late robot going round: robot 2 passes first
    assert record["robots"] == [1] and record["around"] == 1 and record["late"] >= 1 and record["gain"] >= 1
    assert record["text"].startswith("robot 1, late ") and "held up robot 2" in record["text"]
    assert record["plan"] == "plan-2.txt" and "plan-2.txt" in f.files
    (plan,) = f.kinds("plan")
    assert plan["reason"] == "reroute" and plan["file"] == "plan-2.txt"
    # the operator was told, on the terminal and in every console's event list
    assert any(record["text"] in line for line in f.said)
    assert any(n.text == record["text"] for n in f.ops.notices())
    assert f.ops.state.run.plan_id == 2 and f.ops.state.run.reroute == "auto"
    assert f.core.run.engine.show is f.core.run.loaded.show  # its messages keep the plan file's frame
    # the summary (and so `fleetctl report`) reads the folder's records across the hand-over
    assert "arrived: 3/3" in f.core.summary().lines()[0]
    # robot 2 went first at (2, 1): it did not wait out robot 1's stall (robot 1 arrives last anyway)
    off = started("off", size)
    run_to_end(off)
    assert f.core.summary().soc < off.core.summary().soc - 2.0
    assert f.core.summary().wait < off.core.summary().wait - 2.0


def test_an_auto_reroute_makes_stale_only_the_requests_about_the_robots_it_rerouted():
    """A console that has not yet seen an automatic reroute may still disable a robot the reroute
    left alone, or switch the strategy; a request about a rerouted robot is refused, naming the
    reroute (about one reroute a plan step at 300 robots would otherwise refuse most requests)."""
    f = started("auto")
    before, end = f.ops.version, f.now + 40
    while not f.kinds("reroute") and f.now < end:
        before = f.ops.version
        f.advance(0.05)
    (record,) = f.kinds("reroute")
    rerouted = record["robots"][0]
    other = next(r.id for r in f.core.fleet if r.id not in record["robots"])
    answer = f.ask(f.ops, "disable", based_on=before, robot=rerouted)
    assert not answer.ok and "plan 2 (reroute)" in answer.reason
    assert f.ask(f.ops, "disable", based_on=before, robot=other).ok
    assert f.ask(f.ops, "strategy", based_on=before, name="reorder").ok


@pytest.mark.parametrize("mode", ["auto", "propose"])
def test_the_plan_clock_a_console_shows_goes_on_across_a_reroute(mode):
    """The new plan starts at 0 (the console draws where it wants the robots from its step 0), but
    the clock a console shows is the run's: `plan_start` (the steps of the plan before) plus the
    new plan's; never backwards, and across the hand-over it moves on by the time that passed."""
    f = started(mode)
    if mode == "propose":
        assert f.ask(f.ops, "accept", proposal=wait_for_proposal(f)).ok
    run_to_end(f)
    assert f.phase == "done" and f.core.run.plan_id == 2
    runs = [s.run for s in f.ops.states if s.run.state in ("running", "done")]
    clock = [r.run_steps for r in runs]
    assert all(b >= a for a, b in zip(clock, clock[1:])), "the plan clock went back"
    k = next(i for i, r in enumerate(runs) if r.plan_id == 2)
    before, after = runs[k - 1], runs[k]
    assert before.plan_start == 0 and after.plan_start > 1.0 and after.plan_time < 0.5  # the new plan's own time
    assert after.run_steps - before.run_steps == pytest.approx((after.clock - before.clock) / 0.5, abs=0.02)
    # it stops at the end of the new plan in the run's steps (the denominator a console shows)
    assert clock[-1] == pytest.approx(after.plan_start + f.core.run.plan.makespan, abs=0.01)


def test_robots_that_turn_at_corners_without_any_delay_are_not_late_and_never_rerouted():
    """Simulated TurtleBots at the lab's pace (a drive of 2 s, 90 degree turns of 1 s, a nominal move
    of 2 s) turn before they drive at corners: half a move each time, on top of the plan. That is
    their own time, but no delay: a run without delays never reroutes."""
    lab = load_plan(lab_instance_path(), 5, "the lab fleet", [])
    f = MemoryFleet(lab, lab_fleet(), ManagerSettings(step_time=2.0, reroute="auto", reroute_timed=False),
                    speed=0.5, turn_speed=1.5)
    ops = f.console()
    f.link_up()
    assert f.ask(ops, "start").ok
    assert f.run_until(lambda: f.phase == "done", 400) and f.at_goals()
    turned = f.core.run.engine.metrics.turn_time
    assert max(turned) >= 1.0  # some robots did turn on their moves
    assert f.core.run.rerouting.looks == 0 and f.core.run.plan_id == 1


def test_off_mode_never_looks():
    f = started("off")
    seen = run_to_end(f)
    assert_arrived_safely(f, seen, cell_sized())
    assert f.core.run.rerouting.looks == 0 and not f.kinds("reroute") and not f.kinds("reroute_proposed")
    assert f.ops.state.run.reroute == "off"


def _forgets_renumbering(hand_over):
    """Wrong on purpose: the driver keeps the old plan's numbers for what the robots were sent."""
    def wrong(self, engine, base, dispatches, now):
        return hand_over(self, engine, [0] * len(base), dispatches, now)
    return wrong


def test_a_hand_over_that_keeps_the_old_numbers_of_moves_in_flight_is_caught(monkeypatch):
    """The negative control: robot 3 is in the middle of its second move at the hand-over; if its
    move keeps number 1 (the new plan's move 0), its completion is not one the new engine can
    place and the run never ends; the checks of the auto test catch it."""
    monkeypatch.setattr(driver_module.Driver, "hand_over", _forgets_renumbering(driver_module.Driver.hand_over))
    f = started("auto")
    seen = run_to_end(f, limit=25.0)
    assert f.kinds("reroute")[0]["base"][2] == 1
    with pytest.raises(AssertionError):
        assert_arrived_safely(f, seen, cell_sized())


def wait_for_proposal(f: MemoryFleet) -> int:
    assert f.run_until(lambda: f.ops.state.run.proposal is not None, 10.0)
    return f.ops.state.run.proposal


def test_propose_mode_shows_the_proposal_keeps_running_and_accept_hands_over():
    f = started("propose")
    pid = wait_for_proposal(f)
    proposal = [x for x in f.ops.received if type(x).__name__ == "Proposal"][-1]
    assert proposal.id == pid and proposal.message.startswith("robot 1, late ")
    assert proposal.plan.robots == (1, 2, 3)
    assert f.phase == "running" and not f.kinds("reroute")
    drives = len(f.sent(3, "drive"))
    f.advance(1.0)
    assert len(f.sent(3, "drive")) > drives  # the run does not wait for the answer
    assert f.ask(f.ops, "replan").reason == "a reroute proposal awaits accept/reject; answer it first"
    answer = f.ask(f.ops, "accept", proposal=pid)
    assert answer.ok and answer.reason == "switched to plan 2", answer.reason
    assert f.kinds("reroute") and "plan-2.txt" in f.files
    seen = run_to_end(f)
    assert_arrived_safely(f, seen, cell_sized())
    assert f.ops.state.run.proposal is None


def test_propose_mode_reject_clears_the_proposal_and_no_new_look_while_one_is_proposed():
    f = started("propose")
    pid = wait_for_proposal(f)
    looks = f.core.run.rerouting.looks
    f.advance(1.0)
    assert f.core.run.rerouting.looks == looks  # no look while one awaits an answer
    assert f.ask(f.ops, "reject", proposal=pid).ok
    f.advance(2.0)  # and the operator is not asked again at once
    assert f.ops.state.run.proposal is None and not f.kinds("reroute") and "plan-2.txt" not in f.files
    seen = run_to_end(f)
    assert_arrived_safely(f, seen, cell_sized())


def test_a_proposal_a_rerouted_robot_moved_away_from_is_refused_on_accept_and_cleared():
    f = started("propose")
    f.hold_looks = True
    assert f.run_until(lambda: bool(f.looks), 10.0)
    # robot 1's stall ends, it completes the move the look saw it stand in and is sent its next
    # (completing the move alone would not be moving away: the plan starts it with that move)
    assert f.run_until(lambda: f.core.run.engine.run.dispatched[0] >= 2, 20.0)
    f.finish_looks()  # the look comes back late: the proposal is made, stale already
    pid = f.core.run.rerouting.proposal_id
    assert pid is not None
    answer = f.ask(f.ops, "accept", based_on=f.core.desk.version, proposal=pid)  # it saw the proposal
    assert not answer.ok
    assert answer.reason == "the reroute no longer fits: robot 1 moved since; it is dropped"
    assert f.core.run.rerouting.proposal_id is None and not f.kinds("reroute")
    assert any(r["reason"].startswith("the reroute no longer fits") for r in f.kinds("reroute_dropped"))
    f.advance(0.1)
    assert f.ops.state.run.proposal is None and f.ops.state.run.plan_id == 1


def test_a_proposal_goes_by_itself_once_a_rerouted_robot_moves_on():
    f = started("propose")
    pid = wait_for_proposal(f)
    assert f.run_until(lambda: f.ops.state.run.proposal is None, STALL + 2.0)
    assert any(n.text == "reroute {} dropped: robot 1 moved since it was proposed".format(pid)
               for n in f.ops.notices())
    assert f.ask(f.ops, "accept", proposal=pid).reason == "no proposal {} awaits an answer".format(pid)


def test_the_mode_is_switched_from_a_console_checked_recorded_and_shown():
    f = started("off")
    other = f.console("desk2")
    answer = f.ask(f.ops, "reroute", mode="sometimes")
    assert not answer.ok and answer.reason == "unknown reroute mode 'sometimes'; modes: off, propose, auto"
    assert f.ask(f.ops, "reroute", mode="auto").ok
    f.advance(0.1)
    assert other.state.run.reroute == "auto"  # every console sees the mode
    assert f.kinds("reroute_mode") == [{"mode": "auto", "scope": "held", "by": "operator"}]
    assert any(n.text == "reroute switched: off -> auto" for n in other.notices())
    seen = run_to_end(f)
    assert_arrived_safely(f, seen, cell_sized())
    assert f.kinds("reroute")  # switched on mid-run, it rerouted


def test_the_scope_is_switched_from_a_console_checked_recorded_shown_and_kept_at_resume():
    f = started("off")
    other = f.console("desk2")
    answer = f.ask(f.ops, "reroute", mode="auto", scope="some")
    assert not answer.ok and answer.reason == "unknown reroute scope 'some'; scopes: held, all"
    assert f.core.run.rerouting.mode == "off" and not f.kinds("reroute_mode")  # nothing changed
    assert f.ask(f.ops, "reroute", mode="auto", scope="all").ok
    f.advance(0.1)
    assert (other.state.run.reroute, other.state.run.reroute_scope) == ("auto", "all")
    assert f.kinds("reroute_mode") == [{"mode": "auto", "scope": "all", "by": "operator"}]
    assert any(n.text == "reroute switched: off -> auto (every robot)" for n in other.notices())
    rule = f.core.run.rerouting.rule
    assert rule.scope == "all" and rule.every == EVERY["all"]  # the scope's own pace
    assert f.ask(f.ops, "reroute", mode="propose").ok  # a mode alone keeps the scope
    assert f.core.run.rerouting.rule.scope == "all"
    point = read_resume(RunFolder(Path("memory-run"), [dict(fields, k=kind, t=t) for kind, t, fields in f.records],
                                  torn=False))
    assert (point.reroute, point.reroute_scope) == ("propose", "all")  # a new manager goes on with both
    assert f.ask(f.ops, "reroute", scope="held").ok  # a scope alone keeps the mode
    f.advance(0.1)
    assert (other.state.run.reroute, other.state.run.reroute_scope) == ("propose", "held")
    asked = [n.text for n in other.notices() if n.kind == "operator"]
    assert asked[-3:] == ["ops: reroute auto, scope all", "ops: reroute propose", "ops: reroute scope held"], asked
    assert f.core.run.rerouting.rule.every == EVERY["held"]
    answer = f.ask(f.ops, "reroute")
    assert not answer.ok and answer.reason.startswith("a reroute request names a mode (off, propose, auto)")
    seen = run_to_end(f)
    assert_arrived_safely(f, seen, cell_sized())


def test_a_scope_switched_while_rerouting_is_off_is_told_as_such():
    """(A live session's log read "reroute switched: off -> off".)"""
    f = started("off")
    assert f.ask(f.ops, "reroute", scope="all").ok
    f.advance(0.1)
    assert any(n.text == "reroute switched: off -> off (every robot when on)" for n in f.ops.notices())
    assert f.ask(f.ops, "reroute", mode="auto").ok  # the scope stays
    f.advance(0.1)
    assert any(n.text == "reroute switched: off (every robot when on) -> auto (every robot)" for n in f.ops.notices())


def killed_after_the_reroute_and_resumed(size: RobotSize) -> Tuple[MemoryFleet, List[float], List[Tuple[int, int]]]:
    """Robots 1 and 3 drive moves renumbered by the reroute when the manager dies (SIGKILL) right after
    it; a new manager takes the run over from its records and Start drives on. The run, the closest
    pair of true centres seen, and every command the robots ran from the reroute on."""
    f = started("auto", size)
    assert f.run_until(lambda: bool(f.kinds("reroute")), 10.0)
    ran = executions(f)
    (base,) = [r["base"] for r in f.kinds("reroute")]
    driving = {r.id: r.flight for r in f.core.fleet if r.flight is not None and r.flight.kind == "drive"}
    assert {rid: flight.index for rid, flight in driving.items()} == {1: 0, 2: 0, 3: 0} and base == [0, 1, 1]
    # robot 3 was sent its second move before the reroute: now its first
    assert [c["action"] for c in f.kinds("command") if c["robot"] == 3 and c["id"] == driving[3].id] == [1]
    sent = list(f.core.run.engine.run.dispatched)  # in the new plan's numbers
    f.kill_manager()
    seen = []
    for _ in range(20):  # a second without a manager: the robots drive on
        f.advance(0.05)
        seen.append(closest(f))
    f.resume_manager()
    (resume,) = f.kinds("resume")
    assert resume["plan"] == "plan-2.txt"
    assert {robot for robot, _, kind in resume["sent"] if kind == "drive"} == set(driving)
    assert list(f.core.run.engine.run.dispatched) == sent, "the moves sent, as the dead manager had them"
    f.advance(0.2)
    assert f.phase == "paused" and "every robot where the run left it" in f.core.run.phase.reason
    assert f.ask(f.console(), "start").ok
    return f, seen + run_to_end(f), ran


@pytest.mark.parametrize("size", [cell_sized(), TURTLEBOT2], ids=["cell", "turtlebot2"])
def test_a_manager_killed_right_after_a_reroute_is_resumed_on_the_new_plan_and_every_robot_arrives(size):
    f, seen, ran = killed_after_the_reroute_and_resumed(size)
    assert_arrived_safely(f, seen, size)
    assert len(ran) == len(set(ran)), "a command ran twice"
    assert f.core.summary().resumes == 1
    # each move of the new plan completed once, before the restart or after it
    since = next(i for i, (kind, _, _) in enumerate(f.records) if kind == "plan")
    completed = [(fields["robot"], fields["index"]) for kind, _, fields in f.records[since:]
                 if kind == "action" and fields["phase"] == "completed"]
    assert sorted(completed) == sorted(set(completed))
    assert len(completed) == sum(f.kinds("plan")[0]["actions"]) - sum(f.kinds("plan")[0]["done"])


def test_a_resume_that_keeps_the_old_numbers_of_moves_in_flight_fails_the_run(monkeypatch):
    """The negative control of the test above: the records read back without renumbering (robot 3's
    move in flight keeps number 1); the resume refuses, restores other moves sent than the dead
    manager had, or the run does not end as it should."""
    monkeypatch.setattr(resume_module, "renumber", keeps_old_numbers)
    with pytest.raises((AssertionError, FleetError)):
        f, seen, ran = killed_after_the_reroute_and_resumed(cell_sized())
        assert_arrived_safely(f, seen, cell_sized())
        assert len(ran) == len(set(ran)), "a command ran twice"


def keeps_old_numbers(point, record, pending) -> None:
    """Wrong on purpose (`resume.renumber`): the new plan and its moves done, but the moves begun and
    the commands in flight keep the old plan's numbers."""
    point.plan = str(record["file"])
    point.completed = {rid: record["done"][a] for a, rid in enumerate(record["robots"])}
    point.passes.clear()


def test_the_summary_counts_a_followers_move_made_before_its_leader_left_once_across_a_reroute():
    """Robot 2 followed robot 1 into (1, 0) and completed that move before robot 1 had left it: the
    reroute's plan starts robot 2 with that move again, done already (`done`), and robot 1 with its
    move in flight; both arrive, and four moves were made, not five."""
    from fleet_common.runlog.summary import SummaryBuilder

    b = SummaryBuilder()
    for t, kind, fields in [
            (0.0, "run", dict(robots=[1, 2], actions=[2, 2], starts=[[1, 0], [0, 0]], plan="plan-1.txt")),
            (0.0, "state", dict(run="running")),
            (0.0, "dispatch", dict(robot=1, index=0, step=0, src=[1, 0], dst=[2, 0])),
            (0.0, "dispatch", dict(robot=2, index=0, step=0, src=[0, 0], dst=[1, 0])),
            (0.1, "action", dict(robot=1, index=0, phase="started", src=[1, 0], dst=[2, 0])),
            (0.2, "action", dict(robot=2, index=0, phase="started", src=[0, 0], dst=[1, 0])),
            (0.9, "action", dict(robot=2, index=0, phase="completed", src=[0, 0], dst=[1, 0])),
            (1.0, "plan", dict(file="plan-2.txt", robots=[1, 2], reason="reroute", actions=[2, 2],
                               starts=[[1, 0], [0, 0]], done=[0, 1], base=[0, 0])),
            (1.1, "action", dict(robot=1, index=0, phase="completed", src=[1, 0], dst=[2, 0])),
            (1.1, "dispatch", dict(robot=1, index=1, step=1, src=[2, 0], dst=[3, 0])),
            (1.2, "action", dict(robot=1, index=1, phase="started", src=[2, 0], dst=[3, 0])),
            (2.0, "action", dict(robot=1, index=1, phase="completed", src=[2, 0], dst=[3, 0])),
            (1.1, "dispatch", dict(robot=2, index=1, step=1, src=[1, 0], dst=[2, 0])),
            (1.3, "action", dict(robot=2, index=1, phase="started", src=[1, 0], dst=[2, 0])),
            (2.2, "action", dict(robot=2, index=1, phase="completed", src=[1, 0], dst=[2, 0])),
            (2.2, "state", dict(run="done"))]:
        b.feed(dict(fields, k=kind, t=t))
    s = b.summary()
    assert s.arrived == [1, 2] and s.moves == (4, 4)


def _run_fields(engine) -> tuple:
    """What a look reads of an engine, as plain values."""
    run = engine.run
    return (bytes(run.done), list(run.completed), list(run.started), list(run.dispatched), list(run.sent),
            list(run.dep), list(run.succ), list(engine._sent_at), list(engine._freed_at), dict(engine.early),
            list(run.out), run.version, [list(x) if isinstance(x, list) else x for x in vars(engine.metrics).values()])


def test_a_snapshot_is_the_engine_as_it_was_whatever_the_loop_does_next():
    """`rerouting.snapshot` copies the long lists flat and shares the table's: a look reads the
    engine as it was when asked, while the loop completes moves and a re-ordering rewrites the
    order at cells in place. Negative: a snapshot sharing `dep` sees the rewrite."""
    import copy

    from fleet_common.execution import ActionCompleted, ActionStarted, Engine, Resume
    from fleet_manager.rerouting import snapshot

    def engine_mid_run() -> Engine:
        engine = Engine(load_plan(lab_instance_path(), 5, "the lab fleet", []).plan, "reorder", follow=True)
        sent = engine.handle(Resume(0.0))
        t = 0.0
        for _ in range(6):  # a few rounds of the moves sent: started, then completed
            for d in sent:
                t += 0.1
                engine.handle(ActionStarted(d.agent, d.index, t))
            new = []
            for d in sent:
                t += 0.1
                new += engine.handle(ActionCompleted(d.agent, d.index, t))
            sent = new
        assert sum(engine.run.completed) >= 10
        return engine

    engine = engine_mid_run()
    snap = snapshot(engine)
    before = _run_fields(copy.deepcopy(engine, {id(engine._give_back): None}))
    assert _run_fields(snap) == before
    assert snap.run.first is engine.run.first and snap.table is engine.table  # never changed: shared
    # the loop goes on
    for r in range(engine.run.num_agents):
        if engine.run.dispatched[r] > engine.run.completed[r]:
            engine.handle(ActionCompleted(r, engine.run.completed[r], 10.0))
    engine.run.dep[:] = engine.run.dep[::-1]
    engine.run.succ[:] = engine.run.succ[::-1]
    engine._sent_at[0] = engine._freed_at[0] = -1.0
    assert _run_fields(engine) != before
    assert _run_fields(snap) == before

    wrong = engine_mid_run()  # negative: a copy that shares dep (a memo entry that is the list itself)
    memo = {id(wrong._give_back): None, id(wrong.table): wrong.table, id(wrong.show): wrong.show,
            id(wrong.run.dep): wrong.run.dep}
    shared = copy.deepcopy(wrong, memo)
    before = _run_fields(shared)
    wrong.run.dep[:] = wrong.run.dep[::-1]
    assert _run_fields(shared) != before  # the same check catches it: the look reads the new order


def lab_with_a_stall(scope: str) -> MemoryFleet:
    """The lab plan, its 5 robots at the lab's pace; robot 3 halts 12 s in its second move (robot 5
    is held up: a new path for it pays)."""
    lab = load_plan(lab_instance_path(), 5, "the lab fleet", [])
    f = MemoryFleet(lab, lab_fleet(), ManagerSettings(step_time=2.0, reroute="auto", reroute_timed=False,
                                                      reroute_scope=scope), speed=0.5, turn_speed=1.5)
    f.robots[3].navigator.stalls = {2: 12.0}
    return f


def run_lab(f: MemoryFleet, lag: float = 0.0, windows: Optional[List[Tuple[float, float]]] = None) -> List[float]:
    """Start and run to the end, each look's result reaching the loop `lag` s after it was asked for
    (the robots move on meanwhile; each look's (asked, answered) times into `windows`); the closest
    pair of true centres at each tick."""
    f.hold_looks = True
    ops = f.console()
    f.link_up()
    assert f.ask(ops, "start").ok
    seen: List[float] = []
    asked = None
    end = f.now + 300.0
    while f.phase != "done" and f.now < end:
        f.advance(0.05)
        seen.append(closest(f))
        if f.looks and asked is None:
            asked = f.now
        if f.looks and asked is not None and f.now - asked >= lag - 1e-9:
            f.finish_looks()
            if windows is not None:
                windows.append((asked, f.now))
            asked = None
    return seen


def test_scope_all_in_auto_mode_hands_over_a_new_plan_and_every_robot_arrives_safely():
    f = lab_with_a_stall("all")
    seen = run_lab(f)
    assert f.phase == "done" and f.at_goals()
    assert min(seen) >= TURTLEBOT2.safe_cells - 0.01 and f.core.summary().collisions == 0
    (record,) = f.kinds("reroute")
    assert record["robots"] == [5] and record["around"] == 3 and record["text"].startswith("robot 5 rerouted")
    assert not f.kinds("reroute_dropped") and f.core.run.plan_id == 2
    assert f.core.run.rerouting.rule.scope == "all" and f.core.run.rerouting.looks >= 2


def inside(t: float, windows: List[Tuple[float, float]]) -> bool:
    """`t` (a record's time, rounded) strictly inside one of `windows`."""
    return any(asked + 1e-6 < t < answered - 1e-6 for asked, answered in windows)


def test_a_look_in_flight_sends_no_new_move_and_its_reroute_is_handed_over():
    """Auto mode: while a look is in flight (here 0.8 s of fleet time, 0.4 plan steps) no move is
    dispatched (the engine is frozen, robots finish the moves they had), so the robots it reroutes
    are where its cut saw them and the reroute is handed over; then moves go on."""
    f = lab_with_a_stall("all")
    windows: List[Tuple[float, float]] = []
    seen = run_lab(f, lag=0.8, windows=windows)
    assert f.phase == "done" and f.at_goals() and min(seen) >= TURTLEBOT2.safe_cells - 0.01
    assert f.kinds("reroute") and not f.kinds("reroute_dropped") and len(windows) >= 2
    dispatched = [t for kind, t, _ in f.records if kind == "dispatch"]
    assert not [t for t in dispatched if inside(t, windows)]
    assert f.core.summary().held == 0.0  # nobody was held by an operator: the waits are the rerouting's
    # each answer (a reroute or none) thaws the run at once, not at the freeze's bound (asked + 1 s)
    assert all([t for t in dispatched if answered - 1e-6 <= t <= answered + 0.1] for _, answered in windows)


def test_scope_all_drops_a_reroute_whose_robot_moved_before_the_hand_over_and_goes_on_safely():
    """A look that takes 2 s of fleet time: robot 5 has moved on by then, the hand-over drops the
    plan (recorded), the run goes on, every robot home."""
    f = lab_with_a_stall("all")
    windows: List[Tuple[float, float]] = []
    seen = run_lab(f, lag=2.0, windows=windows)
    assert f.phase == "done" and f.at_goals() and min(seen) >= TURTLEBOT2.safe_cells - 0.01
    assert f.kinds("reroute_dropped") and "moved since" in f.kinds("reroute_dropped")[0]["reason"]
    # a look is not waited for beyond FREEZE plan steps (1 s here): moves are sent again meanwhile
    late = [t for kind, t, _ in f.records if kind == "dispatch"
            and any(asked + 1.0 <= t < answered for asked, answered in windows)]
    assert late
