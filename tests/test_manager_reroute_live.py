"""The manager reroutes a held-up robot in a real run: `fleetctl virtual-fleet` + `fleetctl manager`.

The lab plan, robot 4 stalled on purpose 8 s halfway through its 3rd drive
while robot 1 waits for it; `fleetctl manager --reroute auto --until-done
--start` looks for a reroute in its worker thread and hands the run over
while the robots drive on. Judged by the virtual fleet's ground truth (every
robot home, no command run twice, no two robots closer than the safe
distance) and by the run folder: the reroute and its plan-2.txt recorded,
and `fleetctl report` reads it, closest approach included.
"""
from __future__ import annotations

from pathlib import Path

import pytest

from fleet_common.lab import lab_instance_path
from fleet_common.robot_size import TURTLEBOT2
from fleet_common.runlog import read_run
from helpers import fleetctl
from live import fleet_definitions, start_fleet, start_manager
from test_manager_run import check_truth, goals_of, summary_value

pytestmark = pytest.mark.slow


def test_a_run_with_a_stalled_robot_is_rerouted_live_and_completes_safely(tmp_path: Path) -> None:
    definitions, feedback, console_port = fleet_definitions(tmp_path, 5)
    truth, runs = tmp_path / "truth.jsonl", tmp_path / "runs"
    fleet = start_fleet(tmp_path, definitions, feedback, "--time-scale", "5", "--truth", truth,
                        "--stall", "4:3:40")  # robot 4 halts 8 s halfway through its 3rd drive
    manager = start_manager(tmp_path, lab_instance_path(), definitions, console_port, "--until-done", "--start",
                            "--log", runs, "--time-limit", "240", "--step-time", "0.5", "--reroute", "auto")
    try:
        assert manager.wait(240) == 0, manager.text()[-4000:]
    finally:
        manager.stop()
        fleet.stop()
    out = manager.text()
    assert ", reroute auto;" in out.splitlines()[0]
    assert summary_value(out, "arrived") == "5/5"
    assert summary_value(out, "collisions").startswith("0 ")
    folder = Path(summary_value(out, "run folder"))
    run = read_run(folder)
    assert run.run["reroute"] == "auto"
    reroutes = list(run.of("reroute"))
    assert reroutes, "no reroute in {}".format(folder)
    assert any(r["text"] in out for r in reroutes)  # told on the terminal, by robot id
    assert (folder / reroutes[0]["plan"]).is_file()
    nearest = check_truth(truth, goals_of(folder))  # every robot home, nothing ran twice, safe
    assert nearest >= TURTLEBOT2.safe_cells - 0.01, "two robots came {:.2f} cells close".format(nearest)
    report = fleetctl("report", folder, "-o", tmp_path / "report.html")
    assert report.returncode == 0, report.stderr
    html = (tmp_path / "report.html").read_text()
    # the closest approach the manager printed, read back from the folder alone; the new plan named
    assert "min distance: " + summary_value(out, "min distance") in html
    assert "reroute: {} from here on".format(reroutes[0]["plan"]) in html
    resumed = fleetctl("manager", "--resume", folder, "--no-curve", "--no-log", "--definitions", definitions)
    assert resumed.returncode == 2
    assert resumed.stderr.strip().startswith("fleetctl manager: cannot resume {}: the run was rerouted".format(
        folder)), resumed.stderr
