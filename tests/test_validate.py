"""The validator: valid plans pass, every injected conflict is caught and named."""
from __future__ import annotations

import random
import subprocess
import sys
from typing import List

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings, strategies as st

from fleet_common.formats.mapfile import map_from_grid, write_map
from fleet_common.formats.solution import make_solution, write_solution
from fleet_common.grid import Coord, Grid
from fleet_common.plan import Plan
from fleet_common.planning import InvalidProblemError, solve
from fleet_common.validate import (BLOCKED, FOLLOWING, GOAL, JUMP, MAKESPAN, OFF_MAP, ROTATION, SOC,
                                   START, SWAP, VERTEX, validate_plan)
from helpers import naive_rotations

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
    assert not report.of_kind(SWAP) and len(report.of_kind(ROTATION)) == 1


SQUARE = [(2, 2), (3, 2), (3, 3), (2, 3)]


def rotating_plan(t: int = 1) -> Plan:
    """Agents 3, 1, 4, 2 sit on SQUARE's corners in that order and, from step t, each takes the next one."""
    owners = [3, 1, 4, 2]
    paths = [[(0, 0)] * (t + 2)] + [None] * 4  # type: ignore[list-item]
    for k, agent in enumerate(owners):
        paths[agent] = [SQUARE[k]] * (t + 1) + [SQUARE[(k + 1) % 4]]
    return Plan.from_paths(paths)


def test_a_rotation_is_information_naming_the_agents_in_cycle_order_and_the_step():
    report = validate_plan(rotating_plan(t=1), OPEN)
    assert report.ok and report.count(ROTATION) == 1
    f = report.of_kind(ROTATION)[0]
    # agent 1 enters the cell agent 4 leaves, 4 agent 2's, 2 agent 3's, 3 agent 1's: from the smallest
    assert f.severity == "info" and f.agents == (1, 4, 2, 3) and f.timestep == 2
    assert f.cell == SQUARE[2]
    assert f.message == ("rotation at t=1->2: agents 1, 4, 2, 3 each enter the cell the next one leaves "
                         "((3, 3), (2, 3), (2, 2), (3, 2)); legal in mapf-IR, but robots cannot execute it")


def test_a_rotation_is_an_error_when_strict_and_speaks_in_the_callers_frame():
    for strict in ({"strict_rotations": True}, {"strict_following": True}):
        report = validate_plan(rotating_plan(), OPEN, show=OPEN.flip_y, **strict)
        rotation = [f for f in report.errors if f.kind == ROTATION]
        assert not report.ok and len(rotation) == 1 and rotation[0].agents == (1, 4, 2, 3)
        assert "((3, 1), (2, 1), (2, 2), (3, 2)); robots cannot execute it" in rotation[0].message
    relaxed = validate_plan(rotating_plan(), OPEN, strict_rotations=False)
    assert relaxed.ok and relaxed.infos


def test_an_open_chain_and_a_swap_are_not_rotations():
    chain = Plan.from_paths([[(x, 0), (x + 1, 0)] for x in range(4)])  # the leader enters a free cell
    report = validate_plan(chain, OPEN, strict_rotations=True)
    assert report.ok and report.count(FOLLOWING) == 3 and report.count(ROTATION) == 0
    swap = validate_plan(Plan.from_paths([[(0, 0), (1, 0)], [(1, 0), (0, 0)]]), OPEN, strict_rotations=True)
    assert [f.kind for f in swap.errors] == [SWAP]


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


# ---- rotations: injected ones are found, a naive checker agrees ------------------------------

def ring(x0: int, y0: int, w: int, h: int) -> List[Coord]:
    """The border cells of a w x h rectangle, in order round it."""
    return ([(x0 + i, y0) for i in range(w - 1)] + [(x0 + w - 1, y0 + j) for j in range(h - 1)]
            + [(x0 + w - 1 - i, y0 + h - 1) for i in range(w - 1)] + [(x0, y0 + h - 1 - j) for j in range(h - 1)])


@settings(max_examples=150, deadline=None)
@given(st.data())
def test_injected_rotations_are_found_and_a_gap_in_the_ring_makes_none(data):
    """A full ring of agents each stepping on is one rotation; with one cell empty it is a chain."""
    gw, gh = data.draw(st.integers(2, 8)), data.draw(st.integers(2, 8))
    grid = Grid(np.ones((gh, gw), dtype=bool))
    w, h = data.draw(st.integers(2, gw)), data.draw(st.integers(2, gh))
    x0, y0 = data.draw(st.integers(0, gw - w)), data.draw(st.integers(0, gh - h))
    cells = ring(x0, y0, w, h)
    if data.draw(st.booleans()):
        cells.reverse()
    gap = data.draw(st.booleans())
    k = len(cells)
    moving = [[cells[i], cells[(i + 1) % k]] for i in range(k - 1 if gap else k)]
    outside = [c for c in grid.free_cells() if c not in cells]
    idle = data.draw(st.lists(st.sampled_from(outside), unique=True, max_size=4)) if outside else []
    paths = moving + [[c, c] for c in idle]
    order = data.draw(st.permutations(range(len(paths))))  # agent order[m] walks paths[m]
    plan = Plan.from_paths([paths[order.index(a)] for a in range(len(paths))])
    report = validate_plan(plan, grid, max_findings_per_kind=10 ** 9)
    assert report.ok
    rotations = report.of_kind(ROTATION)
    if gap:
        assert not rotations and report.count(FOLLOWING) == k - 2
        return
    assert len(rotations) == 1 and rotations[0].timestep == 1
    agents = rotations[0].agents
    expected = [order[m] for m in range(k)]  # ring order: each enters the cell the next one leaves
    start = expected.index(min(expected))
    assert list(agents) == expected[start:] + expected[:start]
    assert {(f.timestep, f.agents) for f in rotations} == naive_rotations(plan)


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.filter_too_much, HealthCheck.too_slow])
@given(st.integers(0, 2 ** 32 - 1), st.sampled_from(["pibt", "lacam"]))
def test_rotations_of_crowded_mapf_ir_plans_match_a_naive_checker(seed, solver):
    """Plans with mapf-IR's semantics on small crowded maps are full of rotations (and some have none)."""
    rng = np.random.default_rng(seed)
    w, h = int(rng.integers(3, 7)), int(rng.integers(3, 7))
    grid = Grid(rng.random((h, w)) > 0.1)
    cells = list(grid.free_cells())
    n = int(rng.integers(2, max(3, len(cells))))
    assume(len(cells) > n)
    starts = [cells[i] for i in rng.permutation(len(cells))[:n]]
    goals = [cells[i] for i in rng.permutation(len(cells))[:n]]
    limits = {"max_timestep": 300} if solver == "pibt" else {}  # where PIBT cycles, give up soon
    try:
        result = solve(solver, grid, starts, goals, deadline=0.5, seed=seed, rotations=True, **limits)
    except InvalidProblemError:
        assume(False)
    assume(result.solved)
    report = validate_plan(result.plan, grid, max_findings_per_kind=10 ** 9)
    assert report.ok
    assert {(f.timestep, f.agents) for f in report.of_kind(ROTATION)} == naive_rotations(result.plan)
    strict = validate_plan(result.plan, grid, strict_rotations=True)
    assert strict.ok == (report.count(ROTATION) == 0)


@settings(max_examples=150, deadline=None)
@given(valid_plans())
def test_random_walks_have_the_rotations_a_naive_checker_finds(case):
    grid, plan = case
    report = validate_plan(plan, grid, max_findings_per_kind=10 ** 9)
    assert {(f.timestep, f.agents) for f in report.of_kind(ROTATION)} == naive_rotations(plan)


def test_fleetctl_validate_counts_rotations_and_refuses_them_when_strict(tmp_path):
    grid = Grid(np.ones((5, 6), dtype=bool), name="open.map")
    write_map(map_from_grid(grid), tmp_path / "open.map")
    plan = rotating_plan()
    sol = make_solution(grid, "open.map", plan, plan.starts, plan.goals, solver="hand", solved=True, comp_time=0)
    path = tmp_path / "plan.txt"
    write_solution(sol, path)

    def validate(*options: str) -> subprocess.CompletedProcess:
        return subprocess.run([sys.executable, "-m", "fleetctl", "validate", str(path), *options],
                              capture_output=True, text=True, timeout=60)

    relaxed = validate()
    assert relaxed.returncode == 0, relaxed.stdout + relaxed.stderr
    summary, hint = relaxed.stdout.strip().splitlines()[-2:]
    assert summary.endswith("(4 following moves, legal in mapf-IR; 1 rotations: robots cannot execute these)")
    # and what to do about it
    assert hint == ("{0}: `fleetctl repair {0} -o OUT` makes it executable by robots (repairs the rotations; "
                    "`fleetctl simulate` does so by itself)".format(path))
    strict = validate("--strict-rotations")
    assert strict.returncode == 1
    # the file's own frame: y flipped on the 5-row map
    assert "{}: error: rotation at t=1->2: agents 1, 4, 2, 3 each enter the cell the next one leaves " \
           "((3, 1), (2, 1), (2, 2), (3, 2))".format(path) in strict.stdout
    assert "INVALID: 1 problem(s)" in strict.stdout and strict.stdout.strip().splitlines()[-1] == hint


def test_counts_include_findings_past_the_listing_cap():
    # 12 squares of 4 agents side by side, every square turning every step for 5 steps
    squares, steps = 12, 5
    paths = []
    for s in range(squares):
        corners = [(3 * s + x, y) for x, y in SQUARE]
        corners = [(x - 2, y - 2) for x, y in corners]  # SQUARE sits at (2, 2); move it to the origin
        for c in range(4):
            paths.append([corners[(c + t) % 4] for t in range(steps + 1)])
    grid = Grid(np.ones((2, 3 * squares), dtype=bool))
    report = validate_plan(Plan.from_paths(paths), grid, max_findings_per_kind=2)
    assert report.count(ROTATION) == squares * steps and report.count(FOLLOWING) == 4 * squares * steps
    listed = report.of_kind(ROTATION)
    assert len(listed) == 3 and "more findings of kind 'rotation' not listed" in listed[2].message
    assert [f.agents for f in listed[:2]] == [(0, 1, 2, 3), (4, 5, 6, 7)] and listed[0].timestep == 1
