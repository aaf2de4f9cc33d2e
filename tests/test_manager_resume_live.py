"""A manager killed mid-run (SIGKILL) and started again on its run folder, as real processes.

`fleetctl virtual-fleet` and `fleetctl manager --until-done --start` on the
lab plan, robot 2 stalled on purpose so that the robot behind it waits for
it; the manager is killed while it does, and `fleetctl manager --resume
RUNDIR` takes the run over. Judged by the virtual fleet's ground truth
(every robot home, no command run twice, no two robots closer than the
safe distance) and by the run folder: one folder tells the whole run, and
`fleetctl trace` reads the same summary from it as the manager printed.
"""
from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from fleet_common.lab import lab_instance_path
from fleet_common.robot_size import TURTLEBOT2
from fleet_common.runlog import read_run
from helpers import fleetctl
from live import ScriptedConsole, fleet_definitions, start_fleet, start_manager
from test_manager_run import check_trace, check_truth, goals_of, summary_value

pytestmark = pytest.mark.slow


def test_a_manager_killed_mid_run_is_started_again_on_its_folder_and_the_run_completes(tmp_path: Path) -> None:
    definitions, feedback, console_port = fleet_definitions(tmp_path, 5)
    truth, runs = tmp_path / "truth.jsonl", tmp_path / "runs"
    plan = lab_instance_path()
    fleet = start_fleet(tmp_path, definitions, feedback, "--time-scale", "5", "--truth", truth,
                        "--stall", "2:7:40")  # robot 2 halts 8 s halfway through its 7th drive
    run_args = ("--until-done", "--start", "--log", runs, "--time-limit", "240", "--step-time", "0.5")
    manager = start_manager(tmp_path, plan, definitions, console_port, *run_args)
    console = ScriptedConsole(console_port)
    again = None
    try:
        console.wait_for(lambda c: c.state and any(r.waiting is not None and 2 in r.waiting.on
                                                   for r in c.state.robots if r.id != 2)
                         and next(r for r in c.state.robots if r.id == 2).done >= 6,
                         timeout=120, why="a robot waiting for robot 2 while it stalls")
        manager.kill()
        console.close()
        folders = sorted(runs.iterdir())
        assert len(folders) == 1
        again = start_manager(tmp_path, plan, definitions, console_port, *run_args, "--resume", folders[0],
                              "--accept", name="manager-again")
        assert again.wait(240) == 0, again.text()[-4000:]
    finally:
        console.close()
        manager.stop()
        if again is not None:
            again.stop()
        fleet.stop()
    out = again.text()
    assert "resuming {}".format(folders[0]) in out
    assert "every robot stands where the run left it" in out
    assert summary_value(out, "arrived") == "5/5"
    assert summary_value(out, "collisions").startswith("0 ")
    assert summary_value(out, "resumed").startswith("1 time after its manager stopped")
    folder = Path(summary_value(out, "run folder"))
    assert folder == folders[0] and sorted(runs.iterdir()) == folders  # one folder tells the whole run
    run = read_run(folder)
    kinds = [r["k"] for r in run.records]
    assert kinds.count("run") == 1 and kinds.count("resume") == 1 and kinds[-1] == "end" and not run.torn
    resumed_at = kinds.index("resume")
    assert "action" in kinds[:resumed_at] and "action" in kinds[resumed_at:]
    times = [r["t"] for r in run.records]
    assert times == sorted(times), "the resumed manager's clock goes on from the first one's"
    nearest = check_truth(truth, goals_of(folder))  # every robot home, nothing ran twice
    assert nearest >= TURTLEBOT2.safe_cells - 0.01, "two robots came {:.2f} cells close".format(nearest)
    check_trace(folder, out)
    report = fleetctl("report", folder, "-o", tmp_path / "report.html")
    assert report.returncode == 0, report.stderr
    assert "resumed at " in (tmp_path / "report.html").read_text()


def test_a_manager_killed_on_the_way_to_the_starts_is_started_again_and_drives_the_robots_there(
        tmp_path: Path) -> None:
    """Reset mid-run opens a way to the starts (a run folder of its own); the manager is killed on
    it and `fleetctl manager PLAN --resume` (no folder) takes the way over: the robots reach their
    starts and the plan waits for Start in a new folder, as if the manager had lived."""
    definitions, feedback, console_port = fleet_definitions(tmp_path, 5)
    truth, runs = tmp_path / "truth.jsonl", tmp_path / "runs"
    plan = lab_instance_path()
    fleet = start_fleet(tmp_path, definitions, feedback, "--time-scale", "5", "--truth", truth)
    run_args = ("--log", runs, "--step-time", "0.5")
    manager = start_manager(tmp_path, plan, definitions, console_port, *run_args, "--start")
    console = ScriptedConsole(console_port)
    again = None
    try:
        console.wait_for(lambda c: c.state and sum(r.done for r in c.state.robots) >= 10, timeout=120,
                         why="ten moves done")
        assert console.ask("stop").ok
        console.wait_for(lambda c: "reset" in (c.state.run.allowed or ()), timeout=30, why="Reset allowed")
        assert console.ask("reset").ok
        console.wait_for(lambda c: c.state.run.purpose == "to-starts" and sum(r.done for r in c.state.robots) >= 2,
                         timeout=60, why="the robots on their way to the starts")
        manager.kill()
        console.close()
        folders = sorted(runs.iterdir())
        assert len(folders) == 2  # the plan's run, the way to its starts
        alone = tmp_path / "alone"  # the way's folder without the plan's beside it: said in one line
        alone.mkdir()
        shutil.copytree(folders[1], alone / folders[1].name)
        refused = fleetctl("manager", plan, "--definitions", definitions, "--log", alone, "--resume",
                           "--no-curve", "--host", "127.0.0.1", "--bind", "tcp://127.0.0.1:{}".format(console_port),
                           "--time-limit", "5")
        assert refused.returncode != 0 and "Traceback" not in refused.stderr, refused.stderr
        assert "whose run folder is not beside it" in refused.stderr.strip().splitlines()[-1], refused.stderr
        again = start_manager(tmp_path, plan, definitions, console_port, *run_args, "--resume", "--start",
                              name="manager-again")
        again.wait_line("resuming {}".format(folders[1]), 60)
        console = ScriptedConsole(console_port)
        console.wait_for(lambda c: c.state and c.state.run.purpose == "plan" and c.state.run.state == "waiting"
                         and "start" in (c.state.run.allowed or ()), timeout=120,
                         why="every robot on its start, the plan waiting for Start")
        assert len(sorted(runs.iterdir())) == 3
        assert console.ask("start").ok
        console.wait_for(lambda c: c.state.run.state == "done", timeout=120, why="the run done")
    finally:
        console.close()
        manager.stop()
        if again is not None:
            again.stop()
        fleet.stop()
    check_truth(truth, goals_of(sorted(runs.iterdir())[-1]))  # every robot home, nothing ran twice
