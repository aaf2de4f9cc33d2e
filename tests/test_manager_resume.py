"""A manager that dies mid-run and another that takes the run over from its records, in memory.

The robots go on while no manager runs (each finishes what it was running; a
follower waits at its hold point); the new manager reads the records the
dead one left (`MemoryFleet.resume_manager`, as `fleetctl manager --resume`
reads a run folder), checks where every robot stands, and the run ends with
every robot at its goal, no command run twice and the robots' distance kept.
The engine's `restore` is held to the progress it was given.
"""
from __future__ import annotations

import math
import random
from pathlib import Path
from typing import List, Tuple

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from fleet_common.execution import ActionCompleted, ActionStarted, Engine, EventError, Resume, RobotFailed
from fleet_common.grid import Grid
from fleet_common.lab import lab_instance_path
from fleet_common.plan_loading import LoadedPlan, load_plan
from fleet_common.robot_size import TURTLEBOT2
from fleet_common.runlog.reader import RunFolder
from fleet_common.runlog.summary import SummaryBuilder
from fleet_common.wire import Pose
from fleet_manager.resume import read_resume
from fleet_manager.run import Run
from fleet_manager.settings import ManagerSettings
from memory_fleet import MemoryFleet, MemoryVicon, lab_fleet
from test_manager_core import answered, closest_truth, replanned, run_recording, train

_LAB: List[LoadedPlan] = []


def lab() -> LoadedPlan:
    if not _LAB:
        _LAB.append(load_plan(lab_instance_path(), 5, "the lab fleet", []))
    return _LAB[0]


def executions(f: MemoryFleet) -> List[Tuple[int, int]]:
    """Every (robot, command id) a robot starts from now on (a motion, or a stop), in order."""
    ran: List[Tuple[int, int]] = []
    for robot in f.robots.values():
        robot.executor.on_execute = lambda epoch, command, rid=robot.id: ran.append((rid, command.id))
    return ran


def far_cell(f: MemoryFleet) -> Tuple[float, float]:
    """The free cell farthest from every robot."""
    grid = f.loaded.grid
    poses = [r.navigator.true_pose() for r in f.robots.values()]
    cells = [(x, y) for y in range(grid.height) for x in range(grid.width) if grid.free[y, x]]
    x, y = max(cells, key=lambda c: min(math.hypot(c[0] - p.x, c[1] - p.y) for p in poses))
    return float(x), float(y)


def idle_robot(f: MemoryFleet) -> int:
    """A robot running no command, not at its goal yet."""
    goals = dict(zip(f.robots, f.loaded.goals))
    return next(rid for rid, r in f.robots.items() if r.executor.current is None
                and math.hypot(r.navigator.true_pose().x - goals[rid][0], r.navigator.true_pose().y - goals[rid][1]) > 0.5)


def carry(f: MemoryFleet, rid: int, x: float, y: float) -> None:
    """Robot `rid` (standing still) is carried by hand to (x, y)."""
    navigator = f.robots[rid].navigator
    assert not navigator.moving
    navigator._rest = Pose(float(x), float(y), 0.0)


def started_run(loaded: LoadedPlan, n: int = 5, **kwargs) -> MemoryFleet:
    f = MemoryFleet(loaded, lab_fleet(n), **kwargs)
    ops = f.console()
    f.link_up()
    assert f.ask(ops, "start").ok
    return f


def test_a_manager_killed_mid_run_is_replaced_and_the_run_completes():
    f = started_run(lab())
    ran = executions(f)
    total = f.core.run.engine.table.num_actions
    assert f.run_until(lambda: sum(f.core.run.engine.run.completed) >= total // 3)
    moving = {r.id for r in f.core.fleet if r.flight is not None and r.flight.kind == "drive"}
    assert moving, "the manager should die while robots drive"
    f.kill_manager()
    f.advance(3.0)  # the robots finish their moves without it
    f.resume_manager()
    resume = f.kinds("resume")[0]
    assert {robot for robot, _, kind in resume["sent"] if kind == "drive"} == moving
    assert f.phase == "paused"
    f.advance(0.2)
    assert "every robot where the run left it" in f.core.run.phase.reason
    ops = f.console()
    assert f.ask(ops, "start").ok
    assert f.run_until(lambda: f.phase == "done") and f.at_goals()
    assert len(ran) == len(set(ran)), "a command ran twice"
    summary = f.core.summary()
    assert len(summary.arrived) == 5 and summary.collisions == 0 and summary.resumes == 1
    # every action completed once in the run's records, before and after the restart
    completed = [(fields["robot"], fields["index"]) for fields in f.kinds("action") if fields["phase"] == "completed"]
    assert len(completed) == len(set(completed)) == total


def test_a_pose_older_than_the_reply_that_ended_a_move_does_not_put_a_robot_off_the_plan():
    """As above, with poses that reach the manager 0.3 s late: the first poses the new manager
    hears were taken before the robots finished the moves they were making, while the replies to
    the drives sent again say they finished. The replies win (a pose names the command the robot
    was running): every robot is where the run left it, and the run goes on with no replan. Before,
    the late poses put the robots off the plan, and a replan from the cells they had left sent
    another robot into a cell one of them stood in (random operator sessions, --wide, seed 122)."""
    f = MemoryFleet(lab(), lab_fleet(), pose_lag=0.3, settings=ManagerSettings(step_time=0.5, size=TURTLEBOT2))
    f.link_up()
    f.advance(0.5)  # the first poses come in
    assert f.ask(f.console(), "start").ok
    total = f.core.run.engine.table.num_actions
    assert f.run_until(lambda: sum(f.core.run.engine.run.completed) >= total // 3)
    assert any(r.flight is not None and r.flight.kind == "drive" for r in f.core.fleet)
    f.kill_manager()
    f.advance(3.0)  # the robots finish their moves without it
    f.resume_manager()
    assert f.run_until(lambda: f.core.run.resuming is None, 5)
    assert "every robot where the run left it" in f.core.run.phase.reason, f.core.run.phase.reason
    assert f.ask(f.console(), "start").ok
    assert f.run_until(lambda: f.phase == "done") and f.at_goals()
    assert f.core.summary().collisions == 0 and f.core.run.plan_id == 1


def test_a_follower_at_its_hold_point_waits_for_the_new_manager_and_keeps_its_distance():
    size = TURTLEBOT2
    f = started_run(train(), 3, settings=ManagerSettings(step_time=0.5, size=size), speed=1.0)
    f.robots[1].navigator.stalls = {2: 4.0}  # the leader halts 4 s in the middle of its second move
    seen: List[float] = []

    def released_since_logged() -> bool:
        """Robot 2 got a release (not logged) after its last logged command: a new manager must not
        give its ids again."""
        logged = max([fields["id"] for kind, _, fields in f.records
                      if kind in ("command", "reply") and fields["robot"] == 2] + [0])
        return any(getattr(c, "TYPE", "") == "release" and c.id > logged for c in f.robots[2].commands)

    assert f.run_until(lambda: bool(f.core.run.driver.following.holds) and f.robots[1].navigator.moving
                       and f.core.run.engine.run.completed[0] >= 1 and released_since_logged(), 30)
    f.kill_manager()
    for _ in range(100):  # 5 s without a manager: the leader's stall ends, its followers wait
        f.advance(0.05)
        closest_truth(f, seen)
    follower = f.robots[2].navigator
    assert follower.moving and follower._held_at is not None, "the follower should stand at its hold point"
    sent = len(f.robots[2].commands)
    f.resume_manager(up=[1, 2])  # robot 3 answers later: nothing may move on before it has
    f.advance(1.0)
    assert "robot 3 (not connected)" in f.core.run.not_ready()
    assert not any(getattr(c, "TYPE", "") == "release" for c in f.robots[2].commands[sent:])
    f.link_up(3)
    f.advance(0.2)
    assert f.ask(f.console(), "start").ok
    run_recording(f, 60, seen)
    assert f.phase == "done" and f.at_goals()
    assert min(seen) >= size.safe_cells - 0.01
    assert any(getattr(c, "TYPE", "") == "release" for c in f.robots[2].commands[-30:])


def test_a_robot_moved_while_no_manager_ran_is_named_and_replanned_from_where_it_stands():
    f = started_run(lab())
    assert f.run_until(lambda: sum(f.core.run.engine.run.completed) >= 10)
    f.kill_manager()
    f.advance(3.0)
    rid = idle_robot(f)
    carry(f, rid, *far_cell(f))  # an operator carried it to a free cell away from the rest
    f.resume_manager()
    ops = f.console()
    f.advance(0.5)
    told = [n.text for n in ops.notices()] + f.said
    assert any("robot {} stands at".format(rid) in t and "replanned from" in t for t in told), told
    proposals = [x for x in ops.received if type(x).__name__ == "Proposal"]
    assert proposals and f.core.run.replanner.proposal_id is not None
    assert not f.ask(ops, "start").ok  # not before the proposal is answered
    assert f.ask(ops, "accept", proposal=proposals[-1].id).ok
    assert f.ask(ops, "start").ok
    assert f.run_until(lambda: f.phase == "done") and f.at_goals()
    assert f.core.summary().collisions == 0


def resumed_with_a_robot_between_cells(accept: bool) -> Tuple[MemoryFleet, int, Tuple[int, int], List[Grid]]:
    """A run whose manager died; meanwhile a robot standing still was pushed half a cell towards a
    free cell nobody needs now; another manager resumed it. The fleet, that robot, the cell it
    leans into and the maps the replans were asked on."""
    f = started_run(lab(), settings=ManagerSettings(step_time=0.5, size=TURTLEBOT2, accept=accept))
    grids: List[Grid] = []
    solve = f.solve
    f.solve = lambda job: grids.append(job.grid) or solve(job)
    assert f.run_until(lambda: sum(f.core.run.engine.run.completed) >= 10)
    core = f.core  # the dead manager's, for where its plan wanted the robots next
    f.kill_manager()
    f.advance(3.0)
    rid = idle_robot(f)
    stray = f.robots[rid].navigator
    here = stray.true_pose()
    x, y = round(here.x), round(here.y)
    robot = core.fleet.by_id[rid]
    nxt = core.run.engine.run.next_incomplete(robot.agent)
    taken = {(round(r.navigator.true_pose().x), round(r.navigator.true_pose().y)) for r in f.robots.values()}
    if nxt >= 0:
        taken.add(core.run.engine.table.coord(core.run.engine.run.dst[nxt]))
    grid = f.loaded.grid
    dx, dy = next((dx, dy) for dx, dy in ((1, 0), (-1, 0), (0, 1), (0, -1)) if grid.in_bounds((x + dx, y + dy))
                  and grid.free[y + dy, x + dx] and (x + dx, y + dy) not in taken)
    carry(f, rid, x + dx / 2, y + dy / 2)  # pushed half a cell towards a free cell nobody needs now
    f.resume_manager()
    f.advance(0.5)
    return f, rid, (x + dx, y + dy), grids


def test_a_robot_left_between_cells_is_held_and_planned_around():
    size = TURTLEBOT2
    f, rid, (x, y), grids = resumed_with_a_robot_between_cells(accept=True)
    stray = f.robots[rid].navigator
    robot = f.core.fleet.by_id[rid]
    assert f.core.run.engine.run.out[robot.agent] == "failed" and "between cells" in robot.hold_reason
    assert not grids[-1].free[y, x], "the cell it leans into is walled off for the replan"
    told = " ".join(f.said)
    assert "robot {} stands at".format(rid) in told and "between cells, held and planned around" in told
    assert f.kinds("plan"), "--accept switches to the replan at once"
    pose = (stray.true_pose().x, stray.true_pose().y)
    near = [(x, y) for x in range(f.loaded.grid.width) for y in range(f.loaded.grid.height)
            if math.hypot(x - pose[0], y - pose[1]) < size.safe_cells and f.loaded.grid.free[y, x]
            and (x, y) not in {tuple(c) for c in f.core.run.plan.positions[0]}]
    assert near and not any(grids[-1].free[y, x] for x, y in near), "the cells around it were walled off"
    # and stay so for every reroute of the new plan (`Rerouting.keep_to`)
    assert f.core.run.rerouting.maps.grid is grids[-1]
    plan = f.core.run.plan.positions
    others = [a for a in range(plan.shape[1]) if a != robot.agent]
    nearest = min(math.hypot(plan[t, a, 0] - pose[0], plan[t, a, 1] - pose[1])
                  for t in range(1, plan.shape[0]) for a in others if tuple(plan[t, a]) != tuple(plan[0, a]))
    assert nearest >= size.safe_cells, "a replanned robot passes the held one"


def test_a_robot_carried_between_two_other_cells_is_enabled_only_once_put_on_a_cell():
    """While no manager ran, robot 2 was carried from its goal to between two other cells; the new
    manager holds it there. Enabled as it stands, it could be planned from neither cell (its
    drive would start 1.5 cells from where the plan has it, and the robot refuses such a drive:
    a fault, enabled and refused again, for ever; wide operator sessions, seed 1994), so the
    enable is refused, saying what to do. Put on a cell, it is enabled and a replan takes it home."""
    f = started_run(lab(), settings=ManagerSettings(step_time=0.5, size=TURTLEBOT2))
    assert f.run_until(lambda: f.phase == "done")
    goal = f.loaded.goals[1]
    f.kill_manager()
    carry(f, 2, goal[0] + 1.5, goal[1])
    f.resume_manager()
    ops = f.console()
    assert f.run_until(lambda: f.core.fleet.by_id[2].hold == "fault", 5)
    f.advance(0.5)
    if f.core.run.replanner.proposal_id is not None:
        answered(f, ops)
    answer = f.ask(ops, "enable", robot=2)
    assert not answer.ok and "between two cells" in answer.reason and "put it on a cell, then enable it" in answer.reason
    carry(f, 2, goal[0] + 1, goal[1])
    f.advance(0.3)
    assert f.ask(ops, "enable", robot=2).ok
    replanned(f, ops)
    assert f.ask(ops, "start").ok or f.phase == "running"
    assert f.run_until(lambda: f.phase == "done") and f.at_goals()


def test_a_robot_put_on_a_cell_next_to_one_left_between_cells_is_replanned_from_it():
    """While no manager ran, robot 2 was carried to between two cells and robot 1 onto a free cell
    a cell and a half from it. The new manager walls off the cells around robot 2, but not the
    one robot 1 stands on: it plans robot 1 from there. Before, the wall went up on robot 1's
    cell and every replan failed ("current cell ... is on a blocked cell"; wide operator
    sessions, seed 2418)."""
    f = started_run(lab(), settings=ManagerSettings(step_time=0.5, size=TURTLEBOT2))
    assert f.run_until(lambda: f.phase == "done")
    grid = f.loaded.grid
    goal = f.loaded.goals[1]
    between = (goal[0] + 1.5, float(goal[1]))
    taken = {(round(r.navigator.true_pose().x), round(r.navigator.true_pose().y)) for r in f.robots.values()}
    near = [(x, y) for x in range(grid.width) for y in range(grid.height) if grid.free[y, x] and (x, y) not in taken
            and 1.0 < math.hypot(x - between[0], y - between[1]) < 1.2]
    assert near
    f.kill_manager()
    carry(f, 2, *between)
    carry(f, 1, *near[0])
    f.resume_manager()
    assert f.run_until(lambda: f.core.run.replanner.proposal_id is not None, 10), f.said[-3:]
    pending = f.core.run.replanner.pending
    assert tuple(pending.current[f.core.fleet.by_id[1].agent]) == near[0]
    assert pending.grid.free[near[0][1], near[0][0]]


def test_a_rejected_replan_after_a_resume_leaves_reroutes_walled_off_a_robot_between_cells():
    """The operator rejects the replan a resume proposes: the run goes on with the old plan and
    the robot between cells held out, and every reroute of it (`--reroute`) still keeps off the
    cells walled round that robot (the engine's record has it in its cell)."""
    f, rid, (x, y), grids = resumed_with_a_robot_between_cells(accept=False)
    ops = f.console()
    assert f.run_until(lambda: f.core.run.replanner.proposal_id is not None, 5)
    f.advance(0.1)  # the console sees the State that names the proposal
    assert f.ask(ops, "reject", proposal=f.core.run.replanner.proposal_id).ok
    assert f.core.run.plan_id == 1 and not grids[-1].free[y, x]
    walls = f.core.run.walls  # the cells round it, walled for the replan
    assert (x, y) in walls
    reroutes = f.core.run.rerouting.maps.grid
    assert all(not reroutes.free[cy, cx] for cx, cy in walls), "a reroute may plan round it on the whole map"


def test_a_run_that_had_not_started_is_resumed_waiting_for_start():
    f = MemoryFleet(lab(), lab_fleet())
    f.link_up()
    f.kill_manager()
    f.resume_manager()
    assert f.phase == "waiting" and f.core.run.resuming is None
    assert f.ask(f.console(), "start").ok
    assert f.run_until(lambda: f.phase == "done") and f.at_goals()


def test_a_run_begun_by_step_alone_is_resumed_under_way():
    """The operator steps the run (never Start) and the manager dies: the one that takes over
    goes on from where the robots are. Before, only a "running" state counted as begun, so it
    waited for Start and refused it, the robots being off their starts, and told the operator
    to resume, which it just had (random operator sessions, --wide, seeds 0, 13, 30, 74, 89)."""
    f = MemoryFleet(lab(), lab_fleet())
    ops = f.console()
    f.link_up()
    assert f.ask(ops, "step").ok
    assert f.run_until(lambda: f.phase == "paused" and not f.core.run.driver.moving, 20)
    done = list(f.core.run.engine.run.completed)
    assert sum(done) > 0
    f.kill_manager()
    f.resume_manager()
    assert f.run_until(lambda: f.core.run.resuming is None, 5)
    assert f.phase == "paused" and list(f.core.run.engine.run.completed) == done
    assert f.ask(f.console(), "start").ok
    assert f.run_until(lambda: f.phase == "done") and f.at_goals()


def test_a_manager_that_dies_after_a_reset_goes_on_with_command_ids_the_robots_have_not_seen():
    """The run is done, the operator resets it (the robots drive back to their starts, a run
    folder of its own, then the plan's new folder waits for Start), and the manager dies. The new
    manager resumes that folder in the same epoch, where no command was sent yet: it must not
    number its commands from 1 again, for the robots remember those ids from the runs before and
    would answer "completed" without moving (found by wide operator sessions, seed 1891: a robot
    counted in a cell it never drove to). The run folder's first record says where the ids were."""
    f = started_run(lab())
    ops = f.console()
    assert f.run_until(lambda: f.phase == "done") and f.at_goals()
    assert f.ask(ops, "reset").ok
    assert f.run_until(lambda: f.phase == "waiting" and f.core.run.purpose == "plan" and not f.core.run.not_ready())
    f.kill_manager()
    f.resume_manager()
    replies = len(f.kinds("reply"))
    assert f.phase == "waiting"
    assert f.ask(f.console(), "start").ok
    assert f.run_until(lambda: f.phase == "done") and f.at_goals()
    assert not [r for r in f.kinds("reply")[replies:] if r.get("duplicate")]
    assert f.core.summary().collisions == 0


def test_a_second_manager_taking_over_numbers_above_the_ids_the_first_one_started_from():
    """A manager that took over numbers its commands from above the log (releases of hold points
    are not logged); if it dies too, the next one must number above where it started, not again
    from the same place: a robot that was only released meanwhile (no logged command) would answer
    the new manager's drive with that release's "completed", without moving (wide operator
    sessions, seed 3230). The `resume` record says where each robot's ids started."""
    from fleet_manager.resume import ID_MARGIN
    records = [
        {"k": "run", "t": 0.0, "version": 1, "source": "manager", "plan": "plan-1.txt", "robots": [1, 2],
         "actions": [1, 1], "starts": [[0, 0], [1, 1]], "next_ids": [1, 1], "started": None},
        {"k": "command", "t": 1.0, "robot": 1, "id": 6, "type": "drive", "x": 1.0, "y": 0.0, "action": 0},
        {"k": "resume", "t": 2.0, "plan": "plan-1.txt", "completed": [0, 0], "sent": [[1, 6, "drive"]],
         "next_ids": [6 + 1 + ID_MARGIN, 1 + ID_MARGIN]},
    ]
    point = read_resume(RunFolder(Path("memory-run"), records, torn=False))
    assert point.next_id[1] > 6 + 1 + ID_MARGIN and point.next_id[2] > 1 + ID_MARGIN
    # and the first record of a folder the manager opened after others (a reset) says the same
    records[0]["next_ids"] = [40, 50]
    del records[2]
    point = read_resume(RunFolder(Path("memory-run"), records, torn=False))
    assert point.next_id[1] >= 40 and point.next_id[2] >= 50


def test_the_records_of_a_resumed_run_read_as_one_run():
    f = started_run(lab())
    assert f.run_until(lambda: sum(f.core.run.engine.run.completed) >= 15)
    f.kill_manager()
    f.advance(2.0)
    f.resume_manager()
    f.advance(0.2)
    f.ask(f.console(), "start")
    assert f.run_until(lambda: f.phase == "done")
    records = [dict(fields, k=kind, t=t) for kind, t, fields in f.records]
    builder = SummaryBuilder()
    for record in records:
        builder.feed(record)
    again = builder.summary()
    assert again.lines() == f.core.summary().lines()
    assert "resumed: 1 time after its manager stopped (2.0 s without one)" in again.lines()
    point = read_resume(RunFolder(Path("memory-run"), records, torn=False))
    assert point.phase == "done" and not point.unsettled


# ---- Engine.restore ---------------------------------------------------------------------------

def _progress(loaded: LoadedPlan, follow: bool, seed: int, events: int) -> Tuple[Engine, List[int], List[int],
                                                                                    List[int]]:
    """An engine run `events` steps into the plan, robots starting and completing moves in a random
    order the engine and the robots allow (a follower arrives only once its leader has set off)."""
    engine = Engine(loaded.plan, "adg", follow=follow)
    run = engine.run
    rng = random.Random(seed)
    engine.handle(Resume(0.0))
    for t in range(events):
        moves = []
        for r in range(run.num_agents):
            if run.started[r] < run.dispatched[r]:
                moves.append(("start", r, run.started[r]))
            elif run.completed[r] < run.started[r]:
                a = run.first[r] + run.completed[r]
                d = run.dep[a]
                if d < 0 or run.done[d] or run.started[run.agent[d]] > d - run.first[run.agent[d]]:
                    moves.append(("complete", r, run.completed[r]))
        if not moves:
            break
        kind, r, index = rng.choice(moves)
        engine.handle((ActionStarted if kind == "start" else ActionCompleted)(r, index, float(t)))
    return engine, list(run.completed), list(run.started), list(run.dispatched)


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 10_000), st.integers(0, 60), st.booleans(), st.booleans())
def test_restore_gives_the_progress_it_was_given_and_the_run_goes_on_to_the_end(seed, events, follow, logged):
    engine, completed, started, dispatched = _progress(lab(), follow, seed, events)
    if not logged:  # what a run log tells: what robots began, not every dispatch
        dispatched = list(started)
    again = Engine(lab().plan, "adg", follow=follow)
    pending = again.restore(completed, started, dispatched, 100.0)
    run = again.run
    for d in pending:  # a follower sent early has its leader's move dispatched
        if d.follows is not None:
            assert run.dispatched[d.follows[0]] > d.follows[1]
    assert list(again.run.completed) == completed
    assert bytes(again.run.done) == bytes(engine.run.done)
    assert all(again.run.dispatched[r] >= dispatched[r] for r in range(len(completed)))
    assert again.run.dispatched == engine.run.dispatched or not logged
    assert {(d.agent, d.index) for d in pending} == {
        (r, k) for r in range(len(completed)) for k in range(completed[r], again.run.dispatched[r])}
    # carried on from there, the run reaches the end
    queue = {(d.agent, d.index) for d in pending} | {(d.agent, d.index) for d in again.handle(Resume(101.0))}
    for _ in range(again.table.num_actions + 1):
        if not queue:
            break
        agent, index = min(queue, key=lambda q: (q[1], q[0]))
        if index != again.run.completed[agent]:
            agent, index = next((a, i) for a, i in sorted(queue) if i == again.run.completed[a])
        queue.discard((agent, index))
        queue |= {(d.agent, d.index) for d in again.handle(ActionCompleted(agent, index, 102.0))}
    assert again.finished


def test_restore_counts_the_leader_of_a_follower_that_set_off_first_as_dispatched():
    engine = Engine(train().plan, "adg", follow=True)
    engine.handle(Resume(0.0))  # robot 0 leads robots 1 and 2 east along a row
    engine.handle(ActionStarted(1, 0, 0.1))  # the follower drives to its hold point; its leader turns
    again = Engine(train().plan, "adg", follow=True)
    pending = again.restore([0, 0, 0], [0, 1, 0], [0, 1, 0], 1.0)  # what a run log says
    assert {(d.agent, d.index) for d in pending} == {(0, 0), (1, 0)}
    follower = next(d for d in pending if d.agent == 1)
    assert follower.follows == (0, 0) and list(again.run.dispatched) == [1, 1, 0]


@pytest.mark.parametrize("told", [True, False])
def test_restore_takes_a_follower_in_behind_a_leader_whose_move_was_taken_back(told):
    """Robot 1 followed robot 0 and completed its move into the cell robot 0 was leaving; then a
    fault took robot 0's move back (it stands between the two cells). The live engine has robot 0
    not sent that move and robot 1 in (big operator session 293): a manager taking over, told the
    move was taken back, restores that; not told (the control: before 2026-11-27), it refused the
    run log ("completed action 0 before agent 0 began action 0") and could not take over."""
    live = Engine(train().plan, "adg", follow=True)
    live.handle(Resume(0.0))
    live.handle(ActionStarted(0, 0, 0.1))
    live.handle(ActionStarted(1, 0, 0.2))
    live.handle(ActionCompleted(1, 0, 0.4))  # in, its leader still leaving
    live.handle(RobotFailed(0, 0.5))
    sent = list(live.run.dispatched)  # (robot 2 follows robot 1 in turn)
    assert list(live.run.completed) == [0, 1, 0] and sent[:2] == [0, 1]
    again = Engine(train().plan, "adg", follow=True)
    if not told:
        with pytest.raises(EventError, match="agent 1 completed action 0 before agent 0 began action 0"):
            again.restore([0, 1, 0], [0, 1, 0], sent, 1.0)
        return
    again.restore([0, 1, 0], [0, 1, 0], sent, 1.0, [True, False, False])
    assert list(again.run.completed) == list(live.run.completed)
    assert list(again.run.dispatched) == list(live.run.dispatched)


def test_restore_refuses_progress_the_dependencies_do_not_allow():
    engine = Engine(lab().plan, "adg")
    run = engine.run
    # an action whose dependency (another robot leaving the cell) is not complete
    a = next(a for a in range(len(run.dep)) if run.dep[a] >= 0)
    r = run.agent[a]
    completed = [0] * run.num_agents
    completed[r] = a - run.first[r] + 1
    with pytest.raises(EventError):
        engine.restore(completed, completed, completed, 0.0)
    assert sum(engine.run.completed) == 0 and engine.run.version == 0  # nothing changed


def test_a_manager_that_dies_on_the_way_to_the_starts_drives_the_robots_on_to_them():
    """The operator resets a run under way (the robots drive back to their starts, a run of its
    own) and the manager dies on the way. The new manager takes the way over: the robots go on to
    their starts, and the plan waits for Start in a new folder, as if the manager had lived.
    Before, `--resume` took over the run the reset had ended and drove the robots to their goals."""
    f = started_run(lab())
    ops = f.console()
    assert f.run_until(lambda: sum(f.core.run.engine.run.completed) >= 10)
    assert f.ask(ops, "stop").ok  # the robots finish their moves
    assert f.run_until(lambda: not f.core.run.driver.moving, 10)
    f.advance(0.2)  # a pose from each robot standing
    assert f.ask(ops, "reset").ok
    assert f.run_until(lambda: f.core.run.purpose == "to-starts" and sum(f.core.run.engine.run.completed) >= 3)
    way = f.core.run.plan
    folders = f.folders
    f.kill_manager()
    f.advance(1.0)  # the robots finish what they were running
    f.resume_manager()
    assert f.core.run.purpose == "to-starts" and f.core.run.plan is way
    assert f.core.run.target.name == lab().name and f.folders == folders  # the way's folder goes on
    assert f.run_until(lambda: f.core.run.resuming is None, 5)
    ops = f.console()
    assert f.ask(ops, "start").ok
    assert f.run_until(lambda: f.core.run.purpose == "plan" and f.phase == "waiting", 60)
    assert f.folders == folders + 1  # the plan's new folder, waiting for Start
    for rid, start in zip(f.robots, lab().starts):
        pose = f.robots[rid].navigator.true_pose()
        assert math.hypot(pose.x - start[0], pose.y - start[1]) < 0.05, (rid, pose, start)
    assert f.ask(ops, "start").ok
    assert f.run_until(lambda: f.phase == "done") and f.at_goals()
    assert f.core.summary().collisions == 0


def way_cut_by_a_dying_manager(seed: int) -> Tuple[bool, float]:
    """A run stopped after a random number of moves (or done), sent back to its starts (Reset),
    its manager killed at a random moment of the way (poses on time or 0.2 s late) and another
    taking over: (every robot ended on its start and then, started, on its goal; the closest two
    true centres came, cells)."""
    rng = random.Random(seed)
    size = TURTLEBOT2
    f = MemoryFleet(lab(), lab_fleet(), ManagerSettings(step_time=0.5, size=size, accept=True),
                    pose_lag=rng.choice([0.0, 0.0, 0.2]))
    f.link_up()
    f.advance(0.5)  # the first poses in
    assert f.ask(f.console(), "start").ok
    seen: List[float] = []

    def until(condition, limit: float) -> bool:
        end = f.now + limit
        while not condition() and f.now < end:
            f.advance(0.05)
            closest_truth(f, seen)
        return condition()

    def go_on(seconds: float) -> None:
        until(lambda: False, seconds)

    moves = rng.randint(3, 40)
    assert until(lambda: sum(f.core.run.engine.run.completed) >= moves or f.phase == "done", 60)
    ops = f.console()
    if f.phase != "done":
        assert f.ask(ops, "stop").ok
    assert until(lambda: not f.core.run.driver.moving, 10)
    go_on(0.3)  # poses of the robots standing
    assert f.ask(ops, "reset").ok  # (Go to starts opens the same way, from a run waiting for Start)
    assert until(lambda: f.core.run.purpose == "to-starts", 5)
    go_on(rng.uniform(0.0, 4.0))
    f.kill_manager()
    go_on(rng.uniform(0.2, 2.0))
    f.resume_manager()
    ops = f.console()
    assert until(lambda: f.core.run.resuming is None and not f.core.run.replanner.open, 10)
    if f.core.run.purpose == "to-starts":
        assert f.ask(ops, "start").ok
    # (the robots' poses may come 0.2 s late: Start waits for them)
    home = until(lambda: f.core.run.purpose == "plan" and f.phase == "waiting" and not f.core.run.not_ready(), 60)
    home = home and all(math.hypot(r.navigator.true_pose().x - s[0], r.navigator.true_pose().y - s[1]) < 0.05
                        for r, s in zip(f.robots.values(), lab().starts))
    if home:
        assert f.ask(ops, "start").ok
        home = until(lambda: f.phase == "done", 60) and f.at_goals()
    return home, min(seen)


def test_ways_to_the_starts_cut_by_a_dying_manager_end_on_the_starts_at_the_safe_distance():
    for seed in range(10):  # `bench/way_resumes.py` runs more
        home, closest = way_cut_by_a_dying_manager(seed)
        assert home, "seed {}: the robots did not reach their starts, then their goals".format(seed)
        assert closest >= TURTLEBOT2.safe_cells - 0.01, "seed {}: {:.3f} cells".format(seed, closest)


@pytest.mark.parametrize("dropped", [True, False])
def test_a_replan_rejected_after_a_resume_leaves_a_robot_carried_off_the_plan_found_moved(monkeypatch, dropped):
    """A robot carried to a far cell while no manager ran; the new manager proposes a replan from
    there, and the operator rejects it. The run has the robot on its old cell again: Start is refused,
    naming it, until it is put back (then the old plan drives on to the end). The control keeps the
    cell it was found on as its place after the rejection, as before 2026-11-27: Start was accepted,
    and the robot was sent a drive to its plan's next cell from where it stood, 9 cells away."""
    if not dropped:
        monkeypatch.setattr(Run, "drop_replan", lambda self: self.replanner.resolved())
    f = started_run(lab())
    assert f.run_until(lambda: sum(f.core.run.engine.run.completed) >= 10)
    f.kill_manager()
    f.advance(3.0)
    rid = idle_robot(f)
    back = f.robots[rid].navigator.true_pose()
    carry(f, rid, *far_cell(f))
    f.resume_manager()
    ops = f.console()
    assert f.run_until(lambda: f.core.run.replanner.proposal_id is not None, 5)
    f.advance(0.1)  # the console sees the State that names the proposal
    assert f.ask(ops, "reject", proposal=f.core.run.replanner.proposal_id).ok
    started = f.ask(ops, "start")
    if not dropped:  # driven from the wrong place: only the robot's own check of a drive's length stops it
        assert started.ok
        assert f.run_until(lambda: any("robot {} held: target".format(rid) in line and "cells from the robot" in line
                                       for line in f.said), 10)
        return
    assert not started.ok and "robot {} stands at".format(rid) in started.reason and "put it back" in started.reason
    # the run's line says the same, not "replanning robots off the plan" (as until 2026-11-27, later)
    f.advance(0.1)
    reason = ops.state.run.reason
    assert reason.startswith("replan") and "rejected" in reason and "robot {} stands at".format(rid) in reason, reason
    carry(f, rid, back.x, back.y)  # put back where it was
    f.advance(0.5)
    assert f.ask(ops, "start").ok
    assert f.run_until(lambda: f.phase == "done", 60) and f.at_goals()
    assert f.core.summary().collisions == 0


def test_robots_a_replan_left_between_cells_and_enabled_after_a_takeover_are_named_when_the_run_cannot_go_on():
    """Found by a live session (tests/live_sessions.py, seed 3): bumpers stop robots 1 and 2 halfway
    through a drive, and a replan leaves them where they stand. The manager dies; the new one
    takes the run over paused. Enabled, each was promised "a way home around the others once the
    run goes on, or replan": at Start none could come (a robot between two cells is replanned from
    where it stands, never given a way home), and the run ran on with nobody moving and nothing
    said. Now enabling says there is no way home for it, as it does while the run runs, and the
    run's line says, once nothing has moved for a while, that it cannot go on without an operator,
    and what to do; a replan takes them home."""
    f = MemoryFleet(lab(), lab_fleet(5), settings=ManagerSettings(step_time=0.5, size=TURTLEBOT2))
    for rid in (1, 2):
        f.robots[rid].navigator.bumps = {2}
        f.robots[rid].navigator.bump_seconds = 0.5
    ops = f.console()
    f.link_up()
    assert f.ask(ops, "start").ok
    out = lambda rid: f.core.run.engine.run.out[f.core.fleet.by_id[rid].agent]  # noqa: E731
    assert f.run_until(lambda: out(1) and out(2), 30)
    f.advance(1.0)
    replanned(f, ops)
    assert f.core.run.stranded == {0, 1}
    f.advance(2.0)
    f.kill_manager()
    f.advance(1.0)
    f.resume_manager()
    ops = f.console()
    f.advance(0.5)
    for rid in (1, 2):
        answer = f.ask(ops, "enable", robot=rid)
        assert answer.ok and answer.reason.startswith("plan {} has no way to its goal for robot {}: it does not "
                                                      "stand on the centre of".format(f.core.run.plan_id, rid)) \
            and answer.reason.endswith("; replan to take it home"), answer.reason
    assert f.ask(ops, "start").ok
    assert f.run_until(lambda: ops.state.run.reason.startswith("the run cannot go on without an operator"), 10), \
        ops.state.run.reason
    assert "robots 1, 2 have no way home in plan {}: replan".format(f.core.run.plan_id) in ops.state.run.reason
    replanned(f, ops)
    assert f.run_until(lambda: f.phase == "done", 60) and f.at_goals()
    assert f.core.summary().collisions == 0


def _halfway_cells_before(run: Run) -> set:
    """`Run.halfway_cells` as it was before 2026-11-27 (later): the engine's record only."""
    state, table = run.engine.run, run.engine.table
    return {tuple(table.coord(state.dst[state.next_incomplete(a)])) for a in range(state.num_agents)
            if state.out[a] is not None and state.halfway[a] and state.next_incomplete(a) >= 0
            and run.fleet[a].pose is None}


@pytest.mark.parametrize("kept", [True, False])
def test_a_robot_vicon_never_saw_stays_walled_in_across_replans(monkeypatch, kept):
    """Found by a live session (`--vicon` 580): robot 2's bumper stops it halfway out of its cell;
    the manager dies, and the new one runs on Vicon, which has not seen robot 2 since (occluded).
    The first replan walls off the cell robot 2 leans into by the engine's record that it stopped
    halfway; planned around, it is no longer halfway, and with no pose the second replan walled
    nothing: robot 2 was "moved by hand", its own pose between two cells. The plan's kept walls next
    to such a robot now stand for the record. The control puts the old rule back."""
    if not kept:
        monkeypatch.setattr(Run, "halfway_cells", _halfway_cells_before)
    camera = MemoryVicon(random.Random(3))
    f = MemoryFleet(lab(), lab_fleet(5), vicon=camera,
                    settings=ManagerSettings(step_time=0.5, size=TURTLEBOT2, reroute="auto", reroute_timed=False))
    f.robots[2].navigator.bumps = {1}
    f.robots[2].navigator.bump_seconds = 0.5
    ops = f.console()
    f.link_up()
    f.advance(0.1)
    assert f.ask(ops, "source", source="robot").ok and f.ask(ops, "start").ok
    assert f.run_until(lambda: f.core.run.engine.run.out[f.core.fleet.by_id[2].agent] is not None, 30)
    camera.occlude(2, f.now + 60)
    f.advance(3.0)
    f.kill_manager()
    f.advance(1.0)
    f.resume_manager()
    ops = f.console()
    f.advance(0.5)
    assert f.ask(ops, "source", source="vicon").ok
    f.advance(0.5)
    assert f.ask(ops, "disable", robot=4).ok
    replanned(f, ops)
    walls = f.core.run.kept_walls()
    assert walls and f.core.fleet.by_id[2].pose is None
    f.advance(0.5)
    replanned(f, ops)
    f.advance(2.0)
    alarms = [line for line in f.said if "where the run has it" in line]
    if kept:
        assert f.core.run.kept_walls() == walls and not alarms, alarms
    else:
        assert f.core.run.kept_walls() == [] and alarms
