"""The built-in solvers' plans are plans robots can run: the engine accepts them, no collision.

The solvers plan rotation-free by default, so the engine (which refuses
rotations: robots occupy both cells of a move) takes every plan they make;
simulated with delays under both strategies, the runs finish without
collision. With mapf-IR's semantics (`rotations=True`, `--allow-rotations`)
the same instances give plans with rotations, which the engine refuses: the
default is what makes the difference.
"""
from __future__ import annotations

import re
from pathlib import Path

import pytest

from fleet_common.execution import Engine, PlanError
from fleet_common.delays import parse_delay_model
from fleet_common.execution.errors import ROTATION
from fleet_common.execution.simulate import simulate
from fleet_common.formats.instance import read_instance
from fleet_common.planning import solve
from helpers import fleetctl

CASES = [("pibt", "random-32-32-20_70agents_1"), ("lacam", "random-32-32-20_110agents_1"),
         ("pp", "random-32-32-20_70agents_1"), ("lacam", "arena_300agents_1"),
         ("cbs", "makespan-soc-pareto")]
DELAYS = parse_delay_model(["random:0.8-1.5", "stall:0.05:3"])


def load(shared_data: Path, name: str):
    return read_instance(shared_data / "instances" / (name + ".txt"), [shared_data / "maps"])


@pytest.mark.parametrize("solver, instance", CASES)
def test_the_engine_runs_the_plan_without_collision(solver: str, instance: str, shared_data: Path) -> None:
    inst = load(shared_data, instance)
    result = solve(solver, inst.grid, inst.starts, inst.goals, deadline=30.0)
    assert result.solved, result.summary()
    for strategy in ("adg", "step"):
        run = simulate(result.plan, strategy, DELAYS, seed=3)
        assert run.collisions == [] and run.finished, (strategy, run.collisions[:3])
        assert not run.unfinished()


def test_with_mapf_ir_semantics_the_same_instances_give_plans_the_engine_refuses(shared_data: Path) -> None:
    inst = load(shared_data, "arena_300agents_1")
    for solver in ("pibt", "lacam", "pp"):
        plan = solve(solver, inst.grid, inst.starts, inst.goals, deadline=30.0, rotations=True).plan
        with pytest.raises(PlanError) as err:
            Engine(plan)
        assert err.value.kind == ROTATION, solver




def test_fleetctl_solve_then_simulate_runs_with_no_collision(shared_data: Path, tmp_path: Path) -> None:
    instance = shared_data / "instances" / "random-32-32-20_70agents_1.txt"
    maps = ("--map-dir", shared_data / "maps")
    solved = fleetctl("solve", instance, "-s", "pibt", "-o", "plan.txt", *maps, cwd=tmp_path)
    assert solved.returncode == 0 and "rotations" not in solved.stdout, solved.stdout + solved.stderr
    run = fleetctl("simulate", "plan.txt", "--strategy", "adg", *maps, cwd=tmp_path)
    assert run.returncode == 0, run.stdout + run.stderr
    assert "collisions: 0 (" in run.stdout and "reached goal: 70 of 70" in run.stdout
    # mapf-IR's semantics: the summary counts the rotations; simulate repairs them first, or refuses
    free = fleetctl("solve", instance, "-s", "pibt", "--allow-rotations", "-o", "free.txt", *maps, cwd=tmp_path)
    found = re.search(r", (\d+) rotations \(robots cannot execute these\) ->", free.stdout)
    assert free.returncode == 0 and found, free.stdout
    repaired = fleetctl("simulate", "free.txt", *maps, cwd=tmp_path)
    assert repaired.returncode == 0, repaired.stdout + repaired.stderr
    assert repaired.stdout.startswith("free.txt: {} rotation".format(found.group(1)))
    assert "collisions: 0 (" in repaired.stdout and "reached goal: 70 of 70" in repaired.stdout
    refused = fleetctl("simulate", "free.txt", "--no-repair", *maps, cwd=tmp_path)
    assert refused.returncode == 1 and "cannot be executed by robots: rotation at t=" in refused.stdout
