"""The manager's main job, as lab staff run it: real processes on 127.0.0.1, judged by the ground truth.

`fleetctl virtual-fleet` (with slow moves, stalls and dropouts) and `fleetctl
manager --until-done` on the lab plan and on a 50-robot plan from the shipped
data, under each strategy and with switches mid-run. What is checked is what
the virtual fleet says really happened (its --truth file): every robot at its
goal, no two robots' centres closer than the safe distance at any time (the
robots' real size, judged in continuous time by `approach.judge`), no command
id started twice; and the manager's own summary.
"""
from __future__ import annotations

import json
import math
import re
from datetime import datetime
from pathlib import Path
from typing import Dict, List, Tuple

import pytest

from fleet_common.lab import lab_instance_path
from fleet_common.runlog import read_run
from fleet_common.formats.mapsearch import default_map_dirs
from fleet_common.formats.solution import read_solution
from helpers import fleetctl
from live import ScriptedConsole, fleet_definitions, start_fleet, start_manager
from fleet_common.execution.approach import judge
from fleet_common.robot_size import TURTLEBOT2
from virtual_fleet.truth import exec_lines, truth_paths

pytestmark = pytest.mark.slow

DELAYS = "delay=0.3,slow=0.15:2,stall=0.05:2,dropout=0.02:2"


def truth_poses(path: Path) -> List[Dict[int, Tuple[float, float]]]:
    out = []
    for line in path.read_text().splitlines():
        try:
            record = json.loads(line)
        except ValueError:
            continue
        if record.get("k") == "poses":
            out.append({r: (x, y) for r, x, y, _ in record["p"]})
    return out


def check_truth(truth: Path, goals: Dict[int, Tuple[int, int]]) -> float:
    """Every robot ends on its goal, nothing ran twice, no two robots closer than the safe
    distance; the closest approach (cells)."""
    poses = truth_poses(truth)
    assert poses, "no ground truth recorded"
    paths = truth_paths(truth)
    verdict = judge([paths[r] for r in sorted(paths)], TURTLEBOT2.safe_cells)
    assert verdict.safe_run, "robots closer than the safe distance: {}".format(verdict.violations[:3])
    final = poses[-1]
    for robot, goal in goals.items():
        x, y = final[robot]
        assert math.hypot(x - goal[0], y - goal[1]) < 0.05, "robot {} ended at {}, goal {}".format(
            robot, (x, y), goal)
    runs = [(e["robot"], e["epoch"], e["id"]) for e in exec_lines(truth)]
    assert len(runs) == len(set(runs)), "a command id was started twice: {}".format(
        sorted({r for r in runs if runs.count(r) > 1}))
    return verdict.closest.distance if verdict.closest is not None else 1.0


def goals_of(run_folder: Path) -> Dict[int, Tuple[int, int]]:
    run = read_run(run_folder)
    return {r: tuple(g) for r, g in zip(run.robots, run.run["goals"])}


def summary_value(text: str, key: str) -> str:
    m = re.search(r"^{}: (.*)$".format(re.escape(key)), text, re.M)
    assert m, "no '{}' line in:\n{}".format(key, text[-3000:])
    return m.group(1)


def run_plan(tmp_path: Path, plan: Path, robots: int, strategy: str, switch: bool,
             time_scale: str, instance: Path) -> None:
    definitions, feedback, console_port = fleet_definitions(tmp_path, robots)
    truth = tmp_path / "truth.jsonl"
    fleet = start_fleet(tmp_path, definitions, feedback, "--time-scale", time_scale, "--instance",
                        instance, "--delay-model", DELAYS, "--seed", "7", "--truth", truth)
    extra = ["--until-done", "--log", tmp_path / "runs", "--time-limit", "240",
             "--strategy", strategy, "--step-time", str(2.5 / float(time_scale))]
    manager = start_manager(tmp_path, plan, definitions, console_port,
                            *(extra if switch else extra + ["--start"]))
    console = None
    try:
        if switch:  # a console starts the run, then switches strategies twice mid-run
            console = ScriptedConsole(console_port)
            console.wait_for(lambda c: c.state and all(r.link == "up" and r.age is not None
                                                       for r in c.state.robots),
                             why="every robot connected and seen")
            assert console.ask("start").ok
            total = sum(r.total for r in console.state.robots)
            for name, share in (("step", 0.25), ("adg", 0.6)):
                console.wait_for(lambda c: sum(r.done for r in c.state.robots) >= share * total,
                                 timeout=120, why="{:.0%} of the moves done".format(share))
                answer = console.ask("strategy", name=name)
                assert answer.ok, answer.reason
                assert console.wait_for(lambda c: c.state.run.strategy == name)
        assert manager.wait(300) == 0, manager.text()[-4000:]
    finally:
        if console is not None:
            console.close()
        manager.stop()
        fleet.stop()
    out = manager.text()
    assert summary_value(out, "arrived") == "{}/{}".format(robots, robots)
    assert summary_value(out, "collisions").split()[0] == "0"
    folder = Path(summary_value(out, "run folder"))
    check_truth(truth, goals_of(folder))
    check_clock(folder, truth)
    strategies = [r["name"] for r in read_run(folder).of("strategy")]
    assert strategies == (["step", "adg"] if switch else [])
    check_trace(folder, out)


def check_clock(folder: Path, truth: Path) -> None:
    """The run log's times, put on the wall clock by its `run` record (`started` is the wall
    clock at that record's t), line up with the robots': no robot started a command before the
    manager sent it (to the milliseconds of the rounding)."""
    run = read_run(folder)
    zero = datetime.fromisoformat(run.run["started"]).timestamp() - run.run["t"]
    began = {}
    for e in exec_lines(truth):
        began.setdefault((e["robot"], e["id"]), e["t"])
    early = [(r["robot"], r["id"], round(zero + r["t"] - began[(r["robot"], r["id"])], 4))
             for r in run.of("command") if (r["robot"], r["id"]) in began
             and began[(r["robot"], r["id"])] < zero + r["t"] - 0.002]
    assert not early, "robots started commands before they were sent, by the run log's clock: " \
        "(robot, id, seconds) {}".format(early[:5])


def check_trace(folder: Path, manager_output: str) -> None:
    """`fleetctl trace` says what the manager said, from the log alone, and writes a plan that
    the validator accepts, ending on the goals."""
    traced = fleetctl("trace", folder)
    assert traced.returncode == 0, traced.stderr
    for key in ("arrived", "executed makespan", "sum of costs", "total wait", "collisions",
                "min distance"):
        assert summary_value(traced.stdout, key) == summary_value(manager_output, key)
    checked = fleetctl("validate", folder / "executed.txt")
    assert checked.returncode == 0, checked.stdout + checked.stderr
    executed = read_solution(str(folder / "executed.txt"), map_dirs=default_map_dirs())
    goals = goals_of(folder)
    assert [tuple(c) for c in executed.plan.positions[-1]] == [goals[r] for r in read_run(folder).robots]


@pytest.mark.parametrize("strategy,switch", [("adg", False), ("step", False), ("adg", True)])
def test_the_lab_plan_runs_on_a_delayed_virtual_fleet(tmp_path: Path, strategy: str,
                                                      switch: bool) -> None:
    run_plan(tmp_path, lab_instance_path(), 5, strategy, switch, "8", lab_instance_path())


@pytest.mark.parametrize("strategy,switch", [("adg", False), ("step", False), ("adg", True)])
def test_fifty_robots_from_the_shipped_data(tmp_path: Path, shared_data: Path, strategy: str,
                                            switch: bool) -> None:
    instance = shared_data / "instances" / "random-32-32-10_50agents_1.txt"
    run_plan(tmp_path, instance, 50, strategy, switch, "25", instance)


def test_the_run_survives_the_fleet_process_being_killed(tmp_path: Path) -> None:
    """SIGKILL mid-run (a power cut of every robot), then the fleet starts again: robots come
    back where they stood, the manager finds out where each is, and the run completes."""
    definitions, feedback, console_port = fleet_definitions(tmp_path, 5)
    truth, state = tmp_path / "truth.jsonl", tmp_path / "state.json"
    plan = lab_instance_path()
    args = ("--time-scale", "5", "--truth", truth, "--state", state)
    fleet = start_fleet(tmp_path, definitions, feedback, *args)
    manager = start_manager(tmp_path, plan, definitions, console_port, "--until-done", "--start",
                            "--log", tmp_path / "runs", "--time-limit", "240", "--step-time", "0.5")
    console = ScriptedConsole(console_port)
    try:
        console.wait_for(lambda c: c.state and sum(r.done for r in c.state.robots) >= 15,
                         why="15 moves done")
        fleet.kill()
        console.wait_for(lambda c: all(r.link != "up" for r in c.state.robots),
                         why="every link down after the kill")
        fleet = start_fleet(tmp_path, definitions, feedback, *args, name="fleet-again")
        assert manager.wait(240) == 0, manager.text()[-4000:]
    finally:
        console.close()
        manager.stop()
        fleet.stop()
    out = manager.text()
    assert summary_value(out, "arrived") == "5/5"
    assert summary_value(out, "collisions").split()[0] == "0"
    assert "restarted" in out
    folder = Path(summary_value(out, "run folder"))
    check_truth(truth, goals_of(folder))
    starts = [json.loads(line) for line in truth.read_text().splitlines() if '"k":"start"' in line]
    assert [s["resumed"] for s in starts] == [False, True]
