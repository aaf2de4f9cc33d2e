"""Every built-in solver on toy maps, the lab instance and shipped mapf-IR instances.

Toy maps are drawn as in a .map file (top row first); lower-case letters are
agents' starts, the matching upper-case letters their goals.
"""
from __future__ import annotations

import random
import tracemalloc
from pathlib import Path
from typing import List, Tuple

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from fleet_common.formats.instance import read_instance
from fleet_common.grid import Coord, Grid
from fleet_common.lab import lab_instance_path, lab_map_path
from fleet_common.planning import _STEP_LIMITED as STEP_LIMITED  # stop at max_timestep, as PIBT
from fleet_common.planning import SOLVER_NAMES, InvalidProblemError, solve
from fleet_common.planning.cells import NIL
from fleet_common.planning.deadline import Deadline
from fleet_common.planning.lacam import lacam
from fleet_common.planning.pibt_step import PIBTStep
from fleet_common.planning.result import SolveResult
from fleet_common.rotations import step_cycles
from fleet_common.validate import ROTATION, validate_plan
from helpers import dense_instance

Problem = Tuple[Grid, List[Coord], List[Coord]]


def toy(*rows: str) -> Problem:
    grid = Grid.from_rows(rows)
    found = {}
    for file_y, row in enumerate(rows):
        for x, ch in enumerate(row):
            if ch.isalpha():
                found[ch] = (x, len(rows) - 1 - file_y)
    agents = sorted(ch for ch in found if ch.islower())
    return grid, [found[a] for a in agents], [found.get(a.upper(), found[a]) for a in agents]


def assert_solved(result: SolveResult, problem: Problem) -> None:
    grid, starts, goals = problem
    assert result.solved, result.summary()
    report = validate_plan(result.plan, grid, starts=starts, goals=goals)
    assert report.ok, [str(e) for e in report.errors]
    assert result.comp_time_ms >= 0.0


TOYS = {
    # a and b exchange ends of a corridor: one must duck into the pocket
    "swap-with-pocket": toy(
        "@@.@@",
        "aB.bA",
    ),
    # three agents file through a one-cell-wide corridor in the same direction
    "narrow-corridor": toy(
        "@@@@@@@@@",
        "cba...CBA",
        "@@@@@@@@@",
    ),
    # some agents are home already and must make way, then return
    "some-at-goals": toy(
        "c.@..",
        "a.db.",
        "..@.C",
    ),
    # opposite corners of a room with an obstacle, four agents crossing
    "crossing-room": toy(
        "a..d",
        ".@..",
        "..@.",
        "D..A",
    ),
}


@pytest.mark.parametrize("name", SOLVER_NAMES)
@pytest.mark.parametrize("case", sorted(TOYS))
def test_solvers_solve_the_toy_maps(name: str, case: str) -> None:
    problem = TOYS[case]
    assert_solved(solve(name, *problem, deadline=10.0, seed=1), problem)


# b's goal is in the corridor a must cross to its dead-end goal: if b parks first, a is
# walled in; b must let a pass (ducking into the pocket) before it parks
GOAL_BEHIND_A_GOAL = toy(
    "@@@.@@",
    "AB..ba",
)


@pytest.mark.parametrize("name", ["lacam", "cbs", "pp"])
def test_a_goal_behind_another_agents_goal_is_solved_in_the_feasible_order(name: str) -> None:
    result = solve(name, *GOAL_BEHIND_A_GOAL, deadline=10.0)
    assert_solved(result, GOAL_BEHIND_A_GOAL)


def test_pibt_reports_a_goal_it_cannot_reach_instead_of_a_plan() -> None:
    # PIBT is incomplete: here it cycles (b keeps returning home), so it must say so
    result = solve("pibt", *GOAL_BEHIND_A_GOAL, deadline=10.0, max_timestep=300)
    if result.solved:
        assert_solved(result, GOAL_BEHIND_A_GOAL)
    else:
        assert result.status == "timeout" and "not at their goals after max_timestep=300" in result.message


@pytest.mark.parametrize("name", SOLVER_NAMES)
def test_zero_agents_give_an_empty_plan(name: str) -> None:
    grid = Grid.from_rows(["...", "..."])
    result = solve(name, grid, [], [], deadline=1.0)
    assert result.solved
    assert result.plan.num_agents == 0 and result.plan.makespan == 0


@pytest.mark.parametrize("name", SOLVER_NAMES)
def test_agents_already_at_their_goals_do_not_move(name: str) -> None:
    grid = Grid.from_rows(["...", ".@.", "..."])
    cells = [(0, 0), (2, 1), (1, 2)]
    result = solve(name, grid, cells, cells, deadline=1.0)
    assert result.solved and result.plan.makespan == 0 and result.plan.soc == 0
    assert result.plan.config(0) == cells


@pytest.mark.parametrize("name", SOLVER_NAMES)
def test_an_impossible_swap_is_reported_not_planned(name: str) -> None:
    # two agents exchanging ends of a corridor with no room to pass
    grid, starts, goals = toy("aB..bA")[0], [(0, 0), (4, 0)], [(4, 0), (0, 0)]
    result = solve(name, grid, starts, goals, deadline=0.5, max_timestep=200) if name in STEP_LIMITED \
        else solve(name, grid, starts, goals, deadline=0.5)
    assert not result.solved and result.plan is None
    assert result.status in ("timeout", "no-solution") and result.message
    if name == "lacam":  # complete: it proves there is no plan
        assert result.status == "no-solution"


@pytest.mark.parametrize("name", ["pibt", "lacam", "pp"])
def test_a_fixed_seed_gives_the_identical_plan_and_leaves_global_randomness_alone(name: str,
                                                                                shared_data: Path) -> None:
    inst = read_instance(str(shared_data / "instances" / "random-32-32-20_70agents_1.txt"),
                         map_dirs=[shared_data / "maps"])
    random.seed(7)
    expected_draw = random.random()
    random.seed(7)
    a = solve(name, inst.grid, inst.starts, inst.goals, deadline=10.0, seed=3)
    assert random.random() == expected_draw
    b = solve(name, inst.grid, inst.starts, inst.goals, deadline=10.0, seed=3)
    assert a.solved and b.solved and a.plan == b.plan


@pytest.mark.parametrize("name", SOLVER_NAMES)
def test_solvers_plan_the_lab_demo(name: str) -> None:
    inst = read_instance(str(lab_instance_path()), map_dirs=[lab_map_path().parent])
    problem = (inst.grid, inst.starts, inst.goals)
    assert_solved(solve(name, *problem, deadline=20.0), problem)


SHIPPED = [
    ("pibt", "arena_300agents_1"), ("lacam", "arena_300agents_1"), ("pp", "arena_300agents_1"),
    ("pibt", "lak307d_300agents_well-formed_1"), ("lacam", "lak307d_300agents_well-formed_1"),
    ("pibt", "random-32-32-20_110agents_1"), ("lacam", "random-32-32-20_110agents_1"),
    ("pp", "random-32-32-20_70agents_1"), ("lacam", "random-32-32-10_50agents_1"),
    ("cbs", "makespan-soc-pareto"), ("cbs", "sample"), ("pibt", "sample"),
]


@pytest.mark.parametrize("name, instance", SHIPPED)
def test_solvers_solve_shipped_instances(name: str, instance: str, shared_data: Path) -> None:
    inst = read_instance(str(shared_data / "instances" / (instance + ".txt")),
                         map_dirs=[shared_data / "maps"])
    problem = (inst.grid, inst.starts, inst.goals)
    assert_solved(solve(name, *problem, deadline=30.0), problem)


# ---- rotations: plans for robots have none; rotations=True gives mapf-IR's semantics ----------

SQUARE = [(0, 0), (1, 0), (1, 1), (0, 1)]
TURNED = SQUARE[1:] + SQUARE[:1]  # each agent's goal is the next corner


@pytest.mark.parametrize("name", SOLVER_NAMES)
def test_a_full_square_turns_only_with_mapf_ir_semantics(name: str) -> None:
    grid = Grid.from_rows(["..", ".."])
    limits = {"max_timestep": 50} if name in STEP_LIMITED else {}
    turned = solve(name, grid, SQUARE, TURNED, deadline=2.0, rotations=True, **limits)
    assert turned.solved and validate_plan(turned.plan, grid).count(ROTATION) == 1
    # pp keeps agents not yet planned on their starts at step 1, so it turns a step later; pibt-turns'
    # agents all face +x, so the square turns once the agent facing away has turned twice
    assert turned.plan.soc == {"pp": 8, "pibt-turns": 12}.get(name, 4)
    stuck = solve(name, grid, SQUARE, TURNED, deadline=0.5, **limits)
    assert not stuck.solved and stuck.status in ("timeout", "no-solution")


@pytest.mark.parametrize("name", SOLVER_NAMES)
def test_beside_a_free_column_the_square_turns_without_a_rotation(name: str) -> None:
    grid = Grid.from_rows(["...", "..."])
    result = solve(name, grid, SQUARE, TURNED, deadline=10.0)
    assert_solved(result, (grid, SQUARE, TURNED))
    report = validate_plan(result.plan, grid, strict_rotations=True)
    assert report.ok and report.count(ROTATION) == 0 and result.plan.soc > 4


@st.composite
def crowded_problems(draw) -> Problem:
    rng = np.random.default_rng(draw(st.integers(0, 2 ** 32 - 1)))
    w, h = draw(st.integers(3, 7)), draw(st.integers(3, 7))
    grid = Grid(rng.random((h, w)) > draw(st.sampled_from([0.0, 0.1, 0.2])))
    cells = list(grid.free_cells())
    n = draw(st.integers(4, max(4, len(cells) - 1)))
    assume(len(cells) > n)
    starts = [cells[i] for i in rng.permutation(len(cells))[:n]]
    goals = [cells[i] for i in rng.permutation(len(cells))[:n]]
    return grid, starts, goals


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.filter_too_much, HealthCheck.too_slow])
@given(problem=crowded_problems(), name=st.sampled_from(["pibt", "lacam", "pp"]))
def test_plans_on_crowded_maps_have_no_rotation(problem: Problem, name: str) -> None:
    grid, starts, goals = problem
    limits = {"max_timestep": 300} if name in STEP_LIMITED else {}
    try:
        result = solve(name, grid, starts, goals, deadline=0.5, **limits)
    except InvalidProblemError:
        assume(False)
    assume(result.solved)
    report = validate_plan(result.plan, grid, starts, goals, strict_rotations=True)
    assert report.ok, [str(e) for e in report.errors[:3]]


def test_a_pibt_step_never_closes_a_rotation_where_mapf_ir_semantics_would() -> None:
    """Steps in random priority orders on crowded maps, no cells fixed: the stack rule alone keeps
    rotations out (nothing is undone), where the same steps with rotations allowed make many."""
    rng = np.random.default_rng(11)
    made = {True: 0, False: 0}
    for _ in range(30):
        w, h = int(rng.integers(3, 7)), int(rng.integers(3, 7))
        grid = Grid(rng.random((h, w)) > 0.1)
        cells = list(grid.free_cells())
        n = int(rng.integers(4, len(cells)))
        starts = [cells[i] for i in rng.permutation(len(cells))[:n]]
        goals = [cells[i] for i in rng.permutation(len(cells))[:n]]
        for rotations in (True, False):
            stepper = PIBTStep(grid, goals, rotations=rotations)
            q = stepper.to_ids(starts)
            for _ in range(20):
                nxt = [NIL] * n
                assert stepper.step(q, nxt, [int(i) for i in rng.permutation(n)], int(rng.integers(1 << 20)))
                made[rotations] += len(step_cycles(np.array([q, nxt]), min_length=3))
                q = nxt
            assert stepper.reverted == 0
    assert made[False] == 0 and made[True] > 50, made


def test_pibt_undoes_a_rotation_closed_by_cells_fixed_in_advance() -> None:
    grid = Grid.from_rows(["...", "..."])
    stepper = PIBTStep(grid, TURNED)
    q = stepper.to_ids(SQUARE)
    nxt = stepper.to_ids(TURNED)
    nxt[3] = NIL  # three agents fixed to the next corner; PIBT plans the fourth, whose goal is agent 0's cell
    assert stepper.step(q, nxt, [3, 0, 1, 2], 0)
    assert nxt == q and stepper.reverted == 1  # the whole cycle stays: no vertex conflict either
    free = PIBTStep(grid, TURNED, rotations=True)
    nxt = free.to_ids(TURNED)
    nxt[3] = NIL
    assert free.step(q, nxt, [3, 0, 1, 2], 0) and nxt == free.to_ids(TURNED) and free.reverted == 0


def _pibt_with_float_priorities(problem: Problem, seed: int, steps: int) -> List[List[int]]:
    """PIBT's configurations with mapf-IR's priorities as it states them: steps since the goal plus
    a tie fraction, as floats, ordered by a stable sort (what pibt.py did before its integer keys)."""
    from fleet_common.planning.pibt import tie_ranks

    grid, starts, goals = problem
    rng = random.Random(seed)
    stepper = PIBTStep(grid, goals)
    q = stepper.to_ids(starts)
    tie = [r / len(q) for r in tie_ranks(stepper, q, rng)]
    prio = list(tie)
    configs = [q]
    for _ in range(steps):
        if q == stepper.goals:
            break
        prio = [p + 1.0 if v != g else tv for p, v, g, tv in zip(prio, q, stepper.goals, tie)]
        moving = [i for i in range(len(q)) if q[i] != stepper.goals[i]]
        order = sorted(moving, key=prio.__getitem__, reverse=True)
        nxt = [NIL] * len(q)
        if not stepper.step(q, nxt, order, rng.randrange(1 << 20), moving):
            break
        q = nxt
        configs.append(q)
    return configs


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.filter_too_much, HealthCheck.too_slow])
@given(problem=crowded_problems(), seed=st.integers(0, 1000))
def test_pibt_orders_agents_as_the_float_priorities_of_mapf_ir_do(problem: Problem, seed: int) -> None:
    """pibt keeps priorities as integers (steps x n + tie rank) in arrays; its plans must be the
    ones the float rule gives, step for step, solved or not."""
    grid, starts, goals = problem
    try:
        result = solve("pibt", grid, starts, goals, deadline=5.0, seed=seed, max_timestep=60)
    except InvalidProblemError:
        assume(False)
    reference = _pibt_with_float_priorities(problem, seed, 60)
    free = PIBTStep(grid, goals)
    if result.plan is None:
        assert reference[-1] != free.goals  # the float rule gets stuck too
        return
    assert [free.to_ids([tuple(c) for c in row]) for row in result.plan.positions.tolist()] == reference


def test_lacam_star_keeps_each_configuration_in_a_few_bytes_per_agent() -> None:
    """LaCAM* keeps every configuration it reaches until its time limit, so their size is its memory
    (a minute on 400 agents used to take gigabytes). Packed, a configuration with its priorities,
    agent order and constraints takes about 10 bytes per agent; as tuples and float arrays, 30."""
    rng = random.Random(7)
    grid = Grid(np.ones((30, 30), dtype=bool))
    cells = list(grid.free_cells())
    starts, goals = rng.sample(cells, 300), rng.sample(cells, 300)

    def search(checks: int) -> Tuple[int, int]:
        """(configurations, peak bytes) of a search stopped at the deadline's `checks`-th check
        (one per 64 iterations: a clock that counts them, so both runs do the same first work)."""
        calls = [0]

        def clock() -> float:
            calls[0] += 1
            return float(calls[0])

        tracemalloc.start()
        try:
            result = lacam(grid, starts, goals, Deadline(checks, clock=clock), seed=0, anytime=True)
            peak = tracemalloc.get_traced_memory()[1]
        finally:
            tracemalloc.stop()
        assert result.solved
        return result.stats["explored"], peak

    # the difference of two searches leaves out what does not grow with them (distance tables)
    (few, low), (many, high) = search(20), search(80)
    assert many - few > 1000
    per_agent = (high - low) / (many - few) / len(starts)
    assert per_agent < 20, "{:.1f} bytes per agent and configuration".format(per_agent)


def test_lacam_plans_on_a_map_of_more_cells_than_16_bits_count() -> None:
    """Configurations are packed as 16-bit cell ids up to 65,535 free cells, 32-bit above."""
    grid = Grid(np.ones((300, 230), dtype=bool))  # 69,000 free cells
    starts = [(0, 0), (229, 299), (100, 250)]
    goals = [(229, 299), (0, 0), (120, 290)]
    result = solve("lacam", grid, starts, goals, deadline=60.0)
    assert result.solved, result.summary()
    assert validate_plan(result.plan, grid, starts=starts, goals=goals).ok
    assert [tuple(c) for c in result.plan.positions[-1].tolist()] == goals


def test_lacam_stops_at_the_memory_limit_as_at_its_deadline(shared_data: Path, tmp_path: Path) -> None:
    """A limit the process has already reached: the search stops at its first check (64
    iterations), long before its first plan on this instance, and says which limit stopped it."""
    from fleet_common.planning.memory_limit import MemoryLimit, rss_mb, usable_mb

    inst = read_instance(dense_instance(shared_data, tmp_path), [shared_data / "maps"])
    result = lacam(inst.grid, inst.starts, inst.goals, Deadline(60), memory_limit_mb=rss_mb() / 2)
    assert not result.solved and result.status == "timeout" and result.stats["loops"] == 64
    assert result.stats["stopped"] == "memory" and result.message.startswith("memory limit of ")
    unlimited = lacam(inst.grid, inst.starts, inst.goals, Deadline(60))
    assert unlimited.solved and "stopped" not in unlimited.stats and unlimited.stats["loops"] > 1000
    assert 0 < MemoryLimit().limit_mb < usable_mb()
    with pytest.raises(ValueError, match="positive"):
        MemoryLimit(0)
