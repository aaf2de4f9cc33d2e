"""Running a plan under control: switching strategies, pause and step, disabled and
failed robots, blocked-by reports, refused events, metrics and new strategies."""
from __future__ import annotations

from typing import Dict, List

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from fleet_common.execution import (
    STRATEGIES, ActionCompleted, ActionStarted, Disabled, Enabled, Engine, EventError, Freeze, Pause, Resume,
    RobotFailed, StepRound, Strategy, SwitchStrategy, Thaw, UnknownStrategyError, make_strategy, register,
)
from fleet_common.delays import parse_delay_model
from fleet_common.execution.events import CELL, PAUSED
from fleet_common.execution.simulate import simulate
from fleet_common.execution.strategy import BARRIER
from fleet_common.formats import default_map_dirs, read_solution
from fleet_common.plan import Plan

# three robots in a row heading right (2 follows 1 follows 0), robot 3 on its own lane
CORRIDOR = Plan.from_paths([[(x + 3, 0) for x in range(4)], [(x + 2, 0) for x in range(4)],
                            [(x + 1, 0) for x in range(4)], [(x, 3) for x in range(4)]])
# docstring example of `adg`: robot 1 comes down from E into C once robot 0 has left it
EXAMPLE = Plan.from_paths([[(0, 0), (1, 0), (2, 0), (3, 0), (3, 0)],
                           [(2, 1), (2, 1), (2, 1), (2, 0), (1, 0)]])
MODERATE = parse_delay_model(["moderate"])
_plans: Dict[str, Plan] = {}


@pytest.fixture(scope="module")
def sample(shared_data) -> Plan:
    if "sample" not in _plans:
        _plans["sample"] = read_solution(shared_data / "solutions" / "pibt_sample.txt",
                                         map_dirs=default_map_dirs()).plan
    return _plans["sample"]


def drive(engine: Engine, pending: List, time: float = 1.0) -> List:
    """Complete every dispatched action, first come first served; all dispatches seen."""
    seen = []
    while pending:
        d = pending.pop(0)
        seen.append(d)
        pending.extend(engine.handle(ActionCompleted(d.agent, d.index, time)))
    return seen


# ---- disabled robots and blocked-by ------------------------------------------------------
def test_adg_blocks_only_the_chain_behind_a_disabled_robot():
    engine = Engine(CORRIDOR, "adg")
    engine.handle(Disabled(0, 0.0))
    done = drive(engine, engine.handle(Resume(0.0)))
    assert {d.agent for d in done} == {3} and engine.run.finished_agent(3)
    assert engine.waiting() == [(1, (0,), (3, 0), CELL), (2, (1,), (2, 0), CELL)]
    assert engine.blocked_by() == {0: [1, 2]} and engine.stuck and not engine.finished
    drive(engine, engine.handle(Enabled(0, 5.0)))  # continues where it stopped
    assert engine.finished and not engine.waiting()


def test_under_the_step_barrier_a_disabled_robot_blocks_everyone_waiting_for_the_step():
    engine = Engine(CORRIDOR, "step")
    engine.handle(Disabled(0, 0.0))
    done = drive(engine, engine.handle(Resume(0.0)))
    assert [(d.agent, d.step) for d in done] == [(3, 0)]  # then robot 3 waits for 1's step 0
    waits = {w.agent: w for w in engine.waiting()}
    assert waits[3].reason == BARRIER and waits[3].on == (1, 2)
    assert engine.blocked_by() == {0: [1, 2, 3]}
    drive(engine, engine.handle(Enabled(0, 5.0)))
    assert engine.finished


def test_a_robot_disabled_mid_move_may_still_finish_that_move_but_gets_nothing_new():
    engine = Engine(CORRIDOR, "adg", lookahead=3)
    sent = [d for d in engine.handle(Resume(0.0)) if d.agent == 0]
    assert [d.index for d in sent] == [0, 1, 2]  # three free cells ahead: sent at once
    engine.handle(ActionStarted(0, 0, 0.0))
    engine.handle(Disabled(0, 0.5))  # the unstarted two are taken back
    released = engine.handle(ActionCompleted(0, 0, 1.0))  # robot 1 may now enter (3, 0), no further
    assert [(d.agent, d.index, d.dst) for d in released] == [(1, 0, (3, 0))]
    assert engine.run.completed[0] == 1 and engine.run.dispatched[0] == 1
    with pytest.raises(EventError):
        engine.handle(ActionCompleted(0, 2, 1.5))
    again = engine.handle(Enabled(0, 2.0))
    assert [(d.agent, d.index) for d in again] == [(0, 1), (0, 2)]


def test_a_failed_robot_holds_both_cells_of_its_move_and_retries_it_when_enabled():
    engine = Engine(EXAMPLE, "adg")
    pending = engine.handle(Resume(0.0))
    pending = engine.handle(ActionCompleted(0, 0, 1.0))  # robot 0 in B, sent B->C
    assert [(d.agent, d.index) for d in pending] == [(0, 1)]
    engine.handle(ActionStarted(0, 1, 1.0))
    assert engine.handle(RobotFailed(0, 1.5)) == []
    assert engine.waiting() == [(1, (0,), (2, 0), CELL)] and engine.blocked_by() == {0: [1]}
    retry = engine.handle(Enabled(0, 9.0))
    assert [(d.agent, d.index, d.src, d.dst) for d in retry] == [(0, 1, (1, 0), (2, 0))]
    drive(engine, retry)
    assert engine.finished


def test_disabled_then_enabled_in_a_simulated_run_is_safe_and_finishes(sample):
    stalled = simulate(sample, "adg", MODERATE, seed=3, disable={5: 10})
    blocked = stalled.engine.blocked_by()[5]
    assert blocked and stalled.unfinished() == blocked and not stalled.collisions
    assert stalled.engine.stuck
    late = stalled.end_time + 10.0
    resumed = simulate(sample, "adg", MODERATE, seed=3, disable={5: 10}, controls=[Enabled(5, late)])
    assert resumed.finished and not resumed.collisions
    assert resumed.trace.final_cells() == sample.goals
    assert sum(resumed.metrics.agents[r].blocked_by.get(5, 0.0) for r in blocked) > 0


# ---- pause and step ----------------------------------------------------------------------
def test_a_run_starts_paused_and_pause_stops_new_actions(sample):
    engine = Engine(sample, "adg")
    assert engine.paused and {w.reason for w in engine.waiting()} == {PAUSED}
    pending = engine.handle(Resume(0.0))
    assert len(pending) > 50
    engine.handle(Pause(0.5))
    for d in pending:  # robots finish what they were sent, nothing new is sent
        assert engine.handle(ActionCompleted(d.agent, d.index, 1.0)) == []
    assert engine.paused and not engine.stuck and engine.waiting()
    assert len(engine.handle(Resume(2.0))) > 50


def test_a_freeze_sends_nothing_new_until_the_thaw_and_the_run_goes_on_meanwhile(sample):
    """A look for a reroute in flight: completions count, nothing new is sent, the run is neither
    paused (its clock runs) nor stuck; the thaw sends what was kept back, as pause and resume."""
    engine = Engine(sample, "adg")
    pending = engine.handle(Resume(0.0))
    engine.handle(Freeze(0.5))
    for d in pending:
        assert engine.handle(ActionCompleted(d.agent, d.index, 1.0)) == []
    assert engine.frozen and not engine.paused and not engine.stuck and engine.run.clock.steps(1.5) == 1.5
    assert sum(engine.run.completed) == len(pending)
    released = engine.handle(Thaw(1.5))
    assert len(released) > 50 and not engine.frozen
    assert engine.handle(Thaw(1.6)) == []  # a thaw when not frozen changes nothing


def test_step_round_of_the_step_strategy_releases_exactly_one_plan_step(sample):
    engine = Engine(sample, "step")
    table = engine.table
    for _ in range(4):
        done = drive(engine, engine.handle(StepRound(0.0)))
        steps = {d.step for d in done}
        assert len(steps) == 1
        t = steps.pop()
        expected = {(r, a.index) for r in range(table.num_agents) for a in table.actions_of(r) if a.step == t}
        assert {(d.agent, d.index) for d in done} == expected  # followers included, nothing more
        assert not engine.run.moving and engine.paused


def test_step_round_of_the_adg_strategy_releases_one_action_per_robot(sample):
    engine = Engine(sample, "adg", lookahead=3)
    for _ in range(3):
        before = list(engine.run.completed)
        done = drive(engine, engine.handle(StepRound(0.0)))
        assert done and all(c - b <= 1 for c, b in zip(engine.run.completed, before))
        assert engine.handle(Pause(0.0)) == [] and not engine.run.moving


# ---- switching strategies ----------------------------------------------------------------
def _starts_after_barrier_violations(result, since: float) -> int:
    """Moves started after `since` that began before an earlier-step move had completed."""
    table = result.engine.table
    moves = [(m, a) for r in range(table.num_agents)
             for m, a in zip(result.trace.moves[r], table.actions_of(r))]
    last_end_before = {}
    for m, a in moves:
        last_end_before[a.step] = max(last_end_before.get(a.step, 0.0), m.end)
    ends = np.maximum.accumulate([last_end_before.get(t, 0.0) for t in range(table.makespan + 1)])
    return sum(1 for m, a in moves if m.start >= since and a.step > 0 and m.start < ends[a.step - 1] - 1e-9)


def test_the_step_strategy_starts_no_step_before_the_previous_one_is_complete(sample):
    result = simulate(sample, "step", MODERATE, seed=1)
    assert _starts_after_barrier_violations(result, 0.0) == 0
    adg = simulate(sample, "adg", MODERATE, seed=1)
    assert _starts_after_barrier_violations(adg, 0.0) > 0  # the check can tell them apart


def test_switching_from_adg_to_step_mid_run_restores_the_barrier_and_keeps_progress(sample):
    switch = 20.0
    result = simulate(sample, "adg", MODERATE, seed=2, controls=[SwitchStrategy(make_strategy("step"), switch)])
    assert result.engine.strategy.name == "step"
    assert result.finished and not result.collisions and result.trace.final_cells() == sample.goals
    assert _starts_after_barrier_violations(result, switch) == 0
    assert _starts_after_barrier_violations(result, 0.0) > 0  # ADG ran ahead before the switch
    assert sum(len(m) for m in result.trace.moves) == result.engine.table.num_actions


def test_switching_from_step_to_adg_speeds_the_rest_of_the_run_up(sample):
    step = simulate(sample, "step", MODERATE, seed=4)
    mixed = simulate(sample, "step", MODERATE, seed=4,
                     controls=[SwitchStrategy(make_strategy("adg", lookahead=2), 30.0)])
    assert mixed.finished and not mixed.collisions
    assert mixed.metrics.makespan < step.metrics.makespan


@st.composite
def control_schedules(draw):
    events = []
    out = set()
    for _ in range(draw(st.integers(1, 8))):
        time = draw(st.floats(0.0, 120.0))
        kind = draw(st.sampled_from(["switch", "pause", "resume", "round", "disable", "fail", "enable"]))
        robot = draw(st.integers(0, 99))
        if kind == "switch":
            name = draw(st.sampled_from(["adg", "step"]))
            settings_ = {"lookahead": draw(st.integers(1, 3))} if name == "adg" else {}
            events.append(SwitchStrategy(make_strategy(name, **settings_), time))
        elif kind in ("disable", "fail"):
            out.add(robot)
            events.append((Disabled if kind == "disable" else RobotFailed)(robot, time))
        elif kind == "enable":
            events.append(Enabled(robot, time))
        else:
            events.append({"pause": Pause, "resume": Resume, "round": StepRound}[kind](time))
    events.extend(Enabled(r, 1000.0) for r in sorted(out))
    events.append(Resume(1000.0))
    return events


@settings(max_examples=30)
@given(controls=control_schedules(), seed=st.integers(0, 2**32 - 1), start=st.sampled_from(["adg", "step"]))
def test_any_mix_of_switches_pauses_and_out_robots_is_safe_and_completes(sample, controls, seed, start):
    result = simulate(sample, start, MODERATE, seed=seed, controls=controls)
    assert result.collisions == []
    assert result.finished and result.trace.final_cells() == sample.goals
    for r, moves in enumerate(result.trace.moves):  # each action once, in order, none lost
        assert [(m.src, m.dst) for m in moves] == [(a.src, a.dst) for a in result.engine.table.actions_of(r)]


# ---- refused events ----------------------------------------------------------------------
def test_events_that_contradict_the_progress_are_refused_and_change_nothing():
    engine = Engine(EXAMPLE, "adg")
    engine.handle(Resume(0.0))
    before = (list(engine.run.completed), list(engine.run.dispatched), bytes(engine.run.done))
    with pytest.raises(EventError, match="agent 1 reports completing action 0, but .* it was sent 0"):
        engine.handle(ActionCompleted(1, 0, 1.0))
    with pytest.raises(EventError, match="agent 0 reports completing action 1, but its next action to complete is 0"):
        engine.handle(ActionCompleted(0, 1, 1.0))
    with pytest.raises(EventError, match="no agent 7 in this plan of 2 agents"):
        engine.handle(ActionStarted(7, 0, 1.0))
    with pytest.raises(EventError, match="not an engine event"):
        engine.handle("go")
    other = Engine(EXAMPLE, "step")
    with pytest.raises(EventError, match="needs a new strategy"):
        engine.handle(SwitchStrategy(other.strategy, 1.0))
    assert (list(engine.run.completed), list(engine.run.dispatched), bytes(engine.run.done)) == before
    assert engine.handle(ActionCompleted(0, 0, 1.0))  # still accepts the right one


def test_strategy_names_and_settings_are_checked_with_the_valid_ones_listed():
    with pytest.raises(UnknownStrategyError, match="unknown strategy 'fast'; available strategies are: .*adg"):
        make_strategy("fast")
    with pytest.raises(UnknownStrategyError, match="strategy 'step' has no setting 'lookahead'; its settings are: none"):
        make_strategy("step", lookahead=2)
    with pytest.raises(UnknownStrategyError, match="lookahead must be a whole number >= 1"):
        make_strategy("adg", lookahead=0)
    assert make_strategy("adg", lookahead=2).describe() == "adg (lookahead 2)"
    with pytest.raises(UnknownStrategyError, match=r"settings \(lookahead\) go with a strategy name"):
        Engine(EXAMPLE, make_strategy("adg"), lookahead=2)


# ---- metrics -----------------------------------------------------------------------------
def test_waits_are_charged_to_the_robot_that_held_them_up():
    plan = Plan.from_paths([[(0, 0), (1, 0)], [(5, 5), (5, 6), (5, 7)]])  # unrelated robots
    durations = np.array([3.0, 1.0, 1.0])  # robot 0's only move is slow
    step = simulate(plan, "step", durations=durations)
    assert step.metrics.makespan == 4.0 and step.metrics.soc == 3.0 + 4.0
    robot1 = step.metrics.agents[1]
    assert (robot1.waits, robot1.wait_time, robot1.blocked_by) == (1, 2.0, {0: 2.0})
    adg = simulate(plan, "adg", durations=durations)
    assert adg.metrics.makespan == 3.0 and adg.metrics.total_waits == 0


def test_a_follower_waits_for_its_leader_and_the_metrics_say_so():
    result = simulate(EXAMPLE, "adg", durations=np.array([1.0, 1.0, 2.0, 1.0, 1.0]))
    m = result.metrics
    assert m.makespan == 6.0 and m.soc == 4.0 + 6.0 and m.reached == [0, 1]
    assert (m.agents[1].waits, m.agents[1].wait_time, m.agents[1].blocked_by) == (1, 4.0, {0: 4.0})
    assert m.blocking_pairs() == [(4.0, 1, 0)]


# ---- adding a strategy: one class, one registration --------------------------------------
def test_a_new_strategy_is_one_class_and_one_registration(shared_data):
    class OneAtATime(Strategy):
        name = "one-at-a-time"

        def holds(self, a: int) -> bool:
            run = self.run
            return any(run.dispatched[r] > run.completed[r] for r in range(run.num_agents))

        def on_completed(self, a: int):
            return range(self.run.num_agents)

    register(OneAtATime)
    try:
        plan = read_solution(shared_data / "solutions" / "ecbs_random-32-32-20_30agents_1.txt",
                             map_dirs=default_map_dirs()).plan
        result = simulate(plan, "one-at-a-time", MODERATE, seed=0)
        assert result.finished and not result.collisions
        spans = sorted((m.start, m.end) for moves in result.trace.moves for m in moves)
        assert all(b[0] >= a[1] for a, b in zip(spans, spans[1:]))  # never two moving at once
    finally:
        STRATEGIES.pop("one-at-a-time", None)
