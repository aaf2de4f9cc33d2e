"""The way home through the real chain: `fleetctl virtual-fleet` and `fleetctl manager`, a console
over a real socket.

Robot 3 is disabled mid-run (it finishes its move), a replan takes the others home around it,
and robot 3 is enabled again while they drive: the manager gives it a way to its goal around
them at once and the run ends with every robot home, judged by the virtual fleet's ground truth
(no two centres closer than the safe distance, nothing run twice).
"""
from __future__ import annotations

from pathlib import Path

import pytest

from fleet_common.lab import lab_instance_path
from live import ScriptedConsole, fleet_definitions, start_fleet, start_manager
from test_manager_run import check_truth, goals_of, summary_value

pytestmark = pytest.mark.slow


def robot(console: ScriptedConsole, rid: int):
    return next(r for r in console.state.robots if r.id == rid)


def test_a_robot_enabled_again_after_a_replan_drives_home_while_the_others_go_on(tmp_path: Path) -> None:
    definitions, feedback, console_port = fleet_definitions(tmp_path, 5)
    truth, runs = tmp_path / "truth.jsonl", tmp_path / "runs"
    fleet = start_fleet(tmp_path, definitions, feedback, "--time-scale", "4", "--truth", truth)
    manager = start_manager(tmp_path, lab_instance_path(), definitions, console_port, "--until-done", "--start",
                            "--log", runs, "--time-limit", "240", "--step-time", "0.5")
    console = ScriptedConsole(console_port)
    try:
        console.wait_for(lambda c: c.state and robot(c, 3).done >= 2, timeout=60, why="robot 3 two moves on")
        assert console.ask("disable", robot=3).ok
        console.wait_for(lambda c: robot(c, 3).activity is None, timeout=20, why="robot 3 standing")
        console.pump(0.5)  # its pose, standing
        assert console.ask("replan").ok
        pid = console.wait_for(lambda c: c.state.run.proposal, timeout=30, why="the replan's proposal")
        assert console.ask("accept", proposal=pid).ok
        console.wait_for(lambda c: c.state.run.state == "running", timeout=10, why="the run going on")
        answer = console.ask("enable", robot=3)
        assert answer.ok and "robot 3 drives to its goal" in answer.reason, answer.reason
        assert manager.wait(240) == 0, manager.text()[-3000:]
    finally:
        console.close()
        manager.stop()
        fleet.stop()
    out = manager.text()
    assert summary_value(out, "arrived") == "5/5"
    assert summary_value(out, "collisions").startswith("0 ")
    check_truth(truth, goals_of(sorted(runs.iterdir())[-1]))  # every robot home, nothing ran twice
