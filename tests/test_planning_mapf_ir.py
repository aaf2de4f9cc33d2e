"""mapf-IR as a plug-in solver, against the stand-in executable laid out like a mapf-IR build.

The stand-in (tests/fake_mapf_ir) follows mapf-IR's command line: it opens
`map_file=` only relative to its own `../map/` folder, writes mapf-IR's output
format, and can be told to crash, exit non-zero, hang or write garbage.
"""
from __future__ import annotations

import json
import os
import stat
import tempfile
from pathlib import Path

import pytest

import fake_mapf_ir
from fleet_common.errors import SolutionFormatError
from fleet_common.formats.instance import read_instance
from fleet_common.grid import Grid
from fleet_common.planning.deadline import Deadline
from fleet_common.planning.mapf_ir import MapfIrError, MapfIrFailed, MapfIrSolver, find_map_dir
from fleet_common.planning.problem import InvalidProblemError
from fleet_common.validate import validate_plan


@pytest.fixture
def app(tmp_path: Path) -> Path:
    return fake_mapf_ir.install(tmp_path / "install")


@pytest.fixture
def argv_log(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    log = tmp_path / "argv.json"
    monkeypatch.setenv("FAKE_MAPF_IR_ARGV_LOG", str(log))
    return log


@pytest.fixture(autouse=True)
def work_tmp(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """Where the adapter's work folders go, to see what it leaves behind (and, for every test,
    so that the folders kept after a failure stay out of the machine's /tmp)."""
    folder = tmp_path / "tmp"
    folder.mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(folder))
    return folder


@pytest.fixture
def pareto(shared_data: Path):
    return read_instance(shared_data / "instances" / "makespan-soc-pareto.txt", [shared_data / "maps"])


def mode(monkeypatch: pytest.MonkeyPatch, name: str) -> None:
    monkeypatch.setenv("FAKE_MAPF_IR_MODE", name)


def test_plans_through_mapf_ir_and_returns_a_valid_base_frame_plan(app, pareto, argv_log, work_tmp):
    result = MapfIrSolver(app).solve(pareto.grid, pareto.starts, pareto.goals, "CBS")
    assert result.status == "solved" and result.solver == "CBS"
    assert result.plan.soc == 13 and result.plan.makespan == 12
    assert validate_plan(result.plan, pareto.grid, pareto.starts, pareto.goals).ok
    assert result.plan.starts == pareto.starts  # flipped back from mapf-IR's top-left frame
    assert result.stats["lb_soc"] == 9 and result.stats["process_ms"] > 0
    assert list(work_tmp.iterdir()) == []  # the work folder is removed after a normal run


def test_arguments_and_options_reach_mapf_ir(app, pareto, argv_log, work_tmp):
    MapfIrSolver(app).solve(pareto.grid, pareto.starts, pareto.goals, "ECBS", ["-w", "1.2"],
                            deadline=Deadline(7.5), seed=4, keep_files=True)
    logged = json.loads(argv_log.read_text())
    argv = logged["argv"]
    assert argv[argv.index("-s") + 1] == "ECBS"
    assert argv[-2:] == ["-w", "1.2"]
    assert 7000 < int(argv[argv.index("-T") + 1]) <= 7500
    instance = Path(argv[argv.index("-i") + 1]).read_text()
    assert "seed=4" in instance.splitlines() and "agents=2" in instance.splitlines()
    assert Path(argv[argv.index("-o") + 1]).is_file()


def test_a_time_limit_in_the_options_is_not_overridden(app, pareto, argv_log):
    MapfIrSolver(app).solve(pareto.grid, pareto.starts, pareto.goals, "PIBT", ["-T", "1234"])
    argv = json.loads(argv_log.read_text())["argv"]
    assert argv.count("-T") == 1 and argv[argv.index("-T") + 1] == "1234"


def test_the_map_is_named_relative_to_mapf_irs_map_folder_which_stays_untouched(app, pareto, argv_log):
    map_dir = app.parent.parent / "map"
    MapfIrSolver(app).solve(pareto.grid, pareto.starts, pareto.goals, "PIBT")
    logged = json.loads(argv_log.read_text())
    assert Path(logged["cwd"]).resolve() == map_dir.resolve()
    assert list(map_dir.iterdir()) == []
    instance = Path(json.loads(argv_log.read_text())["argv"][2])
    assert not instance.exists()  # removed with the work folder
    # the stand-in opens map_file only from its map folder: an absolute path would have failed


def test_a_wrong_map_folder_is_reported_with_a_hint(app, pareto, tmp_path):
    elsewhere = tmp_path / "elsewhere" / "deeper"
    elsewhere.mkdir(parents=True)
    with pytest.raises(MapfIrFailed) as err:
        MapfIrSolver(app, map_dir=elsewhere).solve(pareto.grid, pareto.starts, pareto.goals, "PIBT")
    text = str(err.value)
    assert "exited with status 1" in text and "is not found." in text
    assert "--mapf-ir-map-dir" in text and str(elsewhere) in text


def test_the_map_folder_is_found_in_the_binary_when_not_beside_it(tmp_path):
    compiled = tmp_path / "src" / "map"
    compiled.mkdir(parents=True)
    binary = tmp_path / "bin" / "app"
    binary.parent.mkdir()
    binary.write_bytes(b"\x7fELF junk\x00" + str(compiled).encode() + b"/\x00more\x00")
    assert find_map_dir(binary) == Path(str(compiled) + "/")
    binary.write_bytes(b"\x7fELF nothing here\x00")
    with pytest.raises(MapfIrError, match="--mapf-ir-map-dir"):
        find_map_dir(binary)


def test_non_zero_exit_is_reported_with_the_tail_of_the_output(app, pareto, monkeypatch, work_tmp):
    mode(monkeypatch, "exit")
    with pytest.raises(MapfIrFailed) as err:
        MapfIrSolver(app).solve(pareto.grid, pareto.starts, pareto.goals, "CBS")
    text = str(err.value)
    assert "exited with status 3" in text and "-s CBS" in text
    assert "error@run: the stand-in was told to exit 3" in text
    kept = [p for p in work_tmp.iterdir()]
    assert len(kept) == 1 and str(kept[0]) in text and (kept[0] / "instance.txt").is_file()


def test_a_crash_is_reported_with_the_signal(app, pareto, monkeypatch):
    mode(monkeypatch, "crash")
    with pytest.raises(MapfIrFailed, match="killed by signal SIGABRT(.|\n)*start solving MAPF by CBS"):
        MapfIrSolver(app).solve(pareto.grid, pareto.starts, pareto.goals, "CBS")


def test_a_missing_output_file_is_reported(app, pareto, monkeypatch):
    mode(monkeypatch, "no-output")
    with pytest.raises(MapfIrFailed, match="wrote no output file(.|\n)*error@app: invalid results"):
        MapfIrSolver(app).solve(pareto.grid, pareto.starts, pareto.goals, "CBS")


def test_garbage_output_is_a_format_error_naming_the_output_file(app, pareto, monkeypatch):
    mode(monkeypatch, "garbage")
    with pytest.raises(SolutionFormatError) as err:
        MapfIrSolver(app).solve(pareto.grid, pareto.starts, pareto.goals, "CBS")
    assert Path(err.value.path).name == "output.txt" and Path(err.value.path).is_file()
    assert err.value.line == 2
    assert str(err.value).startswith("{}:2: ".format(err.value.path)) and "\n" not in str(err.value)


def test_a_plan_that_fails_validation_is_rejected(app, pareto, monkeypatch):
    mode(monkeypatch, "invalid")
    with pytest.raises(MapfIrFailed, match="fails validation.*jumps"):
        MapfIrSolver(app).solve(pareto.grid, pareto.starts, pareto.goals, "CBS")


def test_an_unknown_solver_name_is_an_error_not_a_silent_pibt_run(app, pareto):
    with pytest.raises(MapfIrFailed, match="does not know solver 'NOPE'"):
        MapfIrSolver(app).solve(pareto.grid, pareto.starts, pareto.goals, "NOPE")


def test_solved_0_is_no_plan(app, pareto, monkeypatch):
    mode(monkeypatch, "fail")
    result = MapfIrSolver(app).solve(pareto.grid, pareto.starts, pareto.goals, "CBS")
    assert result.plan is None and result.status == "no-solution" and "solved=0" in result.message


def test_a_hanging_mapf_ir_is_killed_after_its_limit(app, pareto, monkeypatch):
    mode(monkeypatch, "hang")
    result = MapfIrSolver(app, grace_s=0.3).solve(pareto.grid, pareto.starts, pareto.goals, "CBS",
                                                   deadline=Deadline(0.2))
    assert result.status == "timeout" and "killed" in result.message
    assert result.comp_time_ms < 5000


def test_binary_from_the_environment_and_clear_errors_when_unusable(app, pareto, tmp_path, monkeypatch):
    monkeypatch.setenv("MAPF_IR_APP", str(app))
    assert MapfIrSolver().solve(pareto.grid, pareto.starts, pareto.goals, "PIBT").solved
    monkeypatch.delenv("MAPF_IR_APP")
    with pytest.raises(MapfIrError, match="MAPF_IR_APP"):
        MapfIrSolver()
    with pytest.raises(MapfIrError, match="does not exist"):
        MapfIrSolver(tmp_path / "no" / "app")
    app.chmod(app.stat().st_mode & ~(stat.S_IXUSR | stat.S_IXGRP | stat.S_IXOTH))
    if not os.access(str(app), os.X_OK):  # root may execute anything
        with pytest.raises(MapfIrError, match="not executable"):
            MapfIrSolver(app)


def test_no_agents_needs_no_run_and_bad_problems_are_rejected_before_running(app, argv_log):
    grid = Grid.from_rows(["...", ".@."])
    result = MapfIrSolver(app).solve(grid, [], [], "PIBT")
    assert result.solved and result.plan.num_agents == 0 and not argv_log.exists()
    with pytest.raises(InvalidProblemError, match="agent 0: start \\(1, 0\\) is on a blocked cell"):
        MapfIrSolver(app).solve(grid, [(1, 0)], [(2, 1)], "PIBT")
    assert not argv_log.exists()
