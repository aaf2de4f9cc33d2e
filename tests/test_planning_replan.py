"""Replanning after robots drop out: out robots stay put, the others start from where they are."""
from __future__ import annotations

from pathlib import Path

import pytest

from fleet_common.formats.instance import read_instance
from fleet_common.grid import Grid
from fleet_common.planning import InvalidProblemError, solve
from fleet_common.planning.replan import replan
from fleet_common.validate import validate_plan

# base frame; row 0 of the list is the top row
HALL = Grid.from_rows([
    "......",
    "..@@..",
    "......",
])
# two rooms joined by one corridor cell, (3, 1)
ROOMS = Grid.from_rows([
    "...@...",
    ".......",
    "...@...",
])


def stays(plan, agent, cell) -> bool:
    return all(c == cell for c in plan.path(agent))


@pytest.mark.parametrize("method", ["pp", "lacam"])
def test_out_agents_stay_put_and_the_others_start_from_their_current_cells(method: str) -> None:
    current = [(0, 0), (2, 2), (5, 0), (3, 0)]
    goals = [(5, 2), (0, 2), (0, 0), (4, 1)]
    result = replan(HALL, current, goals, out={1}, method=method, deadline=5.0)
    assert result.solved and result.unreachable == set()
    plan = result.plan
    assert plan.num_agents == 4 and plan.config(0) == current
    assert stays(plan, 1, (2, 2))
    assert [plan.config(plan.makespan)[i] for i in (0, 2, 3)] == [(5, 2), (0, 0), (4, 1)]
    report = validate_plan(plan, HALL, starts=current, goals=[(5, 2), (2, 2), (0, 0), (4, 1)])
    assert report.ok, [str(e) for e in report.errors]


def test_an_out_agent_on_someones_goal_makes_that_goal_unreachable() -> None:
    current = [(0, 0), (5, 2), (3, 0)]
    goals = [(5, 2), (0, 0), (0, 2)]
    result = replan(HALL, current, goals, out={1})
    assert result.unreachable == {0}
    assert "agents 0 cannot reach" in result.message
    assert stays(result.plan, 0, (0, 0)) and stays(result.plan, 1, (5, 2))
    assert result.plan.config(result.plan.makespan)[2] == (0, 2)


def test_an_out_agent_in_the_only_corridor_strands_the_agents_behind_it() -> None:
    # agent 0 is out in the corridor; 1 and 2 want to cross, 3 stays in its room;
    # 2 is stranded in front of the corridor and then walls in nobody else
    current = [(3, 1), (0, 1), (2, 1), (1, 0)]
    goals = [(6, 1), (6, 2), (5, 0), (0, 2)]
    result = replan(ROOMS, current, goals, out={0})
    assert result.unreachable == {1, 2}
    plan = result.plan
    for agent in (0, 1, 2):
        assert stays(plan, agent, current[agent])
    assert plan.config(plan.makespan)[3] == (0, 2)
    assert validate_plan(plan, ROOMS, starts=current).ok


def test_a_stranded_agent_walls_in_others_too() -> None:
    corridor = Grid.from_rows(["......."])
    # 0 is out at x=2: 1 (x=1) cannot reach x=5 and stays; so 2 (x=0) cannot pass 1 either
    current = [(2, 0), (1, 0), (0, 0), (6, 0)]
    goals = [(2, 0), (5, 0), (4, 0), (3, 0)]
    result = replan(corridor, current, goals, out={0})
    assert result.unreachable == {1, 2}
    assert result.plan.config(result.plan.makespan) == [(2, 0), (1, 0), (0, 0), (3, 0)]


def test_no_plan_for_the_rest_is_reported() -> None:
    corridor = Grid.from_rows([".....", "@@@@."])
    # 1 and 2 must swap in a corridor whose only side cell holds out agent 0
    current = [(4, 0), (0, 1), (3, 1)]
    goals = [(4, 0), (3, 1), (0, 1)]
    result = replan(corridor, current, goals, out={0})
    assert result.plan is None and not result.solved
    assert result.status == "no-solution" and "no plan exists" in result.message


def test_an_agent_whose_goal_is_blocked_stays_put_and_the_others_are_planned() -> None:
    """The manager blocks the cell a robot standing between two cells leans into; when that is
    another robot's goal, that robot cannot reach it now: it stays where it is, reported, and
    the others are planned (before, the whole replan failed: "goal ... is on a blocked cell")."""
    walled = Grid.from_rows(["...@", "...."])  # (3, 1), agent 1's goal, blocked (the first row is the top)
    assert not walled.is_free((3, 1))
    result = replan(walled, [(0, 0), (0, 1)], [(2, 0), (3, 1)], out=set())
    assert result.solved and result.unreachable == {1} and "agents 1 cannot reach" in result.message
    assert tuple(result.plan.positions[-1, 0]) == (2, 0) and tuple(result.plan.positions[-1, 1]) == (0, 1)


def test_bad_replanning_input_names_the_agent() -> None:
    with pytest.raises(InvalidProblemError, match="agent 1: current cell \\(2, 1\\) is on a blocked cell"):
        replan(HALL, [(0, 0), (2, 1)], [(1, 1), (0, 1)], out=set())
    with pytest.raises(InvalidProblemError, match="agents 0 and 1 have the same current cell"):
        replan(HALL, [(0, 0), (0, 0)], [(1, 1), (0, 1)], out=set())
    with pytest.raises(InvalidProblemError, match="agent 5 is marked out but there are only 2 agents"):
        replan(HALL, [(0, 0), (1, 0)], [(1, 1), (0, 1)], out={5})
    with pytest.raises(InvalidProblemError, match="agents 0 and 2 have the same goal"):
        replan(HALL, [(0, 0), (1, 0), (2, 0)], [(1, 1), (1, 1), (1, 1)], out={1})
    with pytest.raises(ValueError, match="use one of: pp, lacam"):
        replan(HALL, [(0, 0)], [(1, 1)], out=set(), method="cbs")


@pytest.mark.parametrize("method", ["pp", "lacam"])
def test_replanning_300_agents_mid_plan_on_arena(method: str, shared_data: Path) -> None:
    inst = read_instance(str(shared_data / "instances" / "arena_300agents_1.txt"),
                         map_dirs=[shared_data / "maps"])
    first = solve("pibt", inst.grid, inst.starts, inst.goals, deadline=30.0)
    now = first.plan.config(first.plan.makespan // 2)
    out = {7, 150, 299}
    result = replan(inst.grid, now, inst.goals, out, deadline=30.0, method=method)
    assert result.solved, result.message
    plan = result.plan
    assert plan.config(0) == now
    ends = [now[i] if i in out | result.unreachable else inst.goals[i] for i in range(300)]
    assert validate_plan(plan, inst.grid, starts=now, goals=ends).ok
    for i in out:
        assert stays(plan, i, now[i])


@pytest.mark.parametrize("method", ["pp", "lacam"])
def test_replanned_plans_have_no_rotation_unless_asked(method: str) -> None:
    from fleet_common.validate import ROTATION

    square = [(0, 0), (1, 0), (1, 1), (0, 1)]
    turned = square[1:] + square[:1]
    full = Grid.from_rows(["..", ".."])
    stuck = replan(full, square, turned, out=set(), method=method, deadline=2.0)
    assert not stuck.solved  # the only way is a rotation, which robots cannot perform
    free = replan(full, square, turned, out=set(), method=method, deadline=2.0, rotations=True)
    assert free.solved and validate_plan(free.plan, full).count(ROTATION) == 1
    # with a robot out beside the square, the others still turn, without a rotation
    roomy = Grid.from_rows(["...", "...", "..."])
    current = square + [(2, 2)]
    result = replan(roomy, current, turned + [(0, 2)], out={4}, method=method, deadline=5.0)
    assert result.solved and result.plan.config(result.plan.makespan)[:4] == turned
    assert validate_plan(result.plan, roomy, strict_rotations=True).ok
