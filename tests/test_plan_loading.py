"""The one "load a plan to run" (fleet_common.plan_loading) that the manager, `fleetctl simulate`,
the demo and the sweeps use: what it refuses, and with which words; how it plans an instance;
the file's own coordinates in its messages."""
from __future__ import annotations

import pickle
from pathlib import Path

import numpy as np
import pytest

from fleet_common.formats import default_map_dirs, make_solution, map_from_grid, write_map, write_solution
from fleet_common.formats.instance import make_instance, write_instance
from fleet_common.formats.solution import read_solution
from fleet_common.grid import Grid
from fleet_common.lab import lab_instance_path
from fleet_common.plan import Plan
from fleet_common.plan_loading import (CBS_MAX_AGENTS, InvalidPlan, PlanLoadError, file_coordinates,
                                       from_solution, load_plan)

SQUARE = [(2, 2), (3, 2), (3, 3), (2, 3)]


@pytest.fixture
def open_map(tmp_path: Path) -> Grid:
    grid = Grid(np.ones((6, 6), dtype=bool), name="open.map")
    write_map(map_from_grid(grid), str(tmp_path / "open.map"))
    return grid


def _solution(grid: Grid, path: Path, plan: Plan, solved: bool = True, orientation=None) -> Path:
    write_solution(make_solution(grid, "open.map", plan, plan.starts, plan.goals, solver="hand", solved=solved,
                                 comp_time=1), str(path), orientation=orientation)
    return path


def test_a_plan_for_another_fleet_size_is_refused_naming_both_counts() -> None:
    with pytest.raises(PlanLoadError) as err:
        load_plan(lab_instance_path(), 4, "robots.txt", default_map_dirs())
    assert str(err.value).startswith("{} has 5 agents but robots.txt has 4 robots".format(lab_instance_path()))


def test_an_unsolved_solution_and_an_invalid_one_say_why(tmp_path: Path, open_map: Grid) -> None:
    walk = Plan.from_paths([[(0, 0), (1, 0)], [(5, 5), (4, 5)]])
    unsolved = _solution(open_map, tmp_path / "unsolved.txt", walk, solved=False)
    with pytest.raises(PlanLoadError, match=r"unsolved.txt: no plan: solver hand did not solve it \(solved=0\)"):
        load_plan(unsolved, 2, "the fleet", [])
    crash = Plan.from_paths([[(0, 0), (1, 0)], [(2, 0), (1, 0)]])
    invalid = _solution(open_map, tmp_path / "invalid.txt", crash, orientation="mapf-ir")
    with pytest.raises(InvalidPlan) as err:
        load_plan(invalid, 2, "the fleet", [])
    assert "invalid plan (1 problems), first: " in str(err.value) and err.value.report.errors
    assert "(1, 5)" in str(err.value)  # the file's own coordinates: mapf-IR rows count from the top


def test_rotations_are_repaired_for_robots_or_refused_when_strict(tmp_path: Path, open_map: Grid) -> None:
    turning = Plan.from_paths([[SQUARE[(i + t) % 4] for t in range(3)] for i in range(4)])
    path = _solution(open_map, tmp_path / "turning.txt", turning)
    loaded = load_plan(path, 4, "the fleet", [])
    assert "rotations repaired" in loaded.note and loaded.plan.makespan >= 2
    with pytest.raises(InvalidPlan, match="rotation"):  # a sweep's plans must run as they are
        from_solution(read_solution(str(path)), str(path), repair=False, strict_rotations=True)


def test_an_instance_is_planned_by_cbs_for_a_few_agents_and_by_lacam_for_many(tmp_path: Path) -> None:
    grid = Grid(np.ones((12, 12), dtype=bool), name="open.map")
    write_map(map_from_grid(grid), str(tmp_path / "open.map"))
    for agents, solver in ((3, "cbs"), (CBS_MAX_AGENTS + 1, "lacam")):
        cells = [(x, y) for y in range(12) for x in range(12)]
        path = tmp_path / "inst{}.txt".format(agents)
        write_instance(make_instance(grid, "open.map", cells[:agents], cells[-agents:]), str(path))
        loaded = load_plan(path, agents, "the fleet", [])
        assert loaded.note.startswith("planned by {} in ".format(solver)) and loaded.solver == solver
        assert "solver={}\n".format(solver) in loaded.text()  # what the run folder records
        again = pickle.loads(pickle.dumps(loaded))  # sweeps send it to worker processes
        assert np.array_equal(again.plan.positions, loaded.plan.positions)


def test_file_coordinates_follow_the_files_orientation(tmp_path: Path, open_map: Grid) -> None:
    walk = Plan.from_paths([[(0, 0), (1, 0)]])
    for orientation, shown in ((None, (1, 5)), ("base", (1, 0))):
        sol = read_solution(str(_solution(open_map, tmp_path / "p.txt", walk, orientation=orientation)))
        assert file_coordinates(sol)((1, 0)) == shown
