"""Property tests: whatever the delays, both strategies are safe, complete and deadlock-free.

Delay realisations are drawn by hypothesis (a per-move factor range, random
stalls, one permanently slow robot, delay events before moves, a seed) and run on shipped mapf-IR plans,
pibt_sample.txt (100 robots, 218 following moves) among them. Each run is
judged from its executed trace alone (`trace.find_collisions`: vertex and
swap collisions over continuous time). A naive executor, every robot keeping
its own timeline, is judged by the same checker under the same delays and
does collide: the checker would catch an unsafe engine.
"""
from __future__ import annotations

import dataclasses
from typing import Dict, Optional

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from fleet_common.delays import DelayModel, EventDelays, parse_delay_model, simulator_durations
from fleet_common.execution.actions import ActionTable
from fleet_common.execution.simulate import SimResult, simulate
from fleet_common.execution.trace import VERTEX, Trace, find_collisions
from fleet_common.formats import default_map_dirs, read_solution
from fleet_common.plan import Plan

PLANS = ("pibt_sample.txt", "ecbs_random-32-32-20_30agents_1.txt", "cbs_makespan-soc-pareto.txt")
_cache: Dict[str, Plan] = {}


@pytest.fixture(scope="module")
def plans(shared_data) -> Dict[str, Plan]:
    if not _cache:
        for name in PLANS:
            _cache[name] = read_solution(shared_data / "solutions" / name, map_dirs=default_map_dirs()).plan
    return _cache


@st.composite
def delay_models(draw) -> DelayModel:
    low = draw(st.floats(0.3, 1.0))
    high = draw(st.floats(low, 4.0))
    stall_p = draw(st.sampled_from([0.0, 0.02, 0.1, 0.3]))
    stall_len = draw(st.floats(0.0, 8.0))
    slow = ()
    if draw(st.booleans()):
        slow = ((draw(st.integers(0, 99)), draw(st.floats(1.0, 6.0))),)  # taken modulo the robots
    events = None
    if draw(st.booleans()):
        low_events = draw(st.integers(1, 4))
        events = EventDelays(draw(st.sampled_from(["bernoulli", "poisson"])), draw(st.floats(0.0, 0.5)),
                             low_events, low_events + draw(st.integers(0, 4)),
                             draw(st.sampled_from(["uniform", "gaussian"])))
    return DelayModel(factor=(low, high), stall_p=stall_p, stall_moves=stall_len, robots=slow, events=events)


def draw_delays(model: DelayModel, plan: Plan, seed: int):
    model = dataclasses.replace(model, robots=tuple((r % plan.num_agents, f) for r, f in model.robots))
    table = ActionTable.from_plan(plan)
    return simulator_durations(model, table.agent, table.num_agents, seed)


def naive_trace(table: ActionTable, durations: np.ndarray, waits: Optional[np.ndarray] = None) -> Trace:
    """Every robot keeps its own timeline: a plan step of waiting takes 1, a move its wait and
    duration."""
    trace = Trace([table.start(r) for r in range(table.num_agents)])
    waits = np.zeros(table.num_actions) if waits is None else waits
    for r in range(table.num_agents):
        now, step = 0.0, 0
        for a in table.actions_of(r):
            now += a.step - step + float(waits[table.first[r] + a.index])
            end = now + float(durations[table.first[r] + a.index])
            trace.add(r, now, end, a.src, a.dst)
            now, step = end, a.step + 1
    return trace


def assert_safe_and_complete(result: SimResult, plan: Plan) -> None:
    assert result.collisions == [], result.collisions[:3]
    assert result.finished and not result.engine.stuck  # no deadlock
    assert result.trace.final_cells() == plan.goals  # every robot reached its goal
    table = result.engine.table
    for r in range(plan.num_agents):  # every action executed once, in order, none lost
        assert [(m.src, m.dst) for m in result.trace.moves[r]] == [(a.src, a.dst) for a in table.actions_of(r)]


@settings(max_examples=40)
@given(model=delay_models(), seed=st.integers(0, 2**32 - 1), name=st.sampled_from(PLANS),
       lookahead=st.integers(1, 3))
def test_both_strategies_are_safe_and_adg_is_never_slower(plans, model, seed, name, lookahead):
    plan = plans[name]
    waits, durations = draw_delays(model, plan, seed)
    step = simulate(plan, "step", durations=durations, waits=waits)
    adg = simulate(plan, "adg", durations=durations, waits=waits, lookahead=lookahead)
    assert_safe_and_complete(step, plan)
    assert_safe_and_complete(adg, plan)
    assert adg.metrics.makespan <= step.metrics.makespan + 1e-9
    assert adg.metrics.soc <= step.metrics.soc + 1e-6


@settings(max_examples=25)
@given(model=delay_models(), seed=st.integers(0, 2**32 - 1))
def test_a_naive_executor_collides_under_the_same_delays(plans, model, seed):
    plan = plans["pibt_sample.txt"]
    table = ActionTable.from_plan(plan)
    waits, durations = draw_delays(model, plan, seed)
    assume(np.ptp(durations + waits) >= 0.2)  # delays too even to upset anyone prove nothing
    naive = find_collisions(naive_trace(table, durations, waits))
    # robots driving into robots that stand still: a collision for robots of any size
    assert any(c.kind == VERTEX and not all(c.moving) for c in naive)
    assert simulate(plan, "adg", durations=durations, waits=waits).collisions == []


def test_without_delays_the_naive_executor_only_follows_too_closely(plans):
    # the checker counts exactly the plan's following moves, both robots moving, nothing else
    for name, following in (("pibt_sample.txt", 218), ("ecbs_random-32-32-20_30agents_1.txt", 76),
                            ("cbs_makespan-soc-pareto.txt", 0)):
        table = ActionTable.from_plan(plans[name])
        found = find_collisions(naive_trace(table, np.ones(table.num_actions)))
        assert len(found) == following and all(c.kind == VERTEX and all(c.moving) for c in found)


def test_the_same_seed_gives_the_same_run(plans):
    plan = plans["ecbs_random-32-32-20_30agents_1.txt"]
    model = parse_delay_model(["moderate"])
    one = simulate(plan, "adg", model, seed=7)
    two = simulate(plan, "adg", model, seed=7)
    other = simulate(plan, "adg", model, seed=8)
    assert one.trace.moves == two.trace.moves and one.metrics.makespan == two.metrics.makespan
    assert one.metrics.makespan != other.metrics.makespan


def test_without_delays_adg_keeps_the_plan_makespan_when_nobody_follows(plans):
    plan = plans["cbs_makespan-soc-pareto.txt"]
    result = simulate(plan, "adg", parse_delay_model(["none"]))
    assert result.metrics.makespan == plan.makespan and result.metrics.total_waits == 0
