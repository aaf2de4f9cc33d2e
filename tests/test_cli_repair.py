"""Plans with rotations on the command line: `fleetctl repair`, and `simulate` and `demo` on the lab
fleet, as a student or the lab staff type them (real processes, real files)."""
from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from fleet_common.execution import STRATEGIES
from fleet_common.formats import make_solution, map_from_grid, read_solution, write_map, write_solution
from fleet_common.grid import Grid
from fleet_common.lab.fleet import lab_grid
from fleet_common.plan import Plan
from fleet_common.rotations import step_cycles
from helpers import fleetctl

SQUARE = [(2, 2), (3, 2), (3, 3), (2, 3)]  # free on the lab map and on an open one


def turning(grid: Grid, map_file: str, path: Path, steps: int = 1, orientation=None) -> Path:
    plan = Plan.from_paths([[SQUARE[(i + t) % 4] for t in range(steps + 1)] for i in range(4)])
    sol = make_solution(grid, map_file, plan, plan.starts, plan.goals, solver="hand", solved=True, comp_time=3,
                        lb_soc=4, extra=[("iter", "0,comp_time=1")])
    write_solution(sol, str(path), orientation=orientation)
    return path


@pytest.fixture
def open_plan(tmp_path: Path) -> Path:
    grid = Grid(np.ones((6, 6), dtype=bool), name="open.map")
    write_map(map_from_grid(grid), str(tmp_path / "open.map"))
    return turning(grid, "open.map", tmp_path / "plan.txt", steps=2)


@pytest.mark.parametrize("orientation", [None, "base"])
def test_repair_writes_the_same_format_with_soc_and_makespan_updated(tmp_path: Path, open_plan: Path,
                                                                       orientation) -> None:
    src = open_plan
    if orientation:
        src = turning(read_solution(str(open_plan)).grid, "open.map", tmp_path / "base.txt", 2, orientation)
    proc = fleetctl("repair", src, "-o", tmp_path / "out.txt")
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert re.fullmatch(r"{}: 2 rotations repaired: agents [0-3](, [0-3])*; soc \+\d+, makespan \+\d+ "
                        r"\(\d+ ms\) -> {}\n".format(re.escape(str(src)), re.escape(str(tmp_path / "out.txt"))),
                        proc.stdout), proc.stdout
    before, after = read_solution(str(src)), read_solution(str(tmp_path / "out.txt"))
    assert after.orientation == before.orientation and after.starts == before.starts and after.goals == before.goals
    assert after.soc == after.plan.soc and after.makespan == after.plan.makespan > before.makespan
    assert [e.key for e in after.header.entries] == [e.key for e in before.header.entries]
    assert (after.solver, after.lb_soc, after.comp_time, after.iterations) == ("hand", 4, 3, before.iterations)
    text = (tmp_path / "out.txt").read_text()
    assert ("orientation=base" in text) == bool(orientation)
    strict = fleetctl("validate", tmp_path / "out.txt", "--strict-rotations")
    assert strict.returncode == 0, strict.stdout
    assert "rotations" not in strict.stdout


def test_repair_of_a_plan_without_rotations_copies_it(tmp_path: Path, shared_data: Path) -> None:
    src = shared_data / "solutions" / "ecbs_random-32-32-20_30agents_1.txt"
    proc = fleetctl("repair", src, "-o", tmp_path / "out.txt")
    assert proc.returncode == 0 and "no rotations to repair" in proc.stdout
    assert (tmp_path / "out.txt").read_bytes() == src.read_bytes()


def test_repair_refuses_an_invalid_plan_and_a_failed_run(tmp_path: Path, shared_data: Path) -> None:
    grid = Grid(np.ones((3, 3), dtype=bool), name="g.map")
    write_map(map_from_grid(grid), str(tmp_path / "g.map"))
    plan = Plan.from_paths([[(0, 0), (1, 0)], [(2, 0), (1, 0)]])
    write_solution(make_solution(grid, "g.map", plan, plan.starts, plan.goals, "hand", True, 0), str(tmp_path / "bad.txt"))
    proc = fleetctl("repair", tmp_path / "bad.txt", "-o", tmp_path / "out.txt")
    assert proc.returncode == 1 and "error: vertex conflict at t=1" in proc.stdout
    assert "INVALID: 1 problem(s); not repaired" in proc.stdout
    failed = fleetctl("repair", shared_data / "solutions" / "cbs_arena300_1_timeout.txt", "-o", tmp_path / "o.txt")
    assert failed.returncode == 1 and "no plan: solver CBS did not solve it" in failed.stdout
    assert not (tmp_path / "out.txt").exists() and not (tmp_path / "o.txt").exists()


def test_a_300_agent_arena_plan_from_pibt_in_mapf_ir_mode_runs_under_both_strategies(
        tmp_path: Path, shared_data: Path) -> None:
    maps = ("--map-dir", shared_data / "maps")
    made = fleetctl("solve", shared_data / "instances" / "arena_300agents_1.txt", "-s", "pibt", "--allow-rotations",
                    "-o", "plan.txt", *maps, cwd=tmp_path)
    assert made.returncode == 0, made.stdout + made.stderr
    sol = read_solution(str(tmp_path / "plan.txt"), map_dirs=[shared_data / "maps"])
    rotations = step_cycles(sol.plan.positions[:, :, 1].astype(np.int64) * sol.grid.width + sol.plan.positions[:, :, 0])
    assert len(rotations) >= 5  # what the repair has to do
    for strategy in ("adg", "step"):
        run = fleetctl("simulate", "plan.txt", "--strategy", strategy, *maps, cwd=tmp_path)
        assert run.returncode == 0, run.stdout + run.stderr
        assert run.stdout.startswith("plan.txt: {} rotations repaired: agents ".format(len(rotations)))
        assert "collisions: 0 (" in run.stdout and "reached goal: 300 of 300" in run.stdout


def test_simulate_names_the_lab_robots_by_their_ids(tmp_path: Path) -> None:
    plan = turning(lab_grid(), "lab.map", tmp_path / "lab_plan.txt")
    proc = fleetctl("simulate", plan, "--per-robot", "--disable", "3@0")
    out = proc.stdout
    assert re.match(r"{}: 1 rotation repaired: robots [1-4](, [1-4])*; soc".format(re.escape(str(plan))), out), out
    assert "fleet: the lab's robots, named by their ids in the robot definitions" in out
    rows = [ln.split() for ln in out.splitlines() if re.match(r"^\s+\d+\s+\d+\s+", ln)]
    assert [r[0] for r in rows] == ["1", "2", "3", "4"]  # ids, not the 0-based agent index
    assert re.search(r"^disabled: robot 3 at t=", out, re.M)  # --disable takes the robot's id too
    assert rows[2][1] == "0"  # robot 3 (agent 2) stopped before its first move
    blocked = re.search(r"^robot 3 is out; waiting for it, directly or behind others: robots? ([0-9, ]+)$", out, re.M)
    assert blocked and set(blocked.group(1).split(", ")) <= {"1", "2", "4"}
    logged = fleetctl("simulate", plan, "--log", tmp_path / "runs")
    assert logged.returncode == 0, logged.stdout + logged.stderr
    recorded = list((tmp_path / "runs").glob("*/plan-1.txt"))  # the plan that ran: the repaired one
    assert len(recorded) == 1 and fleetctl("validate", recorded[0], "--strict-rotations").returncode == 0
    wrong = fleetctl("simulate", plan, "--disable", "0@1")
    assert wrong.returncode == 2
    assert wrong.stderr.strip() == "fleetctl simulate: --disable 0@1: the plan has robots 1, 2, 3, 4"


def test_simulate_takes_the_fleet_from_definitions(tmp_path: Path, shared_data: Path) -> None:
    (tmp_path / "fleet.txt").write_text("7 127.0.0.1 10007 u v7 red\n9 127.0.0.1 10009 u v9 blue\n")
    src = shared_data / "solutions" / "cbs_makespan-soc-pareto.txt"
    proc = fleetctl("simulate", src, "--definitions", tmp_path / "fleet.txt", "--per-robot")
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert [ln.split()[0] for ln in proc.stdout.splitlines()[-2:]] == ["7", "9"]
    (tmp_path / "one.txt").write_text("7 127.0.0.1 10007 u v7 red\n")
    small = fleetctl("simulate", src, "--definitions", tmp_path / "one.txt")
    assert small.returncode == 2 and "the plan has 2 agents but {} defines 1 robots".format(
        tmp_path / "one.txt") in small.stderr


def test_demo_runs_a_given_plan_repairing_its_rotation(tmp_path: Path) -> None:
    plan = turning(lab_grid(), "lab.map", tmp_path / "lab_plan.txt")
    proc = fleetctl("demo", "--plan", plan, "--plan-only")
    assert proc.returncode == 0, proc.stdout + proc.stderr
    # cells as the plan file writes them (mapf-IR's rows from the top: base (2, 2) is (2, 11))
    assert "robot 1 (red): node 436 (2, 11) -> node 451 (3, 11), 1 steps" in proc.stdout
    assert re.search(r"^plan: 1 rotation repaired: robots [1-4](, [1-4])*; soc \+\d+, makespan \+\d+$",
                     proc.stdout, re.M)
    # every registered strategy executes the repaired plan safely to its goals
    assert proc.stdout.count("collisions: 0, robots at goal: 4 of 4") == len(STRATEGIES)
    refused = fleetctl("demo", "--plan", plan, "--no-repair", "--plan-only")
    assert refused.returncode == 1 and "plan: cannot be executed by robots: rotation at t=0->1" in refused.stdout


def test_the_manager_loads_a_plan_with_its_rotations_repaired(tmp_path: Path) -> None:
    from fleet_common.execution import Engine, PlanError
    from fleet_common.formats import default_map_dirs
    from fleet_common.plan_loading import load_plan

    plan = turning(lab_grid(), "lab.map", tmp_path / "lab_plan.txt", steps=2)
    loaded = load_plan(plan, 4, "the fleet", default_map_dirs())
    assert re.fullmatch(r"solution by hand; 2 rotations repaired: agents [0-3](, [0-3])*; soc \+\d+, makespan \+\d+",
                        loaded.note), loaded.note
    Engine(loaded.plan)  # runs: no PlanError
    recorded = loaded.text()  # the run folder's copy: the plan the robots run, its header to match
    assert "soc={}\n".format(loaded.plan.soc) in recorded and "makespan={}\n".format(loaded.plan.makespan) in recorded
    as_is = load_plan(plan, 4, "the fleet", default_map_dirs(), repair=False)
    with pytest.raises(PlanError):
        Engine(as_is.plan)
