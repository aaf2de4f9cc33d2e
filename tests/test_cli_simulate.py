"""`fleetctl simulate` as a student meets it: real processes, shipped solutions, exit codes."""
from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from fleet_common.formats.mapfile import map_from_grid, write_map
from fleet_common.formats.solution import make_solution, write_solution
from fleet_common.grid import Grid
from fleet_common.plan import Plan

SOLVED = ["pibt_sample.txt", "ecbs_random-32-32-20_30agents_1.txt", "cbs_makespan-soc-pareto.txt",
          "ir_makespan-soc-pareto.txt"]


def simulate(*args: object) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "fleetctl", "simulate", *map(str, args)],
                          capture_output=True, text=True, timeout=120)


def figure(out: str, label: str) -> float:
    m = re.search(r"^{}: ([0-9.]+)".format(re.escape(label)), out, re.M)
    assert m, out
    return float(m.group(1))


@pytest.mark.parametrize("name", SOLVED)
def test_shipped_solutions_run_without_collision_under_every_strategy(name, shared_data):
    makespans = {}
    for strategy in ("adg", "step", "reorder"):
        proc = simulate(shared_data / "solutions" / name, "--strategy", strategy, "--seed", "5")
        assert proc.returncode == 0, proc.stdout + proc.stderr
        out = proc.stdout
        assert "collisions: 0 (" in out
        n = int(re.search(r"^robots: (\d+)", out, re.M).group(1))
        assert "reached goal: {0} of {0} enabled robots".format(n) in out
        assert re.search(r"^strategy: {}.*; delays: moves take 0.8-1.5 x nominal; stalls of 3 moves "
                         r"with p=0.02; seed 5$".format(strategy), out, re.M)
        waits = re.search(r"^waits: \d+ by \d+ robots, ([0-9.]+) in total: forced ([0-9.]+) \(.*\), "
                          r"avoidable ([0-9.]+)$", out, re.M)
        assert waits, out
        total, forced, avoidable = map(float, waits.groups())
        assert forced + avoidable == pytest.approx(total, abs=0.02)  # nobody was held by an operator
        makespans[strategy] = figure(out, "executed makespan")
        assert makespans[strategy] >= figure(out, "lower bound") > 0  # nobody beats running alone
        assert figure(out, "sum of costs") > 0
    assert makespans["adg"] <= makespans["step"]


def test_without_delays_a_plan_without_following_moves_keeps_its_makespan(shared_data):
    proc = simulate(shared_data / "solutions" / "cbs_makespan-soc-pareto.txt", "--delay-model", "none")
    assert proc.returncode == 0
    assert "robots: 2, moves: 13, plan makespan 12, plan soc 13" in proc.stdout
    assert figure(proc.stdout, "executed makespan") == 12.0 and figure(proc.stdout, "sum of costs") == 13.0
    assert "waits: 0 by 0 robots" in proc.stdout and "delays: none" in proc.stdout


def test_a_disabled_robot_blocks_others_who_are_named(shared_data):
    proc = simulate(shared_data / "solutions" / "pibt_sample.txt", "--disable", "3@10", "--per-robot")
    assert proc.returncode == 1  # not every enabled robot reached its goal
    out = proc.stdout
    assert re.search(r"^disabled: robot 3 at t=[0-9.]+$", out, re.M)
    # what the numbers are: the robots that wait for the out one (here agent indices: not the lab)
    blocked = re.search(r"^robot 3 is out; waiting for it, directly or behind others: robots ([0-9, ]+)$",
                        out, re.M).group(1)
    missing = re.search(r"^reached goal: (\d+) of 99 enabled robots; not reached: robots ([0-9, ]+)$", out, re.M)
    assert missing.group(2) == blocked and int(missing.group(1)) == 99 - len(blocked.split(", "))
    assert "collisions: 0 (" in out
    assert "(robots that reached their goals only)" in out
    assert "fleet: simulated robots, numbered by agent index from 0" in out
    rows = [ln for ln in out.splitlines() if re.match(r"^\s+\d+\s+\d+\s+", ln)]
    assert len(rows) == 100 and rows[3].split()[:3] == ["3", "10", "-"]  # 10 moves, never arrived


def test_the_seed_makes_runs_repeatable(shared_data):
    path = shared_data / "solutions" / "ecbs_random-32-32-20_30agents_1.txt"
    one, two, other = simulate(path, "--seed", "9"), simulate(path, "--seed", "9"), simulate(path, "--seed", "10")
    assert one.stdout == two.stdout and one.stdout != other.stdout
    lookahead = simulate(path, "--lookahead", "2", "--delay-model", "random:1-2", "--delay-model", "slow:4:3")
    assert "strategy: adg (lookahead 2); delays: moves take 1-2 x nominal; robot 4 3x slower" in lookahead.stdout


def test_trim_says_what_it_trimmed_and_the_run_folder_keeps_the_plan_that_ran(shared_data, tmp_path):
    """--trim: one line says what was trimmed, the run meets the same delays move by move (paired),
    and --log records the trimmed plan, the plan the robots ran."""
    path = shared_data / "solutions" / "pibt_sample.txt"
    delays = ("--delay-model", "events=bernoulli:0.1:1-5", "--seed", "3")
    plain, trimmed = simulate(path, *delays), simulate(path, *delays, "--trim", "--log", tmp_path)
    assert plain.returncode == trimmed.returncode == 0, trimmed.stdout + trimmed.stderr
    assert "trimmed: 70 moves fewer (3,297 to 3,227), 17 robots" in trimmed.stdout
    assert "trimmed" not in plain.stdout
    assert figure(trimmed.stdout, "executed makespan") <= figure(plain.stdout, "executed makespan")
    logged, = tmp_path.glob("*/plan-1.txt")
    from fleet_common.formats.solution import read_solution

    assert read_solution(str(logged), [shared_data / "maps"]).plan.move_counts().sum() == 3227


@pytest.mark.parametrize("args, message", [
    (["--delay-model", "sometimes"], "delay model 'sometimes': unknown term 'sometimes'; expected factor=LOW-HIGH, "
                                     "delay=D, slow=P:F, stall=P:S, dropout=P:S, robot=R:F, events="),
    (["--delay-model", "random:2-1"],
     "delay model 'random:2-1': factor=2-1: expected factor=LOW-HIGH with 0 < LOW <= HIGH"),
    (["--delay-model", "slow:100:2"], "delay model: robot=100:...: the plan has robots 0..99 only"),
    (["--disable", "100@5"], "fleetctl simulate: --disable 100@5: the plan has robots 0..99"),
    (["--strategy", "step", "--lookahead", "2"],
     "fleetctl simulate: strategy 'step' has no setting 'lookahead'; its settings are: none"),
])
def test_wrong_options_are_one_line_errors(args, message, shared_data):
    proc = simulate(shared_data / "solutions" / "pibt_sample.txt", *args)
    assert proc.returncode == 2 and proc.stdout == ""
    assert proc.stderr.strip() == message or (message.endswith("events=") and proc.stderr.startswith(message))


def test_a_malformed_disable_is_refused_by_the_parser(shared_data):
    proc = simulate(shared_data / "solutions" / "pibt_sample.txt", "--disable", "3-10")
    assert proc.returncode == 2 and "expected ROBOT@STEP (e.g. 3@10), got '3-10'" in proc.stderr


def test_a_failed_solver_run_has_no_plan_to_simulate(shared_data):
    proc = simulate(shared_data / "solutions" / "cbs_arena300_1_timeout.txt")
    assert proc.returncode == 1 and "no plan: solver CBS did not solve it" in proc.stdout


def _write(tmp_path: Path, paths) -> Path:
    grid = Grid(np.ones((4, 4), dtype=bool), name="open.map")
    write_map(map_from_grid(grid), tmp_path / "open.map")
    plan = Plan.from_paths(paths)
    sol = make_solution(grid, "open.map", plan, plan.starts, plan.goals, solver="hand", solved=True, comp_time=0)
    write_solution(sol, tmp_path / "plan.txt")
    return tmp_path / "plan.txt"


def test_a_rotation_is_repaired_in_one_line_and_no_repair_refuses_it_in_the_files_coordinates(tmp_path):
    square = [(0, 0), (1, 0), (1, 1), (0, 1)]  # base frame; the file's y is 3 - y
    path = _write(tmp_path, [[square[i], square[(i + 1) % 4]] for i in range(4)])
    proc = simulate(path)
    assert proc.returncode == 0, proc.stdout
    first = proc.stdout.splitlines()[0]
    assert re.fullmatch(r"{}: 1 rotation repaired: agents [0-3](, [0-3])*; soc \+\d+, makespan \+\d+".format(
        re.escape(str(path))), first), first
    assert "collisions: 0 (" in proc.stdout and "reached goal: 4 of 4" in proc.stdout
    refused = simulate(path, "--no-repair")
    assert refused.returncode == 1
    assert refused.stdout.startswith("{}: cannot be executed by robots: rotation at t=0->1: agents ".format(path))
    assert "(0, 3)" in refused.stdout and "(1, 2)" in refused.stdout and "(0, 0)" not in refused.stdout


def test_an_invalid_plan_is_not_simulated(tmp_path):
    path = _write(tmp_path, [[(0, 0), (1, 0)], [(2, 0), (1, 0)]])
    proc = simulate(path)
    assert proc.returncode == 1
    assert "error: vertex conflict at t=1: agents 0, 1 all at (1, 3)" in proc.stdout
    assert "INVALID: 1 problem(s); not simulated" in proc.stdout


def test_rerouting_is_off_by_default_and_auto_says_how_many_robots_it_moved(shared_data):
    path = shared_data / "solutions" / "ecbs_random-32-32-20_30agents_1.txt"
    delays = ("--delay-model", "events=bernoulli:0.1:1-5", "--robot-size", "0.354:0.1")
    plain, auto = simulate(path, *delays), simulate(path, *delays, "--reroute", "auto")
    assert plain.returncode == 0 and "reroutes" not in plain.stdout
    assert auto.returncode == 0, auto.stdout + auto.stderr
    m = re.search(r"^reroutes: (\d+), (\d+) robots? given new paths \((\d+) different", auto.stdout, re.M)
    assert m and int(m.group(1)) >= 1 and int(m.group(2)) >= int(m.group(3)) >= 1, auto.stdout
    assert "rerouted" in auto.stdout and "collisions: 0" in auto.stdout
    assert "reached goal: 30 of 30 enabled robots" in auto.stdout
    assert figure(auto.stdout, "executed makespan") < figure(plain.stdout, "executed makespan")
    quiet = simulate(path, "--delay-model", "none", "--robot-size", "0.354:0.1", "--reroute", "auto")
    assert "reroutes: none" in quiet.stdout


def test_a_rerouted_run_is_not_logged_as_one_plan(tmp_path, shared_data):
    proc = simulate(shared_data / "solutions" / "pibt_sample.txt", "--reroute", "auto", "--log", tmp_path)
    assert proc.returncode == 2 and proc.stdout == "" and list(tmp_path.iterdir()) == []
    assert proc.stderr.strip().startswith("fleetctl simulate: --log with --reroute auto: a run folder records one plan")


def test_reroute_scope_all_replans_every_robot_and_needs_reroute_auto(shared_data):
    path = shared_data / "solutions" / "ecbs_random-32-32-20_30agents_1.txt"
    delays = ("--delay-model", "events=bernoulli:0.1:1-5", "--robot-size", "0.354:0.1")
    plain, every = simulate(path, *delays), simulate(path, *delays, "--reroute", "auto", "--reroute-scope", "all")
    assert every.returncode == 0, every.stdout + every.stderr
    m = re.search(r"^reroutes: (\d+), (\d+) robots? given new paths \((\d+) different", every.stdout, re.M)
    assert m and int(m.group(1)) >= 1 and int(m.group(3)) >= 2, every.stdout
    assert "collisions: 0" in every.stdout and "reached goal: 30 of 30 enabled robots" in every.stdout
    assert figure(every.stdout, "executed makespan") < figure(plain.stdout, "executed makespan")
    alone = simulate(path, "--reroute-scope", "all")
    assert alone.returncode == 2 and alone.stdout == ""
    assert alone.stderr.strip() == ("fleetctl simulate: --reroute-scope all needs --reroute auto (it says whom a "
                                    "reroute may give new paths)")
