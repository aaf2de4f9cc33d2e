"""A look for a reroute that takes time, as a live manager's worker thread does (`Rerouter.lag`).

Between the look's cut and its hand-over the robots go on. Two things keep
the look's plan good: new moves are frozen meanwhile (`Freeze`, at most
`FREEZE` plan steps), and a robot that only begins or completes the moves it
had been sent at the cut has not moved away from it (`cut.moved_on`): the
plan starts it with those very moves. Runs are judged as
test_execution_reroute.py judges them (true centres in metres, the executed
trace, every robot home, every hand-over accepted). The controls take each
part away in turn: without either, hand-overs are refused; accepting a
robot sent a move since the cut puts the engine's plan and the robot's place
apart, which the simulator's trace refuses.
"""
from __future__ import annotations

import dataclasses
import itertools

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from fleet_common.delays import DelayModel, EventDelays
from fleet_common.execution import cut as cut_module
from fleet_common.execution import engine as engine_module
from fleet_common.execution.motion import Feedback
from fleet_common.execution.reroute import FREEZE, RerouteRule, Rerouter
from fleet_common.execution.simulate import simulate
from fleet_common.robot_size import TURTLEBOT2, RobotSize, cell_sized
from fleet_common.validate import validate_plan
from random_runs import PLAN_SEEDS, operator_actions, operator_case, random_problem, sizes
from test_execution_reroute import assert_safe_and_complete

#: The controls' runs: 4 maps x 6 delay seeds, p = 0.2, robots of the lab's size, a look 0.3 steps long.
CONTROL_RUNS = list(itertools.product(PLAN_SEEDS[:4], range(6)))


def run(plan_seed: int, seed: int, size: RobotSize, p: float, scope: str, lag: float):
    plan, grid = random_problem(plan_seed)
    model = DelayModel(events=EventDelays("bernoulli", p, 1, 5))
    rerouter = Rerouter(grid, RerouteRule(scope=scope), timed=False, lag=lag)
    return plan, grid, simulate(plan, "adg", model, seed=seed, size=size, reroute=rerouter, grid=grid)


@settings(max_examples=80, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(plan_seed=st.sampled_from(PLAN_SEEDS), seed=st.integers(0, 1000), size=st.one_of(st.just(cell_sized()), sizes()),
       p=st.floats(0.05, 0.4), scope=st.sampled_from(["held", "all"]), lag=st.floats(0.05, FREEZE))
def test_a_look_that_takes_time_is_handed_over_safely_and_every_robot_arrives(plan_seed, seed, size, p, scope, lag):
    plan, grid, result = run(plan_seed, seed, size, p, scope, lag)
    assert_safe_and_complete(plan, grid, size, result)  # every hand-over accepted among them
    assert result.metrics.total_held_time == 0.0  # no operator: the looks' waits are avoidable
    for _, reroute in result.reroutes:
        assert validate_plan(reroute.plan, grid, strict_rotations=True).ok


def test_a_look_that_takes_time_beside_the_operators_hand_stays_safe_and_every_robot_arrives():
    """Looks that take time while the operator acts: faults and disables (cleared again) and
    switches between every strategy, some of them during a look; a robot that goes out or comes
    back during a look drops its plan (nothing changes). Every run safe, every robot home."""
    rerouted = 0
    for plan_seed in PLAN_SEEDS[:12]:
        for seed in range(3):
            plan, grid, rng, size, model = operator_case(plan_seed, seed, 2611)
            rerouter = Rerouter(grid, RerouteRule(scope=("held", "all")[(plan_seed + seed) % 2]), timed=False,
                                lag=float(rng.uniform(0.05, FREEZE + 0.5)))
            start = ("adg", "reorder", "step")[(plan_seed + seed) % 3]
            result = simulate(plan, start, model, seed=seed, size=size, reroute=rerouter, grid=grid,
                              controls=operator_actions(plan, rng, plan.makespan),
                              feedback=Feedback(0.05, float(rng.uniform(0.0, 0.3))))
            assert_safe_and_complete(plan, grid, size, dataclasses.replace(result, refused=0))
            rerouted += bool(result.reroutes)
    assert rerouted >= 6


@pytest.mark.parametrize("scope", ["held", "all"])
def test_a_look_longer_than_the_freeze_lets_moves_go_on_and_the_run_stays_safe(scope):
    """Past FREEZE steps the run does not wait for the look: robots are sent moves again, its
    plan is mostly refused (nothing changes) and the run goes on with its own."""
    refused = 0
    for plan_seed, seed in CONTROL_RUNS[:12]:
        plan, grid, result = run(plan_seed, seed, TURTLEBOT2, 0.2, scope, FREEZE + 0.3)
        refused += result.refused
        assert_safe_and_complete(plan, grid, TURTLEBOT2, dataclasses.replace(result, refused=0))
    assert refused > 0


def refusals(scope: str) -> int:
    refused = 0
    for plan_seed, seed in CONTROL_RUNS:
        plan, grid, result = run(plan_seed, seed, TURTLEBOT2, 0.2, scope, 0.3)
        refused += result.refused
    return refused


@pytest.mark.parametrize("scope", ["held", "all"])
def test_the_plan_stays_good_over_the_same_runs(scope):
    """The controls' runs themselves: with both parts, not one hand-over is refused."""
    assert refusals(scope) == 0


@pytest.mark.parametrize("scope", ["held", "all"])
def test_control_a_robot_completing_its_move_sent_counted_as_moved_drops_plans(scope, monkeypatch):
    monkeypatch.setattr(cut_module, "moved_on", lambda cut, r, done, sent, began: (done, sent, began) != (
        cut.completed[r], cut.committed[r], cut.started[r]))
    assert refusals(scope) > 0


@pytest.mark.parametrize("scope", ["held", "all"])
def test_control_without_the_freeze_robots_are_sent_moves_and_plans_are_dropped(scope, monkeypatch):
    monkeypatch.setattr(engine_module.Engine, "_freeze", lambda self, e: ((), None))
    assert refusals(scope) > 0


def test_control_taking_a_plan_a_robot_was_sent_a_move_away_from_is_caught(monkeypatch):
    """The wrong tolerance: any progress since the cut counts as the plan's. Without the freeze
    robots are sent their old plan's moves during the look, and the new plan has them elsewhere:
    the hand-over's fit check refuses such a plan (the moves sent are not the plan's); with only
    the order checked, as before 2026-11-27, the simulator's trace refuses a move from a cell the
    robot is not in."""
    monkeypatch.setattr(cut_module, "moved_on", lambda cut, r, done, sent, began: done < cut.completed[r])
    monkeypatch.setattr(engine_module.Engine, "_freeze", lambda self, e: ((), None))
    refused = sum(run(plan_seed, seed, TURTLEBOT2, 0.2, "all", 0.3)[2].refused for plan_seed, seed in CONTROL_RUNS)
    assert refused > 0
    monkeypatch.setattr(engine_module.Engine, "_moved_otherwise", lambda self, progress, old: None)
    caught = 0
    for plan_seed, seed in CONTROL_RUNS:
        try:
            run(plan_seed, seed, TURTLEBOT2, 0.2, "all", 0.3)
        except ValueError as err:
            assert "cannot move" in str(err)
            caught += 1
    assert caught > 0


@pytest.mark.parametrize("scope", ["held", "all"])
def test_a_run_a_robot_out_for_good_holds_up_still_ends(scope):
    """Looks go on while a robot out for good holds others up; once nothing else is to happen the
    simulation ends (stuck), as without a lag: no look is waited for then."""
    for plan_seed in PLAN_SEEDS[:6]:
        plan, grid = random_problem(plan_seed)
        model = DelayModel(events=EventDelays("bernoulli", 0.2, 1, 5))
        result = simulate(plan, "adg", model, seed=1, size=TURTLEBOT2, grid=grid, disable={0: 2},
                          reroute=Rerouter(grid, RerouteRule(scope=scope), timed=False, lag=FREEZE + 0.3))
        assert result.finished or 0 in result.engine.out_agents()
        assert result.safety.violations == ()
