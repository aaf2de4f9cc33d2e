"""Re-ordering (`reorder`): a ready robot passes late ones, never too close, never into a deadlock.

Every run is judged from what really happened: the robots' executed paths in
continuous time (`approach.judge`: no pair closer than the safe distance,
diameter + margin, or for robots as large as a cell, the cell rule) and
whether every robot taking part reached its goal (a cycle of waits would
leave robots short of it). Over random maps, plans, robot sizes, delays that
make robots stand still before moves (so that moves are taken back), report
latencies, re-ordering settings and operator actions (faults, disables,
switches between every strategy mid-run), every run is safe and finishes.
Two deliberately wrong re-orderings are caught by the same checks: passing a
robot already on its way into the cell (too close), and passing without
looking at the graph (deadlocks).
"""
from __future__ import annotations

from typing import List, Optional

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from fleet_common.delays import DelayModel, EventDelays, MoveFates, simulator_fates
from fleet_common.execution import (
    Engine, ReorderStrategy, Resume, SwitchStrategy, Tick, make_strategy,
)
from fleet_common.execution.motion import Feedback
from fleet_common.execution.run import RunState
from fleet_common.execution.simulate import simulate
from fleet_common.formats import default_map_dirs, read_solution
from fleet_common.plan import Plan
from fleet_common.robot_size import TURTLEBOT2, cell_sized
from random_runs import PLAN_SEEDS, STRATEGY_NAMES, fates_for, operator_actions, random_plan, sizes



@st.composite
def standing_delays(draw) -> DelayModel:
    """Delays with robots standing still before moves (LoRR-style events), besides slow moves."""
    low = draw(st.floats(0.5, 1.0))
    events = EventDelays("bernoulli", draw(st.floats(0.05, 0.5)), 1, draw(st.integers(1, 6)))
    return DelayModel(factor=(low, draw(st.floats(low, 2.0))), stall_p=draw(st.sampled_from([0.0, 0.1])),
                      stall_moves=draw(st.floats(0.0, 3.0)), events=events)


def run_one(plan_seed: int, size, model: DelayModel, seed: int, start: str, latency: float, operated: bool,
            strategy_class: type = ReorderStrategy):
    plan = random_plan(plan_seed)
    rng = np.random.default_rng(seed)
    fates = fates_for(plan, model, seed, 0.0)
    if start == "reorder":
        strategy = strategy_class(gap=int(rng.integers(1, 3)), reach=int(rng.integers(1, 7)))
    else:  # another strategy first, re-ordering from a moment in the run on
        strategy = make_strategy(start)
    controls = operator_actions(plan, rng, plan.makespan) if operated else []
    if start != "reorder":
        controls = sorted(controls + [SwitchStrategy(strategy_class(), float(rng.uniform(0, plan.makespan)))],
                          key=lambda c: c.time)
    return plan, simulate(plan, strategy, size=size, fates=fates, controls=controls,
                          feedback=Feedback(0.05, latency))


def assert_safe_and_complete(plan: Plan, result, size) -> None:
    assert result.safety.violations == (), result.safety.violations[:2]
    assert result.collisions == []
    assert result.finished and not result.engine.stuck, result.unfinished()
    assert result.trace.final_cells() == plan.goals
    if result.closest is not None and not size.cell_sized:
        assert result.closest.distance >= size.safe_cells - 1e-9


@settings(max_examples=500, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(plan_seed=st.sampled_from(PLAN_SEEDS), real=st.booleans(), size=sizes(), model=standing_delays(),
       seed=st.integers(0, 2 ** 32 - 1), start=st.sampled_from(STRATEGY_NAMES), latency=st.floats(0.0, 0.5),
       operated=st.booleans())
def test_reordering_is_safe_and_every_robot_arrives(plan_seed, real, size, model, seed, start, latency,
                                                    operated):
    size = size if real else cell_sized()
    for first in (start, "reorder"):  # 2 runs an example: 1,000 in all
        plan, result = run_one(plan_seed, size, model, seed, first, latency, operated)
        assert_safe_and_complete(plan, result, size)


class PassesRobotsOnTheirWay(ReorderStrategy):
    """Wrong on purpose: a robot that was sent its move into the cell counts as not set off."""

    def _passable(self, run: RunState, q: int, ep: int) -> Optional[bool]:
        p = run.agent[ep + 1]
        if ep < run.first[p]:
            return None
        lo = run.dep[ep]
        if not (lo < 0 or run.agent[lo] == q or run.released(lo)):
            return None
        return False if ep - run.first[p] >= run.started[p] else None  # not begun: "passable"

    def _late(self, run: RunState, p: int, k: int, standing: bool) -> bool:
        return True


class PassesBlindly(ReorderStrategy):
    """Wrong on purpose: passes without looking for cycles, and into the robot's goal."""

    def overtake(self, eq: int) -> bool:
        run = self._attached()
        lp = run.dep[eq]
        ep = lp - 1
        p = run.agent[lp]
        if ep < run.first[p] or ep - run.first[p] < run.sent[p]:
            return False
        lo = run.dep[ep]
        if not (lo < 0 or run.released(lo)) or eq + 1 >= run.first[run.agent[eq] + 1]:
            return False
        self._swap(run, eq, ep)
        return True


@pytest.mark.parametrize("wrong, caught_by", [(PassesRobotsOnTheirWay, "distance"), (PassesBlindly, "deadlock")])
def test_wrong_reorderings_are_caught(wrong, caught_by):
    """The negative controls: the same runs and checks, with a re-ordering that breaks one rule."""
    model = DelayModel(factor=(0.8, 1.5), events=EventDelays("bernoulli", 0.3, 1, 5))
    caught = runs = 0
    for plan_seed in PLAN_SEEDS:
        for seed in range(3):
            size = TURTLEBOT2 if caught_by == "distance" else cell_sized()
            plan, result = run_one(plan_seed, size, model, seed, "reorder", 0.025, False, wrong)
            runs += 1
            if caught_by == "distance":
                caught += bool(result.safety.violations or result.collisions)
            else:
                caught += bool(result.unfinished())
    assert caught >= runs // 4, (caught, runs)
    # the right strategy, on the same runs, is never caught
    for plan_seed in PLAN_SEEDS[:6]:
        plan, result = run_one(plan_seed, TURTLEBOT2, model, 0, "reorder", 0.025, False)
        assert_safe_and_complete(plan, result, TURTLEBOT2)


# ---- what a pass does ------------------------------------------------------------------------

# robot 0 crosses robot 1's row at (2, 1) first, in the plan; robot 1 waits for it at (1, 1)
CROSSING = Plan(np.array([
    [[2, 3], [0, 1]],
    [[2, 2], [1, 1]],
    [[2, 1], [1, 1]],
    [[2, 0], [2, 1]],
    [[2, 0], [3, 1]],
], dtype=np.int32))


def fates(plan: Plan, wait: dict) -> MoveFates:
    """Moves of one nominal move each; `wait[(robot, index)]`: moves it stands still before it."""
    table = Engine(plan).table
    n = table.num_actions
    waits = np.zeros(n)
    for (robot, index), w in wait.items():
        waits[table.first[robot] + index] = w
    return MoveFates(waits, np.ones(n), np.zeros(n), np.zeros(n), np.zeros(n), np.zeros(n))


@pytest.mark.parametrize("size", [TURTLEBOT2, cell_sized()])
def test_a_ready_robot_passes_a_late_one_and_the_late_one_goes_after_it(size):
    late = fates(CROSSING, {(0, 0): 5.0})  # robot 0 stands still 5 moves before its first move
    adg = simulate(CROSSING, "adg", size=size, fates=late)
    reorder = simulate(CROSSING, "reorder", size=size, fates=late, journal=True)
    assert [(p.agent, p.passed) for p in reorder.engine.run.passes] == [(1, 0)]
    assert reorder.metrics.agents[1].arrival == pytest.approx(3.0)  # it never waited
    assert adg.metrics.agents[1].arrival > 7.0  # it waited for robot 0 to cross first
    assert reorder.metrics.makespan < adg.metrics.makespan
    assert reorder.metrics.agents[0].arrival == pytest.approx(adg.metrics.agents[0].arrival)  # no cost to it
    passes = [fields for _, kind, fields in reorder.journal if kind == "pass"]
    assert passes == [{"robot": 1, "passed": 0, "cell": (2, 1), "taken_back": False}]
    assert_safe_and_complete(CROSSING, reorder, size)
    # robot 1's wait under the ADG was avoidable: robot 0 had not set off into (2, 1)
    m = adg.metrics.agents[1]
    assert m.avoidable_time > 4.0 and m.forced_time < m.wait_time


def test_a_robot_standing_inside_a_move_it_began_is_passed_once_a_move_overdue():
    """Robot 0 begins its first move and stands still in it for 5 moves (as a real robot does
    that accepted its drive and is held up): it counts as a move from (2, 1) once the move is
    `OVERDUE`, and robot 1 passes it there, instead of waiting all 5 moves."""
    table = Engine(CROSSING).table
    n = table.num_actions
    stall, where = np.zeros(n), np.zeros(n)
    stall[table.first[0]] = 5.0  # at the very start of the move: it has begun, it stands
    inside = MoveFates(np.zeros(n), np.ones(n), stall, where, np.zeros(n), np.zeros(n))
    reorder = simulate(CROSSING, "reorder", size=TURTLEBOT2, fates=inside)
    adg = simulate(CROSSING, "adg", size=TURTLEBOT2, fates=inside)
    assert [(p.agent, p.passed, p.taken_back) for p in reorder.engine.run.passes] == [(1, 0, False)]
    assert reorder.metrics.agents[1].arrival < adg.metrics.agents[1].arrival - 2.0
    assert_safe_and_complete(CROSSING, reorder, TURTLEBOT2)


def test_a_robot_on_time_is_not_passed():
    on_time = fates(CROSSING, {})
    result = simulate(CROSSING, "reorder", size=TURTLEBOT2, fates=on_time)
    assert result.engine.run.passes == []
    assert result.metrics.makespan == simulate(CROSSING, "adg", size=TURTLEBOT2, fates=on_time).metrics.makespan


# robot 0 moves into (2, 1) at once; robot 1 follows it there
STANDING = Plan(np.array([
    [[2, 2], [1, 1]],
    [[2, 1], [1, 1]],
    [[2, 0], [2, 1]],
    [[2, 0], [3, 1]],
], dtype=np.int32))


def test_a_robot_standing_still_with_its_move_gives_it_back_and_is_passed():
    standing = fates(STANDING, {(0, 0): 6.0})  # sent its move into (2, 1), it stands still 6 moves
    result = simulate(STANDING, "reorder", size=TURTLEBOT2, fates=standing, journal=True)
    passes = result.engine.run.passes
    assert [(p.agent, p.passed, p.taken_back) for p in passes] == [(1, 0, True)]
    assert result.metrics.agents[1].arrival == pytest.approx(3.0)  # it went after a move's wait, not 6
    assert result.metrics.agents[0].arrival == pytest.approx(8.0)  # 6 standing, 2 moves: no cost to it
    adg = simulate(STANDING, "adg", size=TURTLEBOT2, fates=standing)
    assert adg.metrics.agents[1].arrival > 7.0
    assert_safe_and_complete(STANDING, result, TURTLEBOT2)


def test_a_move_the_caller_will_not_give_back_is_not_passed():
    """Robot 0 stands still with its move into (2, 1) already handed over (the manager's driver
    sent the drive): robot 1 does not pass it, however late it is."""
    engine = Engine(STANDING, "reorder", follow=True)
    asked: List[int] = []

    def refuse(agent: int, index: int) -> bool:
        asked.append(agent)
        return False

    engine.allow_take_back(refuse)
    assert [d.agent for d in engine.handle(Resume(0.0))] == [0]  # robot 1 waits for robot 0
    assert engine.handle(Tick(3.0)) == []
    assert asked == [0] and engine.run.passes == []
    assert engine.run.dispatched[0] == 1 and engine.run.dep[engine.run.first[1]] >= 0


# robot 1's goal (2, 1) is on robot 0's way: it may not wait inside it for robot 0
GOAL = Plan(np.array([
    [[2, 3], [0, 1]],
    [[2, 2], [1, 1]],
    [[2, 1], [1, 1]],
    [[2, 0], [2, 1]],
], dtype=np.int32))


def test_a_robot_never_passes_into_its_goal():
    late = fates(GOAL, {(0, 0): 5.0})
    result = simulate(GOAL, "reorder", size=TURTLEBOT2, fates=late)
    assert result.engine.run.passes == []
    assert_safe_and_complete(GOAL, result, TURTLEBOT2)
    m = result.metrics.agents[1]
    assert m.forced_time == pytest.approx(m.wait_time)  # its goal: forced, whatever the order


def test_after_passes_the_time_step_still_finishes():
    """The step barrier counts effective steps once the order changed (`step.effective_steps`)."""
    late = fates(CROSSING, {(0, 0): 5.0})
    result = simulate(CROSSING, "reorder", size=TURTLEBOT2, fates=late,
                      controls=[SwitchStrategy(make_strategy("step"), 2.5)])
    assert result.engine.run.passes and result.engine.strategy.name == "step"
    assert_safe_and_complete(CROSSING, result, TURTLEBOT2)


@pytest.mark.parametrize("name", ["pibt_sample.txt", "ecbs_random-32-32-20_30agents_1.txt"])
def test_without_delays_reordering_changes_nothing(shared_data, name):
    plan = read_solution(shared_data / "solutions" / name, map_dirs=default_map_dirs()).plan
    adg = simulate(plan, "adg", size=TURTLEBOT2)
    reorder = simulate(plan, "reorder", size=TURTLEBOT2)
    assert reorder.engine.run.passes == []
    assert reorder.metrics.makespan == adg.metrics.makespan


def test_waits_split_and_the_lower_bound_hold_on_a_delayed_plan(shared_data):
    plan = read_solution(shared_data / "solutions" / "pibt_sample.txt", map_dirs=default_map_dirs()).plan
    model = DelayModel(events=EventDelays("bernoulli", 0.1, 1, 5))
    table = Engine(plan).table
    f = simulator_fates(model, table.agent, plan.num_agents, 4)
    for name in STRATEGY_NAMES:
        result = simulate(plan, name, size=TURTLEBOT2, fates=f)
        m = result.metrics
        assert m.total_forced_time + m.total_avoidable_time == pytest.approx(m.total_wait_time)
        assert 0 < result.lower_bound <= m.makespan + 1e-9
        if not result.engine.run.passes:  # (a robot that gave a move back is counted from its return)
            # the engine's own measure counts time held behind a leader too: never below the fates'
            assert m.lower_bound >= result.lower_bound - 1e-6
