"""Trimming a plan (`planning.trim`): fewer moves, nobody later, and still a valid plan.

Judged by the plan validator (strict rotations), by each robot's arrival and moves against the
plan given, and on the evaluation's LaCAM plan by how much it trims. The negative control lets a
trimmed robot be where another is a step before or after (only the same step kept out): the
validator catches the swaps and followings that makes, and the plan given comes back refused.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from fleet_common.plan import Plan
from fleet_common.planning import trim as trim_module
from fleet_common.planning.deadline import Deadline
from fleet_common.planning.trim import moves_of, trim_moves
from fleet_common.validate import validate_plan
from random_runs import PLAN_SEEDS, random_problem

SHARED = Path(__file__).resolve().parents[2] / "shared" / "data" / "mapf-ir"


def robot_moves(plan: Plan, r: int) -> int:
    return int(plan.move_counts()[r])


def assert_trimmed_well(given_plan: Plan, grid, result, keep=0) -> None:
    trimmed = result.plan
    assert result.refused == ""
    report = validate_plan(trimmed, grid, given_plan.starts, given_plan.goals, strict_rotations=True)
    assert report.ok, report.errors[:1]
    assert (trimmed.path_costs() <= given_plan.path_costs()).all()  # nobody arrives later
    assert trimmed.makespan <= given_plan.makespan
    for r in range(given_plan.num_agents):
        assert robot_moves(trimmed, r) <= robot_moves(given_plan, r)
        if r in result.robots:
            assert robot_moves(trimmed, r) < robot_moves(given_plan, r)
        else:
            assert trimmed.path(r) == given_plan.path(r)[:trimmed.makespan + 1]
    kept = [keep] * given_plan.num_agents if isinstance(keep, int) else keep
    for r, k in enumerate(kept):
        assert trimmed.path(r)[:k + 1] == given_plan.path(r)[:k + 1]
    assert result.moves_before == moves_of(given_plan) and result.moves_after == moves_of(trimmed)


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(plan_seed=st.sampled_from(PLAN_SEEDS), keep=st.integers(0, 6), rounds=st.integers(1, 3),
       some=st.booleans(), data=st.data())
def test_a_trimmed_plan_is_valid_nobody_arrives_later_and_nobody_makes_more_moves(plan_seed, keep, rounds, some,
                                                                                   data):
    plan, grid = random_problem(plan_seed)
    robots = None
    if some:
        robots = data.draw(st.sets(st.integers(0, plan.num_agents - 1), max_size=plan.num_agents))
    per_robot = data.draw(st.booleans())
    kept = [data.draw(st.integers(0, keep)) for _ in range(plan.num_agents)] if per_robot else keep
    result = trim_moves(plan, grid, robots, kept, rounds=rounds)
    assert_trimmed_well(plan, grid, result, kept)
    if robots is not None:
        assert set(result.robots) <= set(robots)


def test_the_solvers_plans_have_moves_to_spare_and_lose_them():
    """Over the random plans (LaCAM's and PIBT's), most have robots that wind; trimmed, the moves
    drop and every plan is still valid."""
    trimmed_plans = saved = 0
    for plan_seed in PLAN_SEEDS:
        plan, grid = random_problem(plan_seed)
        result = trim_moves(plan, grid)
        assert_trimmed_well(plan, grid, result)
        trimmed_plans += bool(result.robots)
        saved += result.moves_before - result.moves_after
    assert trimmed_plans >= len(PLAN_SEEDS) // 3 and saved > 0, (trimmed_plans, saved)


def test_lacams_plan_of_the_evaluation_loses_a_twelfth_of_its_moves():
    """random-32-32-20 with 70 agents as the evaluation plans it: 1,814 moves where 1,512 would
    take each robot straight home; trimmed, 156 fewer, robot 41 (43 moves for 19) among them."""
    from fleet_common.formats import default_map_dirs
    from fleet_common.plan_loading import load_plan

    loaded = load_plan(SHARED / "instances" / "random-32-32-20_70agents_1.txt", 70, "random70",
                       [SHARED / "maps"] + default_map_dirs(), solver="lacam", seed=0)
    result = trim_moves(loaded.plan, loaded.grid)
    assert_trimmed_well(loaded.plan, loaded.grid, result)
    assert result.moves_before == 1814 and result.moves_after == 1658
    assert 41 in result.robots and robot_moves(result.plan, 41) < 43
    assert result.describe() == "trimmed: 156 moves fewer (1,814 to 1,658), {} robots".format(len(result.robots))


def test_a_plan_with_nothing_to_spare_comes_back_as_it_was():
    plan = Plan.from_paths([[(0, 0), (1, 0), (2, 0)], [(2, 1), (1, 1), (0, 1)]])
    from fleet_common.grid import Grid

    result = trim_moves(plan, Grid(np.ones((2, 3), dtype=bool)))
    assert result.plan is plan and result.robots == () and result.describe() == \
        "trimmed: no robot has a move to spare"


def test_a_robot_that_winds_waits_instead_and_arrives_when_it_did():
    """Robot 0 goes round the block to a goal two cells away, arriving at step 6; trimmed, it
    waits and goes straight, two moves, still there by step 6."""
    from fleet_common.grid import Grid

    grid = Grid(np.ones((3, 3), dtype=bool))
    winding = [(0, 0), (0, 1), (0, 2), (1, 2), (2, 2), (2, 1), (2, 0)]
    plan = Plan.from_paths([winding, [(1, 1)]])
    result = trim_moves(plan, grid)
    assert result.robots == (0,)
    assert robot_moves(result.plan, 0) == 2 and result.plan.path_costs()[0] <= 6
    assert_trimmed_well(plan, grid, result)


def test_an_expired_deadline_trims_nobody_loses_nothing_and_says_so():
    plan, grid = random_problem(PLAN_SEEDS[0])
    assert trim_moves(plan, grid).robots  # (a plan with robots to trim)
    result = trim_moves(plan, grid, deadline=Deadline(0.0))
    assert result.plan is plan and result.robots == () and result.unreached > 0
    assert result.describe() == "trimmed: none; time was up before {} more robot{} with moves to spare".format(
        result.unreached, "" if result.unreached == 1 else "s")


def test_without_the_steps_either_side_the_validator_catches_the_plan(monkeypatch):
    """Negative control: a trimmed robot kept out only of the cells others hold at the same step may
    swap with, follow or be followed by them; the validator finds it and the plan given is kept."""
    monkeypatch.setattr(trim_module, "closed", lambda held: held)
    refused = []
    for plan_seed in PLAN_SEEDS:
        plan, grid = random_problem(plan_seed)
        result = trim_moves(plan, grid)
        if result.refused:
            assert result.plan is plan and result.robots == ()
            refused.append(result.refused)
    assert refused, "the unsafe variant made no plan the validator refuses"
    assert any(word in " ".join(refused) for word in ("swap", "follow", "rotation", "vertex", "collision"))
