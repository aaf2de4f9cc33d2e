"""The validator: valid plans pass, every injected conflict is caught and named."""
from __future__ import annotations

import random
from typing import List

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from fleet_common.grid import Coord, Grid
from fleet_common.plan import Plan
from fleet_common.validate import (BLOCKED, FOLLOWING, GOAL, JUMP, MAKESPAN, OFF_MAP, SOC, START,
                                   SWAP, VERTEX, validate_plan)

OPEN = Grid(np.ones((5, 6), dtype=bool))


def kinds(report) -> List[str]:
    return [f.kind for f in report.errors]


def test_swap_is_an_error_with_agents_and_step():
    plan = Plan.from_paths([[(0, 0), (1, 0)], [(1, 0), (0, 0)]])
    report = validate_plan(plan, OPEN)
    assert kinds(report) == [SWAP]
    f = report.errors[0]
    assert f.agents == (0, 1) and f.timestep == 1
    assert "agents 0 and 1" in f.message and "t=0->1" in f.message


def test_vertex_conflict_names_all_agents_in_the_cell():
    plan = Plan.from_paths([[(0, 0), (1, 0)], [(2, 0), (1, 0)], [(1, 1), (1, 0)]])
    report = validate_plan(plan, OPEN)
    vertex = report.of_kind(VERTEX)
    assert len(vertex) == 1 and vertex[0].agents == (0, 1, 2) and vertex[0].timestep == 1
    assert "(1, 0)" in vertex[0].message


def test_following_moves_are_information_unless_strict():
    plan = Plan.from_paths([[(0, 0), (1, 0), (2, 0)], [(1, 0), (2, 0), (3, 0)]])
    relaxed = validate_plan(plan, OPEN)
    assert relaxed.ok and [f.kind for f in relaxed.infos] == [FOLLOWING, FOLLOWING]
    assert relaxed.infos[0].agents == (0, 1)
    strict = validate_plan(plan, OPEN, strict_following=True)
    assert not strict.ok and kinds(strict) == [FOLLOWING, FOLLOWING]


def test_a_rotation_cycle_is_following_not_swap():
    cycle = [(0, 0), (1, 0), (1, 1), (0, 1)]
    paths = [[cycle[i], cycle[(i + 1) % 4]] for i in range(4)]
    report = validate_plan(Plan.from_paths(paths), OPEN)
    assert report.ok and len(report.of_kind(FOLLOWING)) == 4


def test_cells_off_the_map_blocked_and_jumps():
    free = np.ones((3, 3), dtype=bool)
    free[1, 1] = False
    grid = Grid(free)
    plan = Plan.from_paths([[(0, 0), (0, 1), (1, 1), (3, 1)]])
    report = validate_plan(plan, grid)
    assert kinds(report) == [OFF_MAP, BLOCKED, JUMP]
    assert report.errors[0].timestep == 3 and "outside the 3x3 map" in report.errors[0].message
    assert report.errors[1].cell == (1, 1) and report.errors[1].timestep == 2


def test_header_claims_are_checked():
    plan = Plan.from_paths([[(0, 0), (1, 0), (2, 0)], [(4, 4)]])
    report = validate_plan(plan, OPEN, starts=[(0, 0), (4, 3)], goals=[(2, 0), (4, 4)], soc=3, makespan=3)
    assert sorted(kinds(report)) == sorted([START, MAKESPAN, SOC])
    assert "soc=3" in report.of_kind(SOC)[0].message and "is 2" in report.of_kind(SOC)[0].message
    report = validate_plan(plan, OPEN, goals=[(2, 1), (4, 4)])
    assert kinds(report) == [GOAL] and report.errors[0].agents == (0,)


def test_messages_can_speak_in_the_files_own_coordinates():
    grid = Grid(np.ones((4, 6), dtype=bool))
    plan = Plan.from_paths([[(0, 0), (1, 0)], [(1, 0), (0, 0)]])
    report = validate_plan(plan, grid, show=grid.flip_y)
    assert "(0, 3) and (1, 3)" in report.errors[0].message
    assert report.errors[0].cell == (1, 0)  # the finding itself stays in the base frame


def test_findings_per_kind_are_capped():
    n = 30
    plan = Plan(np.zeros((2, n, 2), dtype=np.int32))
    report = validate_plan(plan, OPEN, max_findings_per_kind=1)
    assert len(report.of_kind(VERTEX)) == 2  # one listed, one "more not listed"
    assert "more findings" in report.of_kind(VERTEX)[1].message


def test_zero_agents_and_single_step_plans_are_valid():
    assert validate_plan(Plan.from_paths([]), OPEN).ok
    assert validate_plan(Plan.from_paths([[(2, 2)]]), OPEN).ok


# ---- property tests -------------------------------------------------------------------------

@st.composite
def valid_plans(draw):
    """Random walks on a random grid that avoid vertex and swap conflicts by construction."""
    w, h = draw(st.integers(2, 7)), draw(st.integers(2, 7))
    rnd = random.Random(draw(st.integers(0, 2 ** 32 - 1)))
    free = np.array([[rnd.random() > 0.2 for _ in range(w)] for _ in range(h)], dtype=bool)
    grid = Grid(free)
    cells = list(grid.free_cells())
    n = draw(st.integers(0, min(6, len(cells))))
    current: List[Coord] = rnd.sample(cells, n)
    configs = [list(current)]
    for _ in range(draw(st.integers(0, 12))):
        nxt: List[Coord] = []
        for i, c in enumerate(current):
            options = grid.neighbors(c) + [c]
            rnd.shuffle(options)
            for o in options:
                taken = o in nxt or any(o == current[j] for j in range(i + 1, n))  # vertex
                swap = any(nxt[j] == c and current[j] == o for j in range(len(nxt)))
                if not taken and not swap:
                    nxt.append(o)
                    break
            else:
                nxt.append(c)
        if len(set(nxt)) < len(nxt):
            break  # a stayer was displaced: stop here, the prefix is valid
        configs.append(nxt)
        current = nxt
    plan = Plan(np.array(configs, dtype=np.int32).reshape(len(configs), n, 2))
    return grid, plan


@settings(max_examples=150, deadline=None)
@given(valid_plans())
def test_valid_plans_pass(case):
    grid, plan = case
    report = validate_plan(plan, grid, starts=plan.starts, goals=plan.goals, soc=plan.soc,
                           makespan=plan.makespan)
    assert report.ok, [str(f) for f in report.errors]


@settings(max_examples=150, deadline=None)
@given(valid_plans(), st.data())
def test_injected_vertex_conflicts_are_caught(case, data):
    grid, plan = case
    if plan.num_agents < 2:
        return
    t = data.draw(st.integers(0, plan.makespan))
    i, j = data.draw(st.lists(st.integers(0, plan.num_agents - 1), min_size=2, max_size=2, unique=True))
    pos = plan.positions.copy()
    pos[t, j] = pos[t, i]
    report = validate_plan(Plan(pos), grid)
    hits = [f for f in report.of_kind(VERTEX) if f.timestep == t and {i, j} <= set(f.agents)]
    assert hits, [str(f) for f in report.findings]


@settings(max_examples=150, deadline=None)
@given(valid_plans(), st.data())
def test_injected_swaps_are_caught(case, data):
    grid, _ = case
    cells = list(grid.free_cells())
    pairs = [(a, b) for a in cells for b in grid.neighbors(a)]
    if not pairs:
        return
    a, b = data.draw(st.sampled_from(pairs))
    others = [c for c in cells if c not in (a, b)]
    extra = data.draw(st.lists(st.sampled_from(others), unique=True, max_size=3)) if others else []
    paths = [[a, b], [b, a]] + [[c, c] for c in extra]
    order = data.draw(st.permutations(range(len(paths))))
    plan = Plan.from_paths([paths[k] for k in order])
    report = validate_plan(plan, grid)
    swaps = report.of_kind(SWAP)
    assert len(swaps) == 1 and set(swaps[0].agents) == {order.index(0), order.index(1)}
    assert swaps[0].timestep == 1 and not report.of_kind(VERTEX)


@settings(max_examples=100, deadline=None)
@given(valid_plans(), st.data())
def test_injected_teleports_are_caught(case, data):
    grid, plan = case
    if plan.num_agents < 1 or plan.makespan < 1:
        return
    i = data.draw(st.integers(0, plan.num_agents - 1))
    t = data.draw(st.integers(1, plan.makespan))
    pos = plan.positions.copy()
    pos[t, i] = pos[t - 1, i] + np.array([2, 0])
    report = validate_plan(Plan(pos), grid)
    assert any(f.kind == JUMP and f.agents == (i,) and f.timestep == t for f in report.errors)


@pytest.mark.parametrize("agents,steps", [(200, 50)])
def test_large_random_plan_findings_match_a_naive_checker(agents, steps):
    """Cross-check the vectorised checks against a plain pairwise loop."""
    rng = np.random.default_rng(7)
    grid = Grid(np.ones((12, 12), dtype=bool))
    pos = np.empty((steps + 1, agents, 2), dtype=np.int32)
    pos[0] = rng.integers(0, 12, size=(agents, 2))
    moves = np.array([[0, 0], [1, 0], [-1, 0], [0, 1], [0, -1]])
    for t in range(steps):
        pos[t + 1] = np.clip(pos[t] + moves[rng.integers(0, 5, size=agents)], 0, 11)
    report = validate_plan(Plan(pos), grid, max_findings_per_kind=10 ** 9)
    vertex, swaps = set(), set()
    for t in range(steps + 1):
        seen = {}
        for i in range(agents):
            seen.setdefault(tuple(pos[t, i]), []).append(i)
        vertex |= {(t, tuple(v)) for v in seen.values() if len(v) > 1}
    for t in range(steps):
        at = {}
        for i in range(agents):
            at.setdefault(tuple(pos[t, i]), []).append(i)
        for i in range(agents):
            a, b = tuple(pos[t, i]), tuple(pos[t + 1, i])
            if a == b:
                continue
            for j in at.get(b, []):
                if j != i and tuple(pos[t + 1, j]) == a:
                    swaps.add((t + 1, min(i, j), max(i, j)))
    assert {(f.timestep, f.agents) for f in report.of_kind(VERTEX)} == vertex
    assert {(f.timestep,) + f.agents for f in report.of_kind(SWAP)} == swaps
