"""pibt-turns: plans that robots turning a quarter a step follow as planned, with fewer turns.

The checker, `turn_shortfall`, replays each agent's heading: a move must go straight ahead,
and a change of direction needs a quarter turn for each step the agent stood in its cell
since its last move. Plain PIBT's plans fail it (the negative control), so it can fail.
"""
from __future__ import annotations

import math
from pathlib import Path
from typing import List, Optional, Sequence

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from fleet_common.formats.instance import read_instance
from fleet_common.grid import Grid
from fleet_common.plan import Plan
from fleet_common.planning import InvalidProblemError, solve
from fleet_common.planning.pibt_turns import moves_and_turns, quarter, quarters_between, slowest_need
from fleet_common.validate import validate_plan
from test_planning_solvers import Problem, crowded_problems
from virtual_fleet.kinematics import QUARTER_OF_A_MOVE

WAY = {(1, 0): 0, (0, 1): 1, (-1, 0): 2, (0, -1): 3}


def turn_shortfall(plan: Plan, headings: Sequence[int]) -> Optional[str]:
    """The first move a robot turning a quarter a step could not make when planned, or None."""
    pos = plan.positions
    for a in range(plan.num_agents):
        facing, stood = headings[a], 0
        for t in range(1, pos.shape[0]):
            step = (int(pos[t, a, 0] - pos[t - 1, a, 0]), int(pos[t, a, 1] - pos[t - 1, a, 1]))
            if step == (0, 0):
                stood += 1
                continue
            way = WAY[step]
            if quarters_between(facing, way) > stood:
                return "agent {} at step {}: {} quarter turns after {} steps standing".format(
                    a, t, quarters_between(facing, way), stood)
            facing, stood = way, 0
    return None


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.filter_too_much, HealthCheck.too_slow])
@given(problem=crowded_problems(), seed=st.integers(0, 1000), facing=st.lists(st.integers(0, 3), min_size=60,
                                                                              max_size=60))
def test_every_plan_is_one_robots_turning_a_quarter_a_step_follow(problem: Problem, seed: int,
                                                                   facing: List[int]) -> None:
    grid, starts, goals = problem
    headings = facing[:len(starts)] + [0] * max(0, len(starts) - len(facing))
    try:
        result = solve("pibt-turns", grid, starts, goals, deadline=5.0, seed=seed, max_timestep=400,
                       headings=[h * math.pi / 2 for h in headings])
    except InvalidProblemError:
        assume(False)
    if not result.solved:  # incomplete, as PIBT: it must say so rather than plan badly
        assert result.status in ("timeout", "no-solution") and result.message
        return
    report = validate_plan(result.plan, grid, starts=starts, goals=goals, strict_rotations=True)
    assert report.ok, [str(e) for e in report.errors]
    assert turn_shortfall(result.plan, headings) is None


def test_over_many_seeded_problems_most_are_solved_and_every_plan_passes() -> None:
    solved = caught = 0  # caught: PIBT's plans of the same problems that fail the checker
    for k in range(200):
        rng = np.random.default_rng(k)
        grid = Grid(rng.random((8, 8)) > 0.15)
        cells = list(grid.free_cells())
        n = int(rng.integers(4, 16))
        picks = rng.permutation(len(cells))
        starts, goals = [cells[i] for i in picks[:n]], [cells[i] for i in rng.permutation(len(cells))[:n]]
        headings = rng.integers(0, 4, n).tolist()
        try:
            result = solve("pibt-turns", grid, starts, goals, deadline=5.0, seed=k, max_timestep=400,
                           headings=[h * math.pi / 2 for h in headings])
        except InvalidProblemError:
            continue
        if result.solved:
            solved += 1
            assert validate_plan(result.plan, grid, starts=starts, goals=goals, strict_rotations=True).ok, k
            assert turn_shortfall(result.plan, headings) is None, k
        blind = solve("pibt", grid, starts, goals, deadline=5.0, seed=k, max_timestep=400)
        caught += blind.solved and turn_shortfall(blind.plan, headings) is not None
    assert solved >= 150 and caught >= 150


@pytest.fixture(scope="module")
def arena(shared_data: Path) -> Problem:
    inst = read_instance(str(shared_data / "instances" / "arena_300agents_1.txt"), map_dirs=[shared_data / "maps"])
    return inst.grid, inst.starts, inst.goals


def test_pibt_plans_fail_the_checker_on_the_arena(arena: Problem) -> None:
    # the negative control: PIBT plans cells only, so its robots would turn and move in one step
    plan = solve("pibt", *arena, deadline=30.0).plan
    assert turn_shortfall(plan, [0] * plan.num_agents) is not None


def test_on_the_arena_the_plan_leaves_room_for_every_turn_and_pibt_cannot(arena: Problem) -> None:
    """What a robot needs at least, its own moves and quarter turns, against the planned makespan:
    PIBT's plan asks more of some robot than any executor can give; pibt-turns' plan does not."""
    def slowest(plan: Plan) -> float:
        return slowest_need(moves_and_turns(plan), QUARTER_OF_A_MOVE) / plan.makespan

    blind, turning = (solve(name, *arena, deadline=30.0).plan for name in ("pibt", "pibt-turns"))
    assert slowest(blind) > 1.10           # the bound through the chain: out of reach
    assert slowest(turning) <= 1.0
    blind_turns = sum(q for _, q in moves_and_turns(blind))
    turning_turns = sum(q for _, q in moves_and_turns(turning))
    assert turning_turns < 0.7 * blind_turns


def test_a_robot_facing_away_turns_first_and_the_headings_are_the_robots() -> None:
    grid = Grid.from_rows(["....", "....", "....", "...."])
    for facing, steps in ((math.pi / 2, 3), (0.0, 4), (-math.pi / 2, 5), (math.pi, 4)):
        result = solve("pibt-turns", grid, [(1, 0)], [(1, 3)], deadline=2.0, headings=[facing])
        assert result.solved and result.plan.makespan == steps, facing
    assert quarter(3.1) == 2 and quarter(-1.5) == 3 and quarter(0.7) == 0
    with pytest.raises(ValueError, match="1 headings for 2 agents"):
        solve("pibt-turns", grid, [(0, 0), (3, 3)], [(3, 3), (0, 0)], deadline=2.0, headings=[0.0])
