"""The manager reroutes a held-up robot in a real run, dies, and another takes the run over.

`fleetctl virtual-fleet` and `fleetctl manager --reroute auto --until-done
--start` on the lab plan, robot 4 stalled on purpose 8 s halfway through its
3rd drive while robot 1 waits for it: the manager looks for a reroute in its
worker thread and hands the run over while the robots drive on. Right after
the hand-over (its `plan` record in the folder) the manager is killed
(SIGKILL) with moves in flight that the reroute renumbered, and
`fleetctl manager --resume RUNDIR` takes the run over on the new plan.
Judged by the virtual fleet's ground truth (every robot home, no command run
twice, no two robots closer than the safe distance) and by the run folder:
the reroute, its plan-2.txt and the resume recorded, and `fleetctl report`
reads it, closest approach included.
"""
from __future__ import annotations

import json
import time
from pathlib import Path

import pytest

from fleet_common.lab import lab_instance_path
from fleet_common.robot_size import TURTLEBOT2
from fleet_common.runlog import read_run
from helpers import fleetctl
from live import Proc, fleet_definitions, start_fleet, start_manager
from test_manager_run import check_truth, goals_of, summary_value

pytestmark = pytest.mark.slow


def rerouted(events: Path) -> bool:
    for line in events.read_text().splitlines():
        try:
            record = json.loads(line)
        except ValueError:
            continue  # a line being written
        if record.get("k") == "plan" and record.get("reason") == "reroute":
            return True
    return False


def wait_for_reroute(runs: Path, manager: Proc, timeout: float) -> Path:
    """The run folder, once the reroute's `plan` record is in it (written through as it is made)."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        for events in runs.glob("*/events.jsonl"):
            if rerouted(events):
                return events.parent
        assert manager.popen.poll() is None, "the manager ended before a reroute:\n" + manager.text()[-3000:]
        time.sleep(0.02)
    raise AssertionError("no reroute in {:g} s:\n{}".format(timeout, manager.text()[-3000:]))


def test_a_run_rerouted_live_is_taken_over_after_a_kill_and_completes_safely(tmp_path: Path) -> None:
    definitions, feedback, console_port = fleet_definitions(tmp_path, 5)
    truth, runs = tmp_path / "truth.jsonl", tmp_path / "runs"
    plan = lab_instance_path()
    fleet = start_fleet(tmp_path, definitions, feedback, "--time-scale", "5", "--truth", truth,
                        "--stall", "4:3:40")  # robot 4 halts 8 s halfway through its 3rd drive
    run_args = ("--until-done", "--start", "--log", runs, "--time-limit", "240", "--step-time", "0.5",
                "--reroute", "auto")
    manager = start_manager(tmp_path, plan, definitions, console_port, *run_args)
    again = None
    try:
        folder = wait_for_reroute(runs, manager, 120)
        manager.kill()
        assert sorted(runs.iterdir()) == [folder]
        # no --reroute: the run goes on in the mode it had (as under its strategy)
        again = start_manager(tmp_path, plan, definitions, console_port, *run_args[:-2], "--resume", folder,
                              "--accept", name="manager-again")
        assert again.wait(240) == 0, again.text()[-4000:]
    finally:
        manager.stop()
        if again is not None:
            again.stop()
        fleet.stop()
    first, out = manager.text(), again.text()
    assert ", reroute auto;" in first.splitlines()[0] and ", reroute auto;" in out.splitlines()[0]
    run = read_run(folder)
    reroutes = list(run.of("reroute"))
    assert reroutes and reroutes[0]["text"] in first  # told on the terminal, by robot id
    assert (folder / reroutes[0]["plan"]).is_file()
    # the new manager took over on the reroute's plan, and drove on with what was in flight
    assert "resuming {}: plan-2.txt".format(folder) in out
    assert "every robot stands where the run left it" in out
    kinds = [r["k"] for r in run.records]
    handed_over, resumed = kinds.index("plan"), kinds.index("resume")
    sent = {(robot, cid) for robot, cid, kind in run.records[resumed]["sent"] if kind == "drive"}
    before = [r for r in run.records[:handed_over] if r["k"] == "command" and (r["robot"], r["id"]) in sent]
    assert before, "no move sent before the reroute was in flight at the kill: {}".format(
        json.dumps(run.records[resumed]))
    assert summary_value(out, "arrived") == "5/5"
    assert summary_value(out, "collisions").startswith("0 ")
    assert summary_value(out, "resumed").startswith("1 time after its manager stopped")
    assert sorted(runs.iterdir()) == [folder] and kinds.count("resume") == 1 and kinds[-1] == "end"
    nearest = check_truth(truth, goals_of(folder))  # every robot home, nothing ran twice, safe
    assert nearest >= TURTLEBOT2.safe_cells - 0.01, "two robots came {:.2f} cells close".format(nearest)
    report = fleetctl("report", folder, "-o", tmp_path / "report.html")
    assert report.returncode == 0, report.stderr
    html = (tmp_path / "report.html").read_text()
    # the closest approach the manager printed, read back from the folder alone; the new plan named
    assert "min distance: " + summary_value(out, "min distance") in html
    assert "reroute: {} from here on".format(reroutes[0]["plan"]) in html and "resumed at " in html
