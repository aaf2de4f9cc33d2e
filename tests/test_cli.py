"""`fleetctl` as a user meets it: real processes, real files, exit codes and one-line errors."""
from __future__ import annotations

import importlib
import re
import subprocess
import sys
from pathlib import Path
from typing import List

import pytest
from helpers import fleetctl




def assert_one_line_error(proc: subprocess.CompletedProcess, path: Path, line: int, fragment: str) -> None:
    assert proc.returncode == 2, proc.stderr
    assert "Traceback" not in proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1, proc.stderr
    assert lines[0].startswith("{}:{}:".format(path, line)), lines[0]
    assert fragment in lines[0]


def header_value(path: Path, key: str) -> str:
    for line in path.read_text().splitlines():
        if line.startswith(key + "="):
            return line.split("=", 1)[1]
    raise KeyError(key)


def solved_solutions(shared_data: Path) -> List[Path]:
    return [p for p in sorted((shared_data / "solutions").iterdir()) if header_value(p, "solved") == "1"]


def test_help_for_every_subcommand():
    from fleetctl.commands import COMMANDS

    for name, module_name, help_line in COMMANDS:
        module = importlib.import_module("fleetctl.commands." + module_name)
        assert callable(module.add_arguments) and callable(module.run)
        # a module that still names itself or its help must agree with the registry's line
        assert getattr(module, "NAME", name) == name and getattr(module, "HELP", help_line) == help_line
        proc = fleetctl(name, "--help")
        assert proc.returncode == 0 and "usage: fleetctl " + name in proc.stdout


IMPORTED = (
    "import sys\n"
    "from fleetctl.cli import main\n"
    "try:\n"
    "    main(sys.argv[1:])\n"
    "except SystemExit:\n"
    "    pass\n"
    "print(' '.join(sorted(m for m in sys.modules if m.startswith(('fleetctl.commands.', 'numpy', 'zmq', "
    "'tkinter', 'fleet_common.execution', 'fleet_common.planning.')))), file=sys.stderr)\n"
)


def modules_imported(*argv: str, cwd: Path = Path(".")) -> List[str]:
    proc = subprocess.run([sys.executable, "-c", IMPORTED, *map(str, argv)], capture_output=True, text=True,
                          cwd=str(cwd))
    return proc.stderr.strip().splitlines()[-1].split() if proc.stderr.strip() else []


def test_top_level_help_imports_no_command_and_a_command_only_its_own():
    assert modules_imported("--help") == []
    assert [m for m in modules_imported("solve", "--help") if m.startswith("fleetctl.commands.")] == [
        "fleetctl.commands.solve"]


def test_solving_a_small_instance_imports_only_the_solver_it_runs(shared_data, tmp_path):
    mods = modules_imported("solve", shared_data / "instances" / "makespan-soc-pareto.txt", "-s", "pibt",
                            "-o", tmp_path / "out.txt")
    assert (tmp_path / "out.txt").is_file()
    assert "fleet_common.planning.pibt" in mods and "numpy" in mods
    for unused in ("fleet_common.planning.cbs", "fleet_common.planning.lacam", "fleet_common.planning.mapf_ir",
                   "fleet_common.planning.prioritized", "fleet_common.execution", "zmq", "tkinter"):
        assert unused not in mods, unused


def test_validate_every_shipped_solution_reports_the_headers_figures(shared_data):
    solutions = solved_solutions(shared_data)
    assert len(solutions) >= 4
    for path in solutions:
        proc = fleetctl("validate", path)
        assert proc.returncode == 0, proc.stdout + proc.stderr
        summary = proc.stdout.strip().splitlines()[-1]
        soc, makespan = header_value(path, "soc"), header_value(path, "makespan")
        assert "soc={},".format(soc) in summary and "makespan={}".format(makespan) in summary, summary


def test_following_moves_are_legal_by_default_and_errors_when_strict(shared_data):
    path = shared_data / "solutions" / "pibt_sample.txt"
    relaxed = fleetctl("validate", path)
    assert relaxed.returncode == 0 and "following moves, legal in mapf-IR" in relaxed.stdout
    strict = fleetctl("validate", "--strict-following", path)
    assert strict.returncode == 1 and "following move at t=" in strict.stdout


def test_failed_run_is_no_plan_with_exit_1(shared_data):
    proc = fleetctl("validate", shared_data / "solutions" / "cbs_arena300_1_timeout.txt")
    assert proc.returncode == 1
    assert "no plan" in proc.stdout and "solved=0" in proc.stdout


def test_conflicts_are_listed_in_the_files_own_coordinates(shared_data, tmp_path):
    src = shared_data / "solutions" / "cbs_makespan-soc-pareto.txt"
    text = src.read_text().replace("1:(4,1),(0,3),", "1:(4,1),(4,1),")  # agent 1 jumps onto agent 0
    (tmp_path / "makespan-soc-pareto.map").write_bytes(
        (shared_data / "maps" / "makespan-soc-pareto.map").read_bytes())
    bad = tmp_path / "bad.txt"
    bad.write_text(text)
    proc = fleetctl("validate", bad)
    assert proc.returncode == 1
    assert "vertex conflict at t=1: agents 0, 1 all at (4, 1)" in proc.stdout
    assert "agent 1 jumps from (1, 3) at t=0 to (4, 1) at t=1" in proc.stdout
    assert "INVALID" in proc.stdout.splitlines()[-1]


def test_unreadable_solution_is_one_line_with_file_and_line(shared_data, tmp_path):
    (tmp_path / "makespan-soc-pareto.map").write_bytes(
        (shared_data / "maps" / "makespan-soc-pareto.map").read_bytes())
    src = (shared_data / "solutions" / "cbs_makespan-soc-pareto.txt").read_text().splitlines(True)
    src[14] = "2:(4,1),(0,2\n"  # line 15
    bad = tmp_path / "broken.txt"
    bad.write_text("".join(src))
    assert_one_line_error(fleetctl("validate", bad), bad, 15, "")
    assert_one_line_error(fleetctl("info", bad), bad, 15, "")


def test_missing_file_and_missing_map_are_one_line(tmp_path):
    proc = fleetctl("validate", tmp_path / "nope.txt")
    assert proc.returncode == 2 and "Traceback" not in proc.stderr and "nope.txt" in proc.stderr
    inst = tmp_path / "inst.txt"
    inst.write_text("map_file=no-such.map\nagents=1\n0,0,1,1\n")
    assert_one_line_error(fleetctl("info", inst), inst, 1, "no-such.map")


@pytest.mark.parametrize("kind,relpath,expect", [
    ("map", "maps/arena.map", "map 49x49"),
    ("instance", "instances/arena_300agents_1.txt", "300 agents on arena.map"),
    ("random instance", "instances/sample.txt", "random_problem=1"),
    ("solution", "solutions/ir_makespan-soc-pareto.txt", "refinement iterations"),
    ("failed run", "solutions/cbs_arena300_1_timeout.txt", "NOT solved"),
    # mapf-IR's PIBT turns its robots at most corners: on robots that turn in place it runs late
    ("turns", "solutions/pibt_sample.txt", "1,223 quarter turns in 3,297 moves; the slowest robot needs 83.5 moves' "
     "time with its turns, 1.14x the makespan: it cannot run as planned on them (fleetctl solve -s pibt-turns "
     "plans the turns)"),
])
def test_info_summarises_mapf_ir_files(shared_data, kind, relpath, expect):
    proc = fleetctl("info", shared_data / relpath)
    assert proc.returncode == 0, proc.stderr
    assert expect in proc.stdout


def test_info_on_robot_definitions_and_unknown_files(repo_root, tmp_path):
    proc = fleetctl("info", repo_root / "robot_definitions.txt")
    assert proc.returncode == 0 and "robot definitions: 5 robots" in proc.stdout
    junk = tmp_path / "junk.txt"
    junk.write_text("hello world\n")
    assert_one_line_error(fleetctl("info", junk), junk, 1, "cannot tell what this file is")


def test_convert_to_mapf_ir_is_byte_for_byte(shared_data, tmp_path):
    for relpath in ("solutions/pibt_sample.txt", "solutions/ir_makespan-soc-pareto.txt",
                    "solutions/cbs_arena300_1_timeout.txt", "instances/sample.txt",
                    "instances/arena_300agents_1.txt", "maps/8x8.map", "maps/arena.map"):
        src = shared_data / relpath
        out = tmp_path / src.name
        proc = fleetctl("convert", src, out, "--to", "mapf-ir", "--map-dir", shared_data / "maps")
        assert proc.returncode == 0, proc.stderr
        assert out.read_bytes() == src.read_bytes(), relpath


def test_convert_to_base_flips_y_and_back(shared_data, tmp_path):
    src = shared_data / "solutions" / "cbs_makespan-soc-pareto.txt"
    maps = shared_data / "maps"
    base = tmp_path / "base.txt"
    assert fleetctl("convert", src, base, "--to", "base", "--map-dir", maps).returncode == 0
    text = base.read_text()
    assert "orientation=base" in text
    assert "starts=(3,2),(1,0)," in text  # map height 4: y' = 3 - y
    back = tmp_path / "back.txt"
    assert fleetctl("convert", base, back, "--to", "mapf-ir", "--map-dir", maps).returncode == 0
    assert back.read_bytes() == src.read_bytes()
    proc = fleetctl("validate", base, "--map-dir", maps)
    assert proc.returncode == 0 and "soc=13," in proc.stdout


def test_convert_refuses_to_overwrite_its_input(shared_data, tmp_path):
    src = tmp_path / "8x8.map"
    src.write_bytes((shared_data / "maps" / "8x8.map").read_bytes())
    proc = fleetctl("convert", src, src)
    assert proc.returncode == 2 and "same file" in proc.stderr
    assert src.read_bytes() == (shared_data / "maps" / "8x8.map").read_bytes()


def test_demo_plans_the_lab_scenario():
    proc = fleetctl("demo", "--plan-only")
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert "13x14 marker grid" in proc.stdout
    assert re.search(r"plan: \S+ in \d+ ms, soc=\d+, makespan=\d+, valid", proc.stdout)
    assert len(re.findall(r"^  robot \d+ ", proc.stdout, flags=re.M)) == 5
    # CBS's optimal plan has robot 5 turn twice, pibt-turns' once: the robots finish that one sooner
    chosen = re.search(r"^plan chosen: pibt-turns over cbs: its slowest robot drives and turns for ([\d.]+) "
                       r"moves' time, against ([\d.]+)$", proc.stdout, flags=re.M)
    assert chosen and float(chosen.group(1)) < float(chosen.group(2)), proc.stdout
    assert "plan: pibt-turns in" in proc.stdout
    for strategy in ("adg", "step"):
        assert re.search(r"^  {}: executed makespan [\d.]+ \(plan \d+\), \d+ waits, collisions: 0, "
                         r"robots at goal: 5 of 5$".format(strategy), proc.stdout, flags=re.M), proc.stdout


def test_demo_runs_the_solver_it_is_given():
    proc = fleetctl("demo", "--plan-only", "-s", "cbs")
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert "plan chosen" not in proc.stdout and "plan: cbs in" in proc.stdout


def test_legacy_plan_converts_to_a_mapf_ir_solution_that_validates(repo_root, tmp_path):
    src = repo_root / "tests" / "data" / "legacy" / "lab_plan.xml"
    out = tmp_path / "lab_plan.txt"
    proc = fleetctl("convert", src, out)
    assert proc.returncode == 0, proc.stderr
    assert "map_file=lab.map" in out.read_text()
    info = fleetctl("info", src)
    assert info.returncode == 0 and "converts to a timed grid plan" in info.stdout
    check = fleetctl("validate", out)
    assert check.returncode == 0, check.stdout + check.stderr
    assert "valid:" in check.stdout


def test_thesis_legacy_plan_is_reported_not_convertible(repo_root, tmp_path):
    src = repo_root / "tests" / "data" / "legacy" / "thesis_fig3_1_plan.xml"
    info = fleetctl("info", src)  # lab units: (37, 37) m is not a lab cell
    assert info.returncode == 0 and "not convertible" in info.stdout and "not on a grid cell" in info.stdout
    info = fleetctl("info", src, "--legacy-scale", "1", "--legacy-origin", "0", "0")
    assert info.returncode == 0 and "not convertible" in info.stdout and "diagonal" in info.stdout
    proc = fleetctl("convert", src, tmp_path / "out.txt", "--legacy-scale", "1", "--legacy-origin", "0", "0")
    assert proc.returncode == 2 and "agent 5 section 1" in proc.stderr
    assert len(proc.stderr.strip().splitlines()) == 1 and not (tmp_path / "out.txt").exists()


def test_legacy_node_map_becomes_the_lab_grid(repo_root, tmp_path):
    from fleet_common.formats.mapfile import read_map
    from fleet_common.lab import lab_map_path

    out = tmp_path / "nodes.map"
    proc = fleetctl("convert", repo_root / "tests" / "data" / "legacy" / "lab_nodes.xml", out)
    assert proc.returncode == 0, proc.stderr
    assert read_map(out).grid == read_map(lab_map_path()).grid


def test_scen_converts_to_an_instance_that_solves(shared_data, tmp_path):
    scen = tmp_path / "pareto.scen"
    scen.write_text("version 1\n"
                    "0\tmakespan-soc-pareto.map\t6\t4\t3\t1\t4\t1\t1\n"
                    "0\tmakespan-soc-pareto.map\t6\t4\t1\t3\t5\t1\t8\n"
                    "0\tmakespan-soc-pareto.map\t6\t4\t0\t3\t0\t2\t1\n")
    info = fleetctl("info", scen)
    assert info.returncode == 0 and "MovingAI scenario: 3 entries" in info.stdout
    out = tmp_path / "pareto.txt"
    proc = fleetctl("convert", scen, out, "--agents", "2", "--map-dir", shared_data / "maps")
    assert proc.returncode == 0, proc.stderr
    text = out.read_text()
    assert "map_file=makespan-soc-pareto.map" in text and "agents=2" in text
    assert text.strip().splitlines()[-2:] == ["3,1,4,1", "1,3,5,1"]
    solved = fleetctl("solve", out, "-s", "cbs", "-o", tmp_path / "sol.txt", "--map-dir", shared_data / "maps")
    assert solved.returncode == 0 and "soc=13" in solved.stdout


def test_scen_naming_a_blocked_cell_is_one_line_with_its_line(shared_data, tmp_path):
    scen = tmp_path / "bad.scen"
    scen.write_text("version 1\n"
                    "0\tmakespan-soc-pareto.map\t6\t4\t3\t1\t4\t1\t1\n"
                    "0\tmakespan-soc-pareto.map\t6\t4\t0\t0\t5\t1\t8\n")  # (0,0) is 'T'
    proc = fleetctl("convert", scen, tmp_path / "out.txt", "--map-dir", shared_data / "maps")
    assert_one_line_error(proc, scen, 3, "blocked")


# option -> a value a user could type by mistake; each is refused by the parser itself
BAD_OPTIONS = [
    (["solve", "i.txt", "--time-limit"], "-1"), (["solve", "i.txt", "--time-limit"], "nan"),
    (["solve", "i.txt", "-s", "ecbs", "--w"], "nan"), (["solve", "i.txt", "--w"], "0.5"),
    (["solve", "i.txt", "--seed"], "-1"), (["solve", "i.txt", "--max-timestep"], "0"),
    (["solve", "x.scen", "--agents"], "-3"), (["simulate", "s.txt", "--seed"], "-1"),
    (["simulate", "s.txt", "--lookahead"], "0"), (["demo", "--time-scale"], "inf"),
    (["demo", "--time-limit"], "-1"), (["demo", "--seed"], "-1"), (["demo", "--linger"], "nan"),
    (["repair", "s.txt", "--time-limit"], "0"), (["trace", "run", "--dt"], "nan"),
    (["console", "--replay", "s.txt", "--speed"], "nan"), (["console", "--manager", "127.0.0.1:1", "--every"], "0"),
    (["console", "--manager"], "x"),
    (["experiment", "e.yaml", "--jobs"], "9" * 30), (["vicon", "listen", "--port"], "70000"),
    (["vicon", "simulate", "--seed"], "-2"), (["virtual-fleet", "--feedback-base"], "-1"),
    (["virtual-fleet", "--max-step"], "inf"), (["convert", "x.scen", "-o", "o.txt", "--agents"], "0"),
    (["manager", "s.txt", "--vicon"], "70000"), (["manager", "s.txt", "--time-limit"], "nan"),
    (["manager", "s.txt", "--seed"], "-1"), (["manager", "s.txt", "--state-rate"], "0"),
]


@pytest.mark.parametrize("args, value", BAD_OPTIONS, ids=[" ".join(a[:1] + a[-1:]) + " " + v[:6]
                                                          for a, v in BAD_OPTIONS])
def test_a_nonsense_option_value_is_the_parsers_one_line_error(args: List[str], value: str,
                                                               capsys: pytest.CaptureFixture) -> None:
    from fleetctl.cli import main

    with pytest.raises(SystemExit) as ended:
        main(args + [value])
    assert ended.value.code == 2
    error = capsys.readouterr().err.splitlines()[-1]
    assert error.startswith("fleetctl " + args[0]) and ": error: argument " in error, error
    assert args[-1] in error.split(": error: argument ")[1].split(":")[0], error  # the option
    assert "expected" in error and repr(value) in error, error


# command-line mistakes of each program a user types: (argv, the program's name, the --help the line points to)
WRONG_COMMAND_LINES = [
    (["-m", "fleetctl"], "fleetctl", "fleetctl"),
    (["-m", "fleetctl", "sovle"], "fleetctl", "fleetctl"),
    (["-m", "fleetctl", "solve"], "fleetctl solve", "fleetctl solve"),
    (["-m", "fleetctl", "solve", "i.txt", "--bogus"], "fleetctl", "fleetctl solve"),
    (["-m", "fleetctl", "solve", "i.txt", "-s"], "fleetctl solve", "fleetctl solve"),
    (["-m", "fleetctl", "solve", "i.txt", "-s", "astar"], "fleetctl solve", "fleetctl solve"),
    (["-m", "fleetctl", "vicon", "listen", "--port", "0"], "fleetctl vicon listen", "fleetctl vicon listen"),
    (["-m", "deploy", "robots:start", "--bogus"], "ciirc-exec.sh", "ciirc-exec.sh robots:start"),
    (["-m", "deploy", "robots:strat"], "ciirc-exec.sh", "ciirc-exec.sh"),
    (["-m", "deploy", "robots:ssh"], "ciirc-exec.sh robots:ssh", "ciirc-exec.sh robots:ssh"),
    (["-c", "import sys; from fleet_manager.main import main; main(sys.argv[1:])", "--state-rate", "0"],
     "fleet_manager", "fleet_manager"),
]


@pytest.mark.parametrize("argv, prog, see", WRONG_COMMAND_LINES, ids=[" ".join(a[1:])[:40] for a, _, _ in
                                                                      WRONG_COMMAND_LINES])
def test_a_wrong_command_line_is_one_line_naming_the_help_to_read(argv: List[str], prog: str, see: str) -> None:
    """argparse's own output is the usage block and then the error; ours is the error alone, on one
    line like every other error, with where the usage is."""
    proc = subprocess.run([sys.executable, *argv], capture_output=True, text=True, timeout=60)
    assert proc.returncode == 2, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1, proc.stderr
    assert lines[0].startswith(prog + ": error: "), lines[0]
    assert lines[0].endswith("(see {} --help)".format(see)), lines[0]
    assert proc.stdout == ""
