"""The live console's pure parts: feed, model, picture, words, frame schedule; the demo's
stall choice and the virtual fleet's planned stall. No display, no sockets."""
from __future__ import annotations

import dataclasses
from typing import List, Optional, Sequence, Tuple

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from console.live.describe import BEHIND_MARK, blocked_chain, greyed, row
from console.live.fit import fit
from console.live.report import report_html
from console.live.ticker import Ticker
from console.live_console import AutoSwitch
from console.live.feed import CONNECTED, LOST, LinkStatus, LiveFeed, Reply
from console.live.model import LiveModel, LiveSource
from console.live.picture import WaitMark, WaitMarks, picture
from console.live.recorder import FrameSchedule, Recorder
from fleet_common.arg_types import tcp_endpoint
from fleet_common.control import (Activity, Notice, PlanData, Proposal, RobotInfo, RobotState, RunInfo, RunSetup,
                                  State, Waiting)
from fleet_common.grid import Grid
from fleet_common.errors import FleetError
from fleet_common.plan import Plan
from fleetctl.live_demo import pick_passing_stall, pick_rerouting_stall, pick_stall
from virtual_fleet.kinematics import VirtualNavigator
from virtual_fleet.stalls import parse_stall, stalls_by_robot
from fleet_common.wire.messages import Pose

ROWS = ("....", "..@.", "....")  # 4 x 3, top row first: cell (2, 1) blocked
PLAN = Plan.from_paths([[(0, 0), (1, 0), (2, 0), (3, 0)], [(3, 2), (2, 2), (1, 2), (0, 2)]])


def scene(plan: Plan = PLAN, robots: Tuple[int, ...] = (7, 9), plan_id: int = 1) -> RunSetup:
    return RunSetup("tiny", ROWS, (RobotInfo(7, "red", "tb7"), RobotInfo(9, "#00ff00", "tb9")),
                 PlanData(plan_id, robots, plan.positions, "/somewhere/tiny_plan.txt"), ("adg", "step"), 2.0)


def robot(rid: int, x: Optional[float] = 0.0, y: Optional[float] = 0.0, **kw) -> RobotState:
    fields = dict(id=rid, link="up", link_reason="", x=x, y=y, theta=0.0, source="robot", age=0.05,
                  stale=False, faults=(), out=None, activity=None, done=0, total=3, step=0, waiting=None,
                  behind=0.0)
    fields.update(kw)
    return RobotState(**fields)


def run(state: str = "running", clock: float = 3.0, plan_time: float = 1.5, proposal=None) -> RunInfo:
    return RunInfo(state, "", "adg", 1, clock, plan_time, 1, 0, 2, None, 0, proposal)


def state(seq: int, robots: Sequence[RobotState], run_info: Optional[RunInfo] = None, version: int = 5) -> State:
    return State(seq, version, run_info or run(), tuple(robots))


def connected_model() -> LiveModel:
    model = LiveModel("tcp://127.0.0.1:1")
    model.apply(LinkStatus(CONNECTED, "connected"), 0.0, 0.0)
    model.apply(scene(), 0.0, 0.0)
    return model


# ---- feed -------------------------------------------------------------------------------

def test_a_full_feed_drops_the_oldest_state_and_keeps_everything_else() -> None:
    feed = LiveFeed(limit=4)
    feed.offer(state(1, []), 0.0)
    feed.offer(Notice(1, 0.0, "fault", 7, "robot 7 reports bumper"), 0.1)
    feed.offer(state(2, []), 0.2)
    feed.offer(Reply("start", {}, False, "no"), 0.3)
    feed.offer(state(3, []), 0.4)  # full: state 1 goes
    feed.offer(state(4, []), 0.5)  # full: state 2 goes
    items = [item for item, _ in feed.drain(limit=3)]
    assert [type(i).__name__ for i in items] == ["Notice", "Reply", "State"] and items[2].seq == 3
    assert [item.seq for item, _ in feed.drain()] == [4]
    assert feed.dropped == 2 and len(feed) == 0


# ---- model ------------------------------------------------------------------------------

def test_scene_becomes_the_map_the_plan_and_the_robots_colours() -> None:
    model = connected_model()
    s = model.scene
    assert s.grid.width == 4 and s.grid.height == 3
    assert not s.grid.is_free((2, 1)) and s.grid.is_free((2, 0))  # rows are top first
    assert s.colours == ["#ff0000", "#00ff00"] and s.names == ["robot 7", "robot 9"]
    assert s.starts == [(0, 0), (3, 2)] and s.goals == [(3, 0), (0, 2)]
    assert "tiny_plan.txt" in s.info and "/somewhere" not in " ".join(s.info)
    assert model.agent_of == {7: 0, 9: 1}


def test_fleet_state_has_the_reported_poses_and_plan_starts_where_none_came() -> None:
    model = connected_model()
    model.apply(state(3, [robot(9, 2.5, 2.0, theta=np.pi / 2), robot(7, None, None, theta=None)]), 1.0, 1.0)
    fs = model.fleet_state()
    np.testing.assert_allclose(fs.positions, [[0.0, 0.0], [2.5, 2.0]])
    assert np.isnan(fs.headings[0]) and fs.headings[1] == pytest.approx(90.0)
    assert fs.time == 1.5 and fs.version == 3
    model.apply(state(2, [robot(9, 0.0, 0.0)]), 1.1, 1.1)  # older: ignored
    assert model.state.seq == 3
    model.apply(LinkStatus(CONNECTED, "reconnected"), 1.2, 1.2)  # a restarted manager counts from 1
    model.apply(state(1, [robot(9, 1.0, 2.0)]), 1.3, 1.3)
    assert model.state.seq == 1


def test_answers_refusals_and_a_lost_manager_are_lines_of_the_event_list() -> None:
    model = connected_model()
    model.apply(Reply("disable", {"robot": 7}, True, ""), 0.0, 0.0)
    model.apply(Reply("enable", {"robot": 7}, False, "refused: the state changed since you looked"), 0.0, 0.0)
    model.apply(LinkStatus(LOST, "manager lost: nothing heard for 3.5 s"), 0.0, 0.0)
    texts = [(line.level, line.robot, line.text) for line in model.lines]
    assert ("info", 7, "disable robot=7: done") in texts
    assert ("error", 7, "enable robot=7: REFUSED: refused: the state changed since you looked") in texts
    assert texts[-1][0] == "error" and "manager lost" in texts[-1][2]
    assert model.take_changes() >= {"reply", "events", "connection"} and not model.connected


def test_a_proposal_is_kept_until_the_state_says_nobody_waits_for_an_answer() -> None:
    model = connected_model()
    other = Plan.from_paths([[(0, 0), (0, 1)], [(3, 2), (3, 1)]])
    model.apply(Proposal(4, PlanData(1004, (7, 9), other.positions), "pp", 2, 1), 0.0, 0.0)
    model.apply(state(1, [robot(7), robot(9)], run(proposal=4)), 0.0, 0.0)
    assert model.proposal.id == 4 and model.proposal_plan.makespan == 1
    model.apply(state(2, [robot(7), robot(9)], run(proposal=None)), 0.0, 0.0)
    assert model.proposal is None and model.proposal_plan is None


def test_a_new_plan_is_drawn_from_its_step_0_until_a_state_of_it_comes() -> None:
    """A reroute's plan (RunSetup, plan 2) comes just before the first State of it: until then the
    rings of where the plan wants each robot are the new plan's step 0, not the old plan's step 1.5
    looked up in the new plan (they would jump ahead for a moment)."""
    model = connected_model()
    model.apply(state(3, [robot(7), robot(9)]), 1.0, 1.0)
    assert model.fleet_state().time == 1.5 and model.plan_start() == 0.0
    model.apply(scene(plan_id=2), 1.1, 1.1)
    # the new plan at its step 0, which is the run's step 1.5: the header's clock does not go back
    assert model.fleet_state().time == 0.0 and model.plan_start() == 1.5
    moved_on = RunInfo("running", "", "adg", 1, 3.2, 0.2, 2, 0, 2, None, 0, None, plan_start=1.6)
    model.apply(state(4, [robot(7), robot(9)], moved_on), 1.2, 1.2)
    assert model.fleet_state().time == 0.2 and model.plan_start() == 1.6


def test_live_source_answers_a_fleet_state_only_when_a_state_came() -> None:
    feed, model = LiveFeed(), LiveModel("e")
    source = LiveSource(feed, model, wall=lambda: 0.0)
    feed.offer(LinkStatus(CONNECTED, "connected"), 0.0)
    feed.offer(scene(), 0.0)
    assert source.poll(0.0) is not None  # the scene: robots on their starts
    assert source.take() >= {"scene", "connection"}
    feed.offer(Notice(1, 0.0, "run", None, "started"), 0.0)
    assert source.poll(0.1) is None and source.take() == {"events"}
    feed.offer(state(1, [robot(7, 1.0, 0.0), robot(9, 3.0, 2.0)]), 0.2)
    feed.offer(state(2, [robot(7, 2.0, 0.0), robot(9, 3.0, 2.0)]), 0.3)
    shown = source.poll(0.3)
    assert shown.version == 2 and shown.positions[0, 0] == 2.0


# ---- picture and words ------------------------------------------------------------------

def test_greyed_says_why_in_order_of_what_matters_most() -> None:
    assert greyed(robot(1, link="down", link_reason="timeout", faults=("bumper",))) == "link down: timeout"
    assert greyed(robot(1, faults=("bumper",), out="failed")) == "fault: bumper"
    assert greyed(robot(1, out="disabled")) == "disabled"
    assert greyed(robot(1, x=None)) == "no pose yet"
    assert greyed(robot(1, stale=True, age=3.24)) == "pose stale (3.2 s old)"
    assert greyed(robot(1)) is None
    assert greyed(robot(1), connected=False) == "manager lost"
    assert row(1, robot(1, out="disabled")).enabled is False and row(1, robot(1)).enabled is True
    assert row(1, robot(1, behind=BEHIND_MARK)).behind and not row(1, robot(1, behind=0.5)).behind


def test_picture_ghosts_follow_the_plan_clock_and_waits_point_at_agents() -> None:
    model = connected_model()
    before = dataclasses.replace(run(), state="waiting", clock=0.0, plan_time=0.0)
    model.apply(state(1, [robot(7), robot(9, 3.0, 2.0)], before), 0.0, 0.0)
    assert picture(model).ghost is None  # no plan clock before Start
    wait = Waiting((7,), (1, 0), "cell")
    model.apply(state(2, [robot(7, 0.4, 0.0, behind=2.0), robot(9, 3.0, 2.0, waiting=wait, link="down")],
                      run(plan_time=1.5)), 0.0, 0.0)
    pic = picture(model)
    np.testing.assert_allclose(pic.ghost, [[1.5, 0.0], [1.5, 2.0]])
    assert pic.behind.tolist() == [True, False]  # a greyed robot is greyed, not late
    assert pic.grey.tolist() == [False, True] and pic.labels[1] == "link down"
    assert pic.waits == [WaitMark(1, (1, 0), (0,))]
    # done before the plan's clock reached its end (the robots ran ahead of it): the ghosts are
    # where the plan ends, on the robots, not where the plan's clock stopped
    model.apply(state(3, [robot(7, 3.0, 0.0), robot(9, 0.0, 2.0)], run(state="done", plan_time=1.5)), 0.0, 0.0)
    np.testing.assert_allclose(picture(model).ghost, [[3.0, 0.0], [0.0, 2.0]])
    model.apply(LinkStatus(LOST, "lost"), 0.0, 0.0)
    lost = picture(model)
    assert lost.grey.all() and lost.waits == []


def test_a_follower_is_drawn_following_while_it_moves_and_waiting_once_it_stands_behind() -> None:
    model = connected_model()
    model.apply(state(1, [robot(7, 1.5, 0.0), robot(9, 0.8, 0.0, follows=7)]), 0.0, 0.0)
    pic = picture(model)
    assert pic.follows == [(1, 0)] and pic.waits == []  # robot 9 follows robot 7: a thin line
    held = Waiting((7,), (1, 0), "follow")
    model.apply(state(2, [robot(7, 1.5, 0.0), robot(9, 0.85, 0.0, follows=7, waiting=held)]), 0.0, 0.0)
    pic = picture(model)
    assert pic.follows == [] and pic.waits == [WaitMark(1, (1, 0), (0,))]  # it waits for it: red


def test_the_robots_real_size_sets_their_discs() -> None:
    from console.live.scene import scene_from_manager
    sized = dataclasses.replace(scene(), robot_size=(0.354, 0.1, 0.7))
    assert scene_from_manager(sized, "x").robot_diameter == pytest.approx(0.354 / 0.7)
    assert scene_from_manager(scene(), "x").robot_diameter == 1.0  # a manager of old: a cell


def test_a_wait_is_shown_once_it_has_lasted() -> None:
    marks = WaitMarks(after=0.3)
    w = WaitMark(1, (1, 0), (0,))
    assert marks.lasting([w], 10.0) == []
    assert marks.lasting([w], 10.2) == []
    assert marks.lasting([w], 10.31) == [w]
    assert marks.lasting([], 10.4) == [] and marks.lasting([w], 10.5) == []  # it went away: from 0


def test_blocked_by_chain_follows_the_waits_and_stops_at_a_cycle() -> None:
    robots = {1: robot(1, waiting=Waiting((2,), (3, 4), "cell")),
              2: robot(2, waiting=Waiting((3,), (5, 5), "cell")),
              3: robot(3, link="down", link_reason="no heartbeat")}
    assert blocked_chain(robots, 1) == ["robot 1 waits for robot 2 to enter (3, 4) (cell)",
                                        "robot 2 waits for robot 3 to enter (5, 5) (cell)",
                                        "robot 3 link down: no heartbeat"]
    robots[3] = robot(3, waiting=Waiting((1,), None, "cell"))
    assert blocked_chain(robots, 1)[-1] == "... robot 1 again: a cycle"
    assert blocked_chain({1: robot(1)}, 1) == []


# ---- recording --------------------------------------------------------------------------

def test_frames_at_every_change_of_the_run_and_every_n_steps(tmp_path) -> None:
    schedule = FrameSchedule(every=2.0)
    plan_times = [("waiting", 0.0, 0.0), ("waiting", 0.0, 0.0), ("running", 0.1, 0.05), ("running", 1.0, 1.9),
                  ("running", 1.5, 2.1), ("running", 2.0, 3.0), ("paused", 2.1, 3.1), ("running", 3.0, 4.0)]
    due = [schedule.due(dataclasses.replace(run(), state=s, clock=c, plan_time=t)) for s, c, t in plan_times]
    assert due == [True, False, True, False, True, False, True, True]
    grabbed = []
    recorder = Recorder(tmp_path / "frames", lambda p: (grabbed.append(p), p.write_bytes(b"png")), every=1.0)
    for t in (0.0, 0.4, 1.2):
        recorder.offer(dataclasses.replace(run(), clock=t + 0.1, plan_time=t))
    assert [p.name for p in grabbed] == ["0001.png", "0002.png"]
    assert (tmp_path / "frames" / "frames.txt").read_text().splitlines()[1:] == [
        "0001.png  running  0.00  0.10", "0002.png  running  1.20  1.30"]


def test_frames_go_on_every_step_across_a_reroute_on_the_runs_plan_clock(tmp_path) -> None:
    # a reroute at plan step 7.3: the new plan's own clock starts again at 0, the run's goes on
    grabbed = []
    recorder = Recorder(tmp_path, lambda p: grabbed.append(p.name), every=1.0)
    steps = [(6.9, 0.0, 6.9), (7.2, 0.0, 7.2), (7.4, 7.3, 0.1), (8.1, 7.3, 0.8), (9.2, 7.3, 1.9)]
    for clock, start, t in steps:
        recorder.offer(dataclasses.replace(run(), clock=clock, plan_start=start, plan_time=t))
    assert len(grabbed) == 4  # at 6.9, 7.2, 8.1 and 9.2: a frame every step, the run's
    assert [line.split()[2] for line in (tmp_path / "frames.txt").read_text().splitlines()[1:]] == \
        ["6.90", "7.20", "8.10", "9.20"]


# ---- the demo's stall -------------------------------------------------------------------

def test_the_stall_is_the_move_another_robot_feels_at_once() -> None:
    # agent 0 leaves (1, 0) at step 2; agent 1 enters it at step 2 (following): the closest pair
    plan = Plan.from_paths([[(0, 0), (0, 0), (1, 0), (2, 0), (3, 0)],
                            [(1, 2), (1, 1), (1, 1), (1, 0), (1, 0)]])
    choice = pick_stall(plan)
    assert (choice.agent, choice.move, choice.waiter, choice.cell) == (0, 2, 1, (1, 0))
    assert pick_stall(Plan.from_paths([[(0, 0), (1, 0)], [(3, 3), (3, 2)]])) is None


def test_lab_plan_stalls_green_where_blue_follows_it() -> None:
    from fleet_common.formats.instance import read_instance
    from fleet_common.lab import lab_instance_path, lab_map_path
    from fleet_common.planning import solve

    inst = read_instance(lab_instance_path(), map_dirs=[lab_map_path().parent])
    plan = solve("cbs", inst.grid, inst.starts, inst.goals, seed=0).plan
    choice = pick_stall(plan)
    t = choice.step
    assert tuple(plan.positions[t, choice.agent]) == choice.cell != tuple(plan.positions[t + 1, choice.agent])
    entering = [u for u in range(t, plan.makespan) if tuple(plan.positions[u + 1, choice.waiter]) == choice.cell]
    assert entering and entering[0] - t <= 1


def test_lab_plan_has_a_stall_the_reordering_strategy_gets_around() -> None:
    from fleet_common.formats.instance import read_instance
    from fleet_common.lab import lab_instance_path, lab_map_path
    from fleet_common.planning import solve

    inst = read_instance(lab_instance_path(), map_dirs=[lab_map_path().parent])
    plan = solve("cbs", inst.grid, inst.starts, inst.goals, seed=0).plan
    choice = pick_passing_stall(plan, moves=4.0)
    a, b, cell = choice.agent, choice.waiter, choice.cell
    # the stalled robot reaches the cell later in the plan, the waiter right after it
    a_enters = [u for u in range(choice.step + 1, plan.makespan) if tuple(plan.positions[u + 1, a]) == cell]
    b_enters = [u for u in range(plan.makespan) if tuple(plan.positions[u + 1, b]) == cell]
    assert a_enters and b_enters and a_enters[0] < b_enters[0]
    assert 0 < choice.step <= plan.makespan // 2  # the robots are under way, the run not half over
    # a plan where nobody's order could change has no such stall
    assert pick_passing_stall(Plan.from_paths([[(0, 0), (1, 0)], [(3, 3), (3, 2)]]), moves=4.0) is None


def stalled_run(plan: Plan, grid: Grid, agent: int, move: int, moves: float, reroute: bool):
    """The lab plan on the simulator as the demo's manager and fleet run it, robot `agent` halting
    `moves` moves in its drive `move` (from 1), with the manager's reroute rule or without."""
    from fleet_common.delays.draw import MoveFates
    from fleet_common.execution import Engine
    from fleet_common.execution.reroute import RerouteRule
    from fleet_common.execution.simulate import simulate
    from fleet_common.robot_size import RobotSize
    from fleetctl.live_demo import DELAY, STEP_MOVES

    table = Engine(plan, follow=True).table
    n = len(table.agent)
    stall = np.zeros(n)
    stall[int(np.flatnonzero(table.agent == agent)[move - 1])] = moves
    fates = MoveFates(np.full(n, DELAY / 2), np.ones(n), stall, np.full(n, 0.5), np.zeros(n), np.zeros(n))
    return simulate(plan, "adg", size=RobotSize(), fates=fates, step_time=STEP_MOVES,
                    **({"reroute": RerouteRule(), "grid": grid} if reroute else {}))


def test_lab_plan_has_a_stall_the_managers_reroute_rule_gets_around() -> None:
    from fleet_common.formats.instance import read_instance
    from fleet_common.lab import lab_instance_path, lab_map_path
    from fleet_common.planning import solve

    inst = read_instance(lab_instance_path(), map_dirs=[lab_map_path().parent])
    plan = solve("cbs", inst.grid, inst.starts, inst.goals, seed=0).plan
    choice = pick_rerouting_stall(plan, inst.grid, moves=4.0)
    rerouted = stalled_run(plan, inst.grid, choice.agent, choice.move, 4.0, reroute=True)
    fixed = stalled_run(plan, inst.grid, choice.agent, choice.move, 4.0, reroute=False)
    assert rerouted.reroutes and not rerouted.collisions and not rerouted.unfinished()
    found = rerouted.reroutes[0][1]
    assert found.around == choice.agent and choice.waiter in found.held  # round the stalled robot
    # the robot it held up arrives sooner, by half the stall or more
    assert rerouted.metrics.agents[choice.waiter].arrival <= fixed.metrics.agents[choice.waiter].arrival - 2.0
    assert 0 < choice.step <= plan.makespan // 2
    # the ADG's stall is no such stall: the demo must choose another one when rerouting is on
    adg = pick_stall(plan)
    assert not stalled_run(plan, inst.grid, adg.agent, adg.move, 4.0, reroute=True).reroutes
    assert pick_rerouting_stall(Plan.from_paths([[(0, 0), (1, 0)], [(3, 3), (3, 2)]]), Grid.from_rows(
        ["....", "....", "....", "...."]), moves=4.0) is None
    # the demo's fleet is told that stall with rerouting on, the ADG's without (the default kept)
    from fleet_common.robots import default_definitions_path, read_robot_definitions
    from fleetctl.live_demo import DemoSettings, stall_argument

    robots = read_robot_definitions(default_definitions_path())
    for mode in ("auto", "propose"):
        assert stall_argument(DemoSettings(reroute=mode), plan, robots, inst.grid) == "{}:{}:8".format(
            robots[choice.agent].id, choice.move)
    assert stall_argument(DemoSettings(), plan, robots, inst.grid) == "{}:{}:8".format(robots[adg.agent].id, adg.move)


def test_planned_stall_halts_the_kth_drive_halfway() -> None:
    now = [0.0]
    nav = VirtualNavigator(Pose(0.0, 0.0, 0.0), speed=1.0, clock=lambda: now[0])
    nav.stalls[2] = 5.0
    nav.start_drive(1.0, 0.0, 0.0)  # drive 1: one second
    now[0] = 1.0
    assert nav.poll() is not None
    nav.start_drive(2.0, 0.0, 0.0)  # drive 2: half, five seconds still, the other half
    now[0] = 1.5
    assert nav.pose().x == pytest.approx(1.5)
    now[0] = 6.4
    assert nav.pose().x == pytest.approx(1.5) and nav.poll() is None
    now[0] = 7.0
    assert nav.poll() is not None and nav.pose().x == pytest.approx(2.0)


def test_stall_arguments_are_checked() -> None:
    assert parse_stall("2:7:8").describe() == "robot 2 stalls 8 s in its drive 7"
    for bad in ("2:7", "x:1:2", "2:0:3", "2:1:-1", "2:1:3:4"):
        with pytest.raises(FleetError, match="ROBOT:MOVE:SECONDS"):
            parse_stall(bad)
    assert stalls_by_robot([parse_stall("5:1:1"), parse_stall("5:3:2"), parse_stall("1:1:4")]) == {
        5: {1: 1.0, 3: 2.0}, 1: {1: 4.0}}


def test_the_link_decodes_only_the_newest_of_the_states_waiting() -> None:
    from console.live.link import newest_states
    from fleet_common.control import encode

    frames = [encode(state(1, [])), encode(Notice(1, 0.0, "run", None, "x")), encode(state(2, [])),
              encode(Notice(2, 0.0, "run", None, "y")), encode(state(3, []))]
    kept = newest_states(frames)
    assert kept == [frames[1], frames[3], frames[4]]
    assert newest_states(frames[:2]) == frames[:2] and newest_states([]) == []


def test_a_proposal_after_an_older_state_in_the_same_batch_stays() -> None:
    model = connected_model()
    other = Plan.from_paths([[(0, 0), (0, 1)], [(3, 2), (3, 1)]])
    model.apply(state(1, [robot(7), robot(9)], run(proposal=None)), 0.0, 0.0)  # sent before the proposal
    model.apply(Proposal(4, PlanData(1004, (7, 9), other.positions), "pp", 2, 1), 0.0, 0.0)
    assert model.proposal is not None and model.proposal.id == 4


# ---- the run's story in words -------------------------------------------------------------

def drive(rid: int, x: float, y: float, **kw) -> RobotState:
    return robot(rid, x, y, activity=Activity("drive", 2, x + 1.0, y), **kw)


def told(ticker: Ticker, states: Sequence[Tuple[float, State]]) -> List[str]:
    out: List[str] = []
    for at, s in states:
        out += ticker.state(s, at)
    return out


def test_the_story_tells_a_stall_a_wait_that_lasts_and_the_operators_hand() -> None:
    ticker = Ticker()
    ticker.step_time = 1.0
    waiting = Waiting((2,), (3, 0), "cell")
    waiting_run = run("waiting")
    story = told(ticker, [(0.0, state(1, [drive(2, 1.0, 0.0), robot(3)], waiting_run)),
                          (0.1, state(2, [drive(2, 1.0, 0.0), robot(3)])),
                          (0.5, state(3, [drive(2, 1.2, 0.0), robot(3, waiting=waiting)])),
                          (1.4, state(4, [drive(2, 1.2, 0.0), robot(3, waiting=waiting)])),  # 0.9 s still
                          (1.6, state(5, [drive(2, 1.2, 0.0), robot(3, waiting=waiting)])),
                          (1.7, state(6, [drive(2, 1.2, 0.0), robot(3, waiting=waiting)])),
                          (2.0, state(7, [drive(2, 1.6, 0.0), robot(3, out="disabled")]))])
    assert story == ["the run starts: 2 robots", "robot 3 waits for robot 2", "robot 2 stalled",
                     "robot 2 moves again", "robot 3 disabled by the operator"]


def test_a_follower_held_behind_its_leader_stops_behind_it() -> None:
    """Waiting for the cell, then (the cell released) driving in and held at the safe distance
    behind a leader that stands: two waits, told as what a visitor sees."""
    ticker = Ticker()
    ticker.step_time = 1.0
    cell = Waiting((2,), (3, 0), "cell")
    held = Waiting((2,), (3, 0), "follow")
    story = told(ticker, [(0.0, state(1, [drive(2, 1.0, 0.0), robot(3, waiting=cell)])),
                          (0.6, state(2, [drive(2, 1.1, 0.0), robot(3, waiting=cell)])),
                          (0.8, state(3, [drive(2, 1.2, 0.0), drive(3, 0.1, 0.0, follows=2)])),
                          (1.0, state(4, [drive(2, 1.3, 0.0), drive(3, 0.2, 0.0, follows=2, waiting=held)])),
                          (1.6, state(5, [drive(2, 1.3, 0.0), drive(3, 0.2, 0.0, follows=2, waiting=held)]))])
    assert story[:2] == ["robot 3 waits for robot 2", "robot 3 stops behind robot 2"]


def test_short_waits_and_standing_robots_that_wait_or_follow_are_no_news() -> None:
    ticker = Ticker()
    ticker.step_time = 1.0
    short = Waiting((2,), (3, 0), "cell")
    story = told(ticker, [(0.0, state(1, [drive(2, 1.0, 0.0), robot(3)])),
                          (0.2, state(2, [drive(2, 1.0, 0.0, waiting=Waiting((), None, "barrier")),
                                          robot(3, waiting=short)])),
                          (0.4, state(3, [drive(2, 1.0, 0.0, waiting=Waiting((), None, "barrier")), robot(3)])),
                          # robot 3 follows robot 2, which stands: robot 3 waits, it does not stall
                          (0.5, state(4, [robot(2, 1.0, 0.0), drive(3, 0.0, 0.0, follows=2)])),
                          (2.5, state(5, [robot(2, 1.0, 0.0), drive(3, 0.0, 0.0, follows=2)])),
                          # robot 2 leaves; robot 3 follows a moment later
                          (3.0, state(51, [drive(2, 1.3, 0.0), drive(3, 0.0, 0.0, follows=2)])),
                          (3.6, state(52, [drive(2, 1.6, 0.0), drive(3, 0.0, 0.0, follows=2)])),
                          (3.9, state(53, [drive(2, 1.8, 0.0), drive(3, 0.2, 0.0, follows=2)])),
                          # robot 2 stood idle for seconds, is given a drive and leaves at once
                          (5.0, state(6, [robot(2, 1.8, 0.0), robot(3, 0.2, 0.0)])),
                          (5.1, state(7, [drive(2, 1.8, 0.0), robot(3, 0.2, 0.0)])),
                          (5.6, state(8, [drive(2, 1.8, 0.0), robot(3, 0.2, 0.0)])),
                          (5.8, state(9, [drive(2, 2.0, 0.0), robot(3, 0.2, 0.0)]))])
    assert story == []


def test_a_crowd_is_counted_and_the_end_and_a_replan_are_told() -> None:
    ticker = Ticker()
    ticker.step_time = 0.5
    robots = [drive(i, float(i), 0.0) for i in range(1, 11)]
    story = told(ticker, [(0.0, state(1, robots)), (1.0, state(2, robots))])
    assert story == ["robot 1 stalled", "robot 2 stalled", "and 8 more robots stalled"]
    done = dataclasses.replace(run("done", clock=41.6), arrived=2)
    assert ticker.state(state(3, [robot(1, 1.0, 0.0)], done), 2.0) == \
        ["every robot is home: done in 42 s, no collision"]
    assert ticker.notice(Notice(9, 3.0, "plan", None, "replanned 4 robots: plan 2 (planned by pp)")) == \
        ["replanned 4 robots"]
    assert ticker.notice(Notice(10, 3.0, "operator", None, "console: start")) == []
    assert ticker.notice(Notice(11, 4.0, "strategy", None, "strategy switched: adg (lookahead 1) -> "
                                "reorder (gap 1, reach 4, budget 400)")) == ["strategy now reorder"]
    assert ticker.notice(Notice(12, 4.0, "pass", 3, "robot 3 goes before robot 2 at (5, 5)")) == \
        ["robot 3 goes before robot 2"]


def test_the_ticker_tells_reroutes_made_and_the_mode_not_proposals() -> None:
    ticker = Ticker()
    assert ticker.notice(Notice(1, 1.0, "reroute", None, "reroute switched: off -> auto")) == \
        ["rerouting now auto"]
    assert ticker.notice(Notice(2, 2.0, "reroute", None, "robots 3, 7 rerouted around robot 12, late 6 "
                                "steps: 9 steps sooner")) == ["robots 3, 7 rerouted around robot 12, late 6 steps"]
    assert ticker.notice(Notice(3, 3.0, "reroute", None, "robot 4, late 5 steps, rerouted: it held up robot "
                                "1; 1 step sooner")) == ["robot 4, late 5 steps, rerouted: it held up robot 1"]
    assert ticker.notice(Notice(4, 4.0, "reroute", None, "robot 5, predicted last, rerouted onto a shorter way "
                                "while robot 3 is late 4 steps: 6 steps sooner")) == [
        "robot 5, predicted last, rerouted onto a shorter way while robot 3 is late 4 steps"]
    # scope all: every robot may get a new path; many robots named in short, the gain on the last one
    assert ticker.notice(Notice(5, 5.0, "reroute", None, "reroute switched: auto -> auto (every robot) "
                                "(reroute 4 dropped)")) == ["rerouting now auto (every robot)"]
    assert ticker.notice(Notice(6, 6.0, "reroute", None, "robots 1, 2, 4, 5 and 11 more rerouted around robot "
                                "12, late 6 steps: the last robot 3 steps sooner")) == [
        "robots 1, 2, 4, 5 and 11 more rerouted around robot 12, late 6 steps"]
    for text in ("reroute 5 proposed: robot 4, late 5 steps, rerouted: it held up robot 1; 3 steps sooner",
                 "reroute 5 dropped: robot 4 moved since it was proposed",
                 "reroute dropped: the reroute no longer fits: robot 4 moved since"):
        assert ticker.notice(Notice(4, 4.0, "reroute", None, text)) == [], text


def test_the_console_switches_strategy_once_a_robot_waits_for_a_stalled_one() -> None:
    model = connected_model()
    model.ticker.step_time = 1.0
    asked: List[tuple] = []
    switch = AutoSwitch(lambda action, **args: asked.append((action, args)), "reorder")
    waits = Waiting((2,), (3, 0), "cell")
    frames = [(0.0, state(1, [drive(2, 1.0, 0.0), robot(3, waiting=waits)], version=5)),  # 2 drives
              (0.5, state(2, [drive(2, 1.2, 0.0), robot(3, waiting=waits)], version=5)),
              (1.6, state(3, [drive(2, 1.2, 0.0), robot(3, waiting=waits)], version=6))]  # 2 stalled
    for at, item in frames:
        model.apply(item, at, at)
        switch(model, at)
        if at < 1.6:
            assert asked == []  # a robot waiting for one that moves is no reason to switch
    assert asked == [("strategy", {"based_on": 6, "name": "reorder"})]
    model.apply(state(4, [drive(2, 1.2, 0.0), robot(3, waiting=waits)], version=7), 1.7, 1.7)
    switch(model, 1.7)
    assert len(asked) == 1  # once
    # a run already under the strategy, or not running, is left alone
    for run_info, expected in ((dataclasses.replace(run(), strategy="reorder"), 0),
                               (run("paused"), 0), (run(), 1)):
        other = connected_model()
        other.ticker.step_time = 1.0
        mine: List[tuple] = []
        switch = AutoSwitch(lambda action, **args: mine.append(action), "reorder")
        for at, item in frames:
            other.apply(dataclasses.replace(item, run=run_info), at, at)
            switch(other, at)
        assert len(mine) == expected, run_info


def test_the_models_story_goes_to_the_event_list_and_the_ticker() -> None:
    model = connected_model()
    model.apply(state(1, [robot(7), robot(9)], run("waiting")), 0.0, 0.0)
    model.apply(state(2, [robot(7), robot(9, out="disabled")]), 0.1, 0.1)
    assert [line.text for line in model.story] == ["the run starts: 2 robots", "robot 9 disabled by the operator"]
    assert model.lines[-1].kind == "story" and model.lines[-1].robot == 9 and model.told == 2
    assert "story" in model.take_changes()


# ---- does a plan fit the fleet ------------------------------------------------------------

def test_a_plan_fits_the_fleet_on_its_map_with_one_agent_a_robot() -> None:
    setup = scene()
    tiny = Grid.from_rows(list(ROWS), blocked="@", name="tiny.map")
    ok = fit("p.txt", tiny, 2, setup)
    assert ok.ok and ok.robots == (7, 9) and "agent 0 -> robot 7, agent 1 -> robot 9" in ok.reason
    other = Grid.from_rows(["....", "....", "...."], name="open.map")
    wrong_map = fit("p.txt", other, 2, setup)
    assert not wrong_map.ok and wrong_map.reason == (
        "p.txt is for map open.map (4 x 3); this fleet runs on tiny (4 x 3): open a plan for that map")
    three = fit("p.txt", tiny, 3, setup)
    assert not three.ok and "p.txt has 3 agents but this fleet has 2 robots" in three.reason


# ---- frames tell the story ------------------------------------------------------------------

def test_a_new_sentence_is_a_frame_of_its_own_with_the_words_beside_it(tmp_path) -> None:
    grabbed: List[str] = []
    rec = Recorder(tmp_path, lambda p: grabbed.append(p.name), every=10.0)
    r = run("running", clock=1.0, plan_time=0.5)
    assert rec.offer(r, [], 0) is not None  # the first state
    assert rec.offer(r, [], 0) is None
    assert rec.offer(r, ["robot 2 stalled"], 1) is not None
    assert rec.offer(r, ["robot 2 stalled", "robot 3 waits for robot 2", "robot 2 moves again"], 3) is not None
    lines = (tmp_path / "frames.txt").read_text().splitlines()
    assert lines[2].endswith("| robot 2 stalled")
    assert lines[3].endswith("| robot 3 waits for robot 2 ; robot 2 moves again")


# ---- the report the console saves ----------------------------------------------------------

def test_the_consoles_report_lists_the_story_filterable_and_escaped() -> None:
    model = connected_model()
    model.apply(state(1, [robot(7), robot(9)], run("waiting")), 0.0, 0.0)
    model.apply(state(2, [robot(7), robot(9)], run("running")), 0.0, 0.0)
    model.apply(Notice(1, 0.0, "operator", 9, "ops: disable robot 9 <now>"), 0.1, 0.1)
    page = report_html(model, "report.png")
    assert "<h1>tiny_plan.txt</h1>" in page and "<img src='report.png'" in page
    assert "id='word'" in page and "data-robot='9'" in page and "&lt;now&gt;" in page
    assert "the run starts: 2 robots" in page


# ---- endpoints ---------------------------------------------------------------------------------

@given(st.sampled_from(["127.0.0.1", "lab-pc", "10.0.0.7", "[::1]"]), st.integers(1, 65535), st.booleans())
def test_an_endpoint_is_taken_with_or_without_tcp(host: str, port: int, scheme: bool) -> None:
    text = "{}{}:{}".format("tcp://" if scheme else "", host, port)
    assert tcp_endpoint(text) == "tcp://{}:{}".format(host, port)


@pytest.mark.parametrize("bad", ["7100", "tcp://lab-pc", "udp://a:1", "a b:1", "h:0", "h:65536", "h:x", ""])
def test_a_bad_endpoint_says_what_was_expected(bad: str) -> None:
    with pytest.raises(ValueError, match="expected HOST:PORT or tcp://HOST:PORT"):
        tcp_endpoint(bad)


def test_an_answer_of_another_session_is_forgotten_when_a_manager_answers_again() -> None:
    model = connected_model()
    model.apply(Reply("start", {}, False, "the run is done"), 0.0, 0.0)
    assert model.last_reply is not None and "reply" in model.take_changes()
    model.apply(LinkStatus(LOST, "manager lost"), 1.0, 1.0)
    model.apply(LinkStatus(CONNECTED, "connected to a restarted manager"), 2.0, 2.0)
    assert model.last_reply is None and "reply" in model.take_changes()
