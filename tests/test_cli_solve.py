"""`fleetctl solve` end to end: real processes, files read back and validated, exit codes."""
from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path
from typing import Dict, Optional

import pytest

import fake_mapf_ir
from helpers import dense_instance
from fleet_common.formats.solution import read_solution
from fleet_common.validate import validate_plan

HEADER_KEYS = ["instance", "agents", "map_file", "solver", "solved", "soc", "lb_soc", "makespan",
               "lb_makespan", "comp_time"]


def fleetctl(*args: object, cwd: Optional[Path] = None,
             env: Optional[Dict[str, str]] = None) -> subprocess.CompletedProcess:
    full_env = dict(os.environ)
    full_env.pop("MAPF_IR_APP", None)
    full_env.update(env or {})
    return subprocess.run([sys.executable, "-m", "fleetctl", "solve", *map(str, args)],
                          capture_output=True, text=True, timeout=120, cwd=cwd, env=full_env)


def header_keys(path: Path):
    keys = []
    for line in path.read_text().splitlines():
        if line.startswith("starts="):
            return keys
        keys.append(line.split("=", 1)[0])
    raise AssertionError("no starts= line in {}".format(path))


def assert_valid_solution(out: Path, shared_data: Path, agents: int):
    sol = read_solution(out, [shared_data / "maps"])
    assert header_keys(out) == HEADER_KEYS
    assert sol.solved and sol.agents == agents
    report = validate_plan(sol.plan, sol.grid, sol.starts, sol.goals, soc=sol.soc, makespan=sol.makespan)
    assert report.ok, [str(f) for f in report.errors[:3]]
    assert sol.lb_soc <= sol.soc and sol.lb_makespan <= sol.makespan
    return sol


def one_line(text: str) -> str:
    lines = text.strip().splitlines()
    assert len(lines) == 1, text
    return lines[0]


@pytest.mark.parametrize("solver", ["pibt", "lacam", "cbs", "pp"])
def test_each_builtin_solver_writes_a_valid_mapf_ir_solution(solver, shared_data, tmp_path):
    instance = shared_data / "instances" / "makespan-soc-pareto.txt"
    out = tmp_path / "out.txt"
    proc = fleetctl(instance, "-s", solver, "-o", out)
    assert proc.returncode == 0, proc.stderr
    sol = assert_valid_solution(out, shared_data, 2)
    assert sol.map_file == "makespan-soc-pareto.map" and sol.instance == str(instance)
    summary = one_line(proc.stdout)
    assert summary.startswith("solved=1, solver={}".format(solver))
    assert "soc={} ".format(sol.soc) in summary and "makespan={} ".format(sol.makespan) in summary
    assert "comp_time(ms)=" in summary and summary.endswith(str(out))
    if solver == "cbs":
        assert sol.soc == 13  # mapf-IR's CBS on the same instance


@pytest.mark.parametrize("solver", ["pibt", "lacam", "pp"])
def test_builtin_solvers_on_a_shipped_benchmark_instance(solver, shared_data, tmp_path):
    out = tmp_path / "out.txt"
    proc = fleetctl(shared_data / "instances" / "random-32-32-20_30agents_1.txt", "-s", solver, "-o", out)
    assert proc.returncode == 0, proc.stderr
    assert_valid_solution(out, shared_data, 30)


def test_default_output_is_named_after_instance_and_solver_in_the_current_folder(shared_data, tmp_path):
    proc = fleetctl(shared_data / "instances" / "makespan-soc-pareto.txt", "-s", "pibt", cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    assert [p.name for p in tmp_path.iterdir()] == ["makespan-soc-pareto.pibt.txt"]
    assert one_line(proc.stdout).endswith("-> makespan-soc-pareto.pibt.txt")


def test_dash_writes_the_solution_to_stdout_and_the_summary_to_stderr(shared_data, tmp_path):
    proc = fleetctl(shared_data / "instances" / "makespan-soc-pareto.txt", "-s", "cbs", "-o", "-")
    assert proc.returncode == 0, proc.stderr
    out = tmp_path / "captured.txt"
    out.write_text(proc.stdout)
    assert assert_valid_solution(out, shared_data, 2).soc == 13
    assert one_line(proc.stderr).startswith("solved=1, solver=cbs")


def write_corridor(tmp_path: Path) -> Path:
    """Two agents that must swap in a two-cell corridor: no plan exists."""
    (tmp_path / "corridor.map").write_text("type octile\nheight 1\nwidth 2\nmap\n..\n")
    instance = tmp_path / "swap.txt"
    instance.write_text("map_file=corridor.map\nagents=2\nseed=0\nrandom_problem=0\n0,0,1,0\n1,0,0,0\n")
    return instance


@pytest.mark.parametrize("solver", ["lacam", "cbs"])
def test_no_plan_writes_a_failed_output_and_exits_3(solver, tmp_path):
    instance = write_corridor(tmp_path)
    out = tmp_path / "out.txt"
    proc = fleetctl(instance, "-s", solver, "-o", out, "--time-limit", "2")
    assert proc.returncode == 3, proc.stdout + proc.stderr
    message = one_line(proc.stderr)
    assert message.startswith("fleetctl solve: no plan: {}".format(solver)) and str(out) in message
    assert "Traceback" not in proc.stderr and proc.stdout == ""
    text = out.read_text()
    assert "solved=0\n" in text and "soc=0\n" in text and "makespan=-1\n" in text
    assert text.endswith("solution=\n")
    sol = read_solution(out)
    assert sol.plan is None and not sol.solved and header_keys(out) == HEADER_KEYS


def test_running_out_of_time_exits_3(shared_data, tmp_path):
    out = tmp_path / "out.txt"
    proc = fleetctl(shared_data / "instances" / "random-32-32-20_110agents_1.txt", "-s", "cbs",
                    "--time-limit", "0.01", "-o", out)
    assert proc.returncode == 3, proc.stdout + proc.stderr
    assert "ran out of time" in one_line(proc.stderr)
    assert "makespan=-1\n" in out.read_text()


def test_a_bad_instance_is_one_line_file_line_message(tmp_path):
    (tmp_path / "corridor.map").write_text("type octile\nheight 1\nwidth 3\nmap\n...\n")
    bad = tmp_path / "bad.txt"
    bad.write_text("map_file=corridor.map\nagents=1\n0,0,2\n")
    proc = fleetctl(bad, "-o", tmp_path / "out.txt")
    assert proc.returncode == 2 and "Traceback" not in proc.stderr
    assert one_line(proc.stderr).startswith("{}:3:".format(bad))
    assert not (tmp_path / "out.txt").exists()


def test_an_unreachable_goal_names_the_agent(tmp_path):
    (tmp_path / "split.map").write_text("type octile\nheight 1\nwidth 3\nmap\n.@.\n")
    inst = tmp_path / "split.txt"
    inst.write_text("map_file=split.map\nagents=1\n0,0,2,0\n")
    proc = fleetctl(inst, "-o", tmp_path / "out.txt")
    assert proc.returncode == 2 and "Traceback" not in proc.stderr
    assert "agent 0: goal (2, 0) cannot be reached from start (0, 0)" in one_line(proc.stderr)


def test_a_scen_with_map_and_agent_count(shared_data, tmp_path):
    instance = (shared_data / "instances" / "random-32-32-20_30agents_1.txt").read_text().splitlines()
    rows = [line.split(",") for line in instance if line.count(",") == 3]
    scen = tmp_path / "random.scen"
    scen.write_text("version 1\n" + "".join(
        "0\trandom-32-32-20.map\t32\t32\t{}\t{}\t{}\t{}\t0\n".format(*r) for r in rows))
    out = tmp_path / "out.txt"
    proc = fleetctl(scen, "--map", shared_data / "maps" / "random-32-32-20.map", "--agents", "10",
                    "-s", "pibt", "-o", out)
    assert proc.returncode == 0, proc.stderr
    sol = assert_valid_solution(out, shared_data, 10)
    assert sol.map_file == "random-32-32-20.map"
    assert sol.starts[0] == (int(rows[0][0]), 31 - int(rows[0][1]))  # base frame after reading


def test_mapf_ir_solver_with_options_through_the_stand_in(shared_data, tmp_path):
    app = fake_mapf_ir.install(tmp_path)
    log = tmp_path / "argv.json"
    out = tmp_path / "out.txt"
    proc = fleetctl(shared_data / "instances" / "makespan-soc-pareto.txt", "-s", "mapf-ir:ECBS",
                    "--mapf-ir", app, "-o", out, "--", "-w", "1.2",
                    env={"FAKE_MAPF_IR_ARGV_LOG": str(log)})
    assert proc.returncode == 0, proc.stderr
    sol = assert_valid_solution(out, shared_data, 2)
    assert sol.solver == "ECBS" and sol.map_file == "makespan-soc-pareto.map"
    assert json.loads(log.read_text())["argv"][-2:] == ["-w", "1.2"]
    assert one_line(proc.stdout).startswith("solved=1, solver=ECBS")


def test_mapf_ir_from_the_environment_and_its_failures(shared_data, tmp_path):
    app = fake_mapf_ir.install(tmp_path)
    instance = shared_data / "instances" / "makespan-soc-pareto.txt"
    out = tmp_path / "out.txt"
    ok = fleetctl(instance, "-s", "mapf-ir:PIBT", "-o", out, env={"MAPF_IR_APP": str(app)})
    assert ok.returncode == 0, ok.stderr
    work = tmp_path / "tmp"  # where the work folders go (TMPDIR), kept after a failure for the user
    work.mkdir()
    failed = fleetctl(instance, "-s", "mapf-ir:PIBT", "-o", out,
                      env={"MAPF_IR_APP": str(app), "FAKE_MAPF_IR_MODE": "exit", "TMPDIR": str(work)})
    assert failed.returncode == 1 and "exited with status 3" in failed.stderr
    assert "error@run" in failed.stderr and "Traceback" not in failed.stderr
    garbage = fleetctl(instance, "-s", "mapf-ir:PIBT", "-o", out,
                       env={"MAPF_IR_APP": str(app), "FAKE_MAPF_IR_MODE": "garbage", "TMPDIR": str(work)})
    assert garbage.returncode == 2 and "output.txt:2:" in one_line(garbage.stderr)
    kept = sorted(work.iterdir(), key=lambda p: p.stat().st_mtime)
    assert len(kept) == 2 and all("mapf-IR's files are kept in {}".format(k) in e.stderr
                                  for k, e in zip(kept, (failed, garbage)))
    assert (kept[1] / "instance.txt").is_file() and (kept[1] / "output.txt").is_file()
    missing = fleetctl(instance, "-s", "mapf-ir:PIBT", "-o", out)
    assert missing.returncode == 2 and "MAPF_IR_APP" in one_line(missing.stderr)


def test_command_line_mistakes_exit_2(shared_data):
    instance = shared_data / "instances" / "makespan-soc-pareto.txt"
    unknown = fleetctl(instance, "-s", "astar")
    assert unknown.returncode == 2 and "unknown solver 'astar'" in unknown.stderr
    extra = fleetctl(instance, "-s", "pibt", "--", "-w", "1.2")
    assert extra.returncode == 2 and "for mapf-IR solvers" in one_line(extra.stderr)
    rotations = fleetctl(instance, "-s", "mapf-ir:PIBT", "--allow-rotations")
    assert rotations.returncode == 2
    assert one_line(rotations.stderr) == ("fleetctl solve: --allow-rotations is for the built-in solvers; "
                                          "mapf-IR's solvers always allow rotations")


def write_long_corridor(tmp_path: Path, max_timestep: int) -> Path:
    """One agent from one end of a 12-cell corridor to the other: 11 steps."""
    (tmp_path / "long.map").write_text("type octile\nheight 1\nwidth 12\nmap\n" + "." * 12 + "\n")
    instance = tmp_path / "long.txt"
    instance.write_text("map_file=long.map\nagents=1\nseed=0\nrandom_problem=0\nmax_timestep={}\n"
                        "0,0,11,0\n".format(max_timestep))
    return instance


@pytest.mark.parametrize("solver", ["pibt", "cbs"])
def test_the_instances_max_timestep_is_honoured_unless_the_command_line_overrides_it(solver, tmp_path):
    instance = write_long_corridor(tmp_path, 10)
    out = tmp_path / "out.txt"
    short = fleetctl(instance, "-s", solver, "-o", out)
    assert short.returncode == 3, short.stdout + short.stderr
    assert "max_timestep=10" in one_line(short.stderr) and "solved=0\n" in out.read_text()
    longer = fleetctl(instance, "-s", solver, "-o", out, "--max-timestep", "11")
    assert longer.returncode == 0, longer.stderr
    assert read_solution(out).makespan == 11


def test_comp_time_counts_the_distance_tables_built_for_the_instance(shared_data, tmp_path, monkeypatch):
    # a stub clock that the distance search moves on by 5 s: comp_time must include those 5 s,
    # so the command may not build the tables (e.g. for the lower bounds) before the solve starts
    from fleet_common.planning import goal_distances
    from fleet_common.planning.deadline import Deadline
    from fleetctl.cli import main
    from fleetctl.commands import solve as solve_command

    now = [1000.0]
    search = goal_distances.grow

    def slow_search(*args, **kwargs):
        now[0] += 5.0
        return search(*args, **kwargs)

    monkeypatch.setattr(goal_distances, "grow", slow_search)
    monkeypatch.setattr(solve_command, "Deadline", lambda seconds: Deadline(seconds, clock=lambda: now[0]))
    out = tmp_path / "out.txt"
    assert main(["solve", str(shared_data / "instances" / "makespan-soc-pareto.txt"), "-s", "pibt",
                 "-o", str(out)]) == 0
    sol = read_solution(out, [shared_data / "maps"])
    assert sol.solved and sol.comp_time >= 5000


def test_ecbs_and_anytime_lacam_from_the_command_line(shared_data, tmp_path):
    instance = shared_data / "instances" / "random-32-32-20_30agents_1.txt"
    out = tmp_path / "out.txt"
    ecbs = fleetctl(instance, "-s", "ecbs", "--w", "1.1", "-o", out)
    assert ecbs.returncode == 0, ecbs.stderr
    assert read_solution(out, [shared_data / "maps"]).soc <= 1.1 * 678  # 678: the optimum (mapf-IR's CBS)
    anytime = fleetctl(instance, "-s", "lacam", "--anytime", "--time-limit", "1", "-o", out)
    assert anytime.returncode == 0, anytime.stderr
    lines = anytime.stdout.rstrip().splitlines()
    socs = [int(line.split()[1]) for line in lines[:-1]]
    assert socs and all(line.startswith("  soc ") for line in lines[:-1])
    assert socs == sorted(socs, reverse=True) and len(set(socs)) == len(socs)  # each line an improvement
    assert "soc={} ".format(socs[-1]) in lines[-1]
    wrong = fleetctl(instance, "-s", "pibt", "--w", "1.2")
    assert wrong.returncode == 2 and one_line(wrong.stderr) == "fleetctl solve: --w is for ecbs, not pibt"


def test_lacam_star_stops_at_its_memory_limit_with_its_best_plan(shared_data, tmp_path):
    """LaCAM* keeps every configuration until its time limit; at --memory-limit it stops and
    writes the best plan so far rather than grow until the OOM killer takes the plan with it."""
    instance = dense_instance(shared_data, tmp_path)
    out = tmp_path / "out.txt"
    proc = fleetctl(instance, "--anytime", "--memory-limit", 100, "--time-limit", 120, "-o", out,
                    "--map-dir", shared_data / "maps")
    assert proc.returncode == 0, proc.stderr
    lines = proc.stdout.splitlines()
    assert lines[0].startswith("  soc ") and lines[-1].startswith("solved=1, solver=lacam")
    assert lines[-2].startswith("  stopped at the memory limit (100 MB, --memory-limit) after ")
    sol = assert_valid_solution(out, shared_data, 400)
    assert sol.comp_time < 120000  # it stopped well before its time limit
    assert sol.soc == int(lines[-3].split()[1])  # the plan is the best it had found


def test_lacam_without_a_plan_at_its_memory_limit_says_so_and_exits_3(shared_data, tmp_path):
    instance = dense_instance(shared_data, tmp_path)
    proc = fleetctl(instance, "--memory-limit", 1, "-o", tmp_path / "out.txt", "--map-dir", shared_data / "maps")
    assert proc.returncode == 3, proc.stderr
    assert one_line(proc.stderr).startswith(
        "fleetctl solve: no plan: lacam reached the memory limit of 1 MB (--memory-limit) after ")
    assert not read_solution(tmp_path / "out.txt", [shared_data / "maps"]).solved


def test_options_of_the_built_in_solvers_are_refused_for_others(shared_data, tmp_path):
    instance = shared_data / "instances" / "makespan-soc-pareto.txt"
    app = fake_mapf_ir.install(tmp_path)
    pibt = fleetctl(instance, "-s", "pibt", "--memory-limit", 100)
    assert pibt.returncode == 2 and one_line(pibt.stderr) == "fleetctl solve: --memory-limit is for lacam, not pibt"
    theirs = fleetctl(instance, "-s", "mapf-ir:ECBS", "--mapf-ir", app, "--anytime", "--w", 1.2)
    assert theirs.returncode == 2 and one_line(theirs.stderr) == (
        "fleetctl solve: --anytime, --w are for the built-in solvers; give mapf-IR's own options after `--` "
        "(e.g. `-- -w 1.2`)")
    zero = fleetctl(instance, "--memory-limit", 0)
    assert zero.returncode == 2 and "--memory-limit" in one_line(zero.stderr)
