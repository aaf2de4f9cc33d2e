"""`fleetctl report`: the plots of a tiny sweep and of a tiny run, checked by the numbers they show,
in one HTML file that needs no network."""
from __future__ import annotations

import base64
import json
import re
from pathlib import Path

import numpy as np
import pytest

from evaluation.report.run import run_page
from evaluation.report.sweep import sweep_page
from evaluation.spec import read_experiment
from evaluation.sweep import run_sweep
from fleet_common.runlog import read_run
from helpers import fleetctl

SPEC = """\
plans: [{instance: lab, solver: cbs}]
strategies: [adg, step]
delays: ["events=bernoulli:{p}:1-3"]
p: [0, 0.3]
seeds: 3
disable: [none, "1@3"]
recover: [none, replan]
"""


def charts_of(page):
    return {c.name: c for c in page.charts}


def assert_self_contained(html: Path, count: int) -> None:
    text = html.read_text(encoding="utf-8")
    assert not re.search(r"https?://", text)  # opens without network: nothing to fetch
    images = re.findall(r'<img alt="[^"]*" src="data:image/png;base64,([A-Za-z0-9+/=]+)">', text)
    assert len(images) == count and text.count("<img") == count
    beside = sorted(html.parent.glob(html.stem + "-*.png"))
    assert len(beside) == count
    assert sorted(base64.b64decode(i) for i in images) == sorted(p.read_bytes() for p in beside)
    assert all(p.read_bytes().startswith(b"\x89PNG\r\n\x1a\n") for p in beside)


@pytest.fixture(scope="module")
def sweep(tmp_path_factory):
    folder = tmp_path_factory.mktemp("sweep")
    (folder / "tiny.yaml").write_text(SPEC)
    return folder, run_sweep(read_experiment(folder / "tiny.yaml"), folder / "out", jobs=1, progress=None).rows


def test_the_sweep_report_plots_the_table(sweep):
    _, rows = sweep
    charts = charts_of(sweep_page(rows, "tiny"))
    assert set(charts) == {"makespan_ratio", "wait_per_robot", "distribution", "disabled"}
    ratio = charts["makespan_ratio"].data["lab-cbs"]
    assert set(ratio) == {"adg", "step"}
    for strategy, series in ratio.items():
        assert series["p"] == [0, 0.3] and series["n"] == [3, 3]
        for p, mean in zip(series["p"], series["mean"]):
            mine = [r["makespan_ratio"] for r in rows if r["strategy"] == strategy and r["p"] == p
                    and r["disable"] == "none"]
            assert mean == pytest.approx(np.mean(mine))
    assert ratio["adg"]["mean"][0] == pytest.approx(1.0)  # no delay: the ADG keeps the plan's makespan
    assert ratio["adg"]["ci"][0] == pytest.approx(0.0)
    assert all(a <= s for a, s in zip(ratio["adg"]["mean"], ratio["step"]["mean"]))
    waits = charts["wait_per_robot"].data["lab-cbs"]
    assert len(waits["adg"]) == 5 and waits["adg"] == pytest.approx(
        np.mean([json.loads(r["wait_by_robot"]) for r in rows if r["strategy"] == "adg" and r["disable"] == "none"],
                axis=0).tolist())
    assert sum(len(v) for v in charts["distribution"].data["lab-cbs"].values()) == 12
    disabled = charts["disabled"].data
    assert disabled["lab-cbs adg replan"]["reached"] == pytest.approx(4 / 5)
    assert disabled["lab-cbs adg none"]["reached"] < 4 / 5


def test_fleetctl_report_of_a_sweep_is_one_html_file_with_its_pngs_beside_it(sweep, tmp_path):
    folder, _ = sweep
    for source in (folder / "out", folder / "out" / "results.parquet", folder / "out" / "results.csv"):
        html = tmp_path / source.name / "report.html"
        proc = fleetctl("report", source, "-o", html)
        assert proc.returncode == 0, proc.stderr
        assert_self_contained(html, 4)
        assert "<th>makespan ratio</th>" in html.read_text()


@pytest.fixture(scope="module")
def run_folder(tmp_path_factory, repo_root):
    folder = tmp_path_factory.mktemp("run")
    plan = folder / "lab.txt"
    assert fleetctl("solve", repo_root / "catkin_ws/src/fleet_common/src/fleet_common/lab/lab_instance.txt",
                    "-s", "cbs", "-o", plan).returncode == 0
    # the lab plan runs on the lab fleet, where --disable names robot 3 by its id: agent 2 in the run folder
    proc = fleetctl("simulate", plan, "--delay-model", "events=bernoulli:1:2-2", "--disable", "3@3",
                    "--log", folder / "runs")
    assert proc.returncode == 1 and "run log: " in proc.stdout  # robot 2 out: someone cannot arrive
    (run,) = list((folder / "runs").iterdir())
    return run


def test_a_simulated_run_folder_follows_the_run_log_schema(run_folder):
    run = read_run(run_folder)
    assert run.run["source"] == "simulate" and run.time_unit == "step" and run.robots == [0, 1, 2, 3, 4]
    assert run.ended and (run_folder / "plan-1.txt").is_file() and not any(run.of("command"))
    end = run.last("end")
    poses = list(run.of("poses"))
    assert len(poses) >= 10 * end["t"]  # at least 10 samples a plan step
    assert {p[4] for rec in poses for p in rec["p"]} == {"robot"}
    assert [r["robot"] for r in run.of("out")] == [2] and any(run.of("waits"))
    # the manager's own reading of run folders (`fleetctl trace`) finds the simulator's figures
    traced = fleetctl("trace", run_folder, "-o", run_folder.parent / "executed.txt")
    assert "total wait: {:.2f} steps".format(end["summary"]["wait_time"]) in traced.stdout, traced.stdout
    assert "collisions: 0" in traced.stdout


def test_the_run_report_shows_what_each_robot_did(run_folder):
    run = read_run(run_folder)
    charts = charts_of(run_page(run))
    assert set(charts) == {"gantt", "progress", "deviation"}
    gantt = charts["gantt"].data
    completed = [r for r in run.of("action") if r["phase"] == "completed"]
    for robot in run.robots:
        moves = [(s, e) for s, e in gantt[robot].get("moving", [])]
        assert len(moves) == sum(1 for r in completed if r["robot"] == robot)
        assert all(e - s == pytest.approx(1.0) for s, e in moves)  # no slow moves in this model
        # every move waited 2 steps first (a delay event with p=1), shown as delayed
        assert [round(e - s, 6) for s, e in gantt[robot].get("delayed", [])] == [2.0] * len(moves)
    (out,) = run.of("out")
    assert gantt[2]["disabled"] == [(out["t"], run.last("end")["t"])]
    waited = [w for r in run.robots for w in gantt[r].get("waiting", [])]
    assert waited and any(2 in on for _, _, on in waited)  # someone waits on the disabled robot
    progress = charts["progress"].data
    steps = {(d["robot"], d["index"]): d["step"] for d in run.of("dispatch")}
    for robot in run.robots:
        last = [r for r in completed if r["robot"] == robot][-1]
        assert progress[robot]["executed"][-1] == (last["t"], steps[(robot, last["index"])] + 1)
    deviation = charts["deviation"].data
    assert set(deviation) == {"robot"} and max(max(s["dev"]) for s in deviation["robot"].values()) < 1e-6


def test_the_deviation_of_vicon_poses_from_the_plan_is_measured(run_folder, tmp_path):
    copy = tmp_path / "run"
    copy.mkdir()
    for f in run_folder.iterdir():
        (copy / f.name).write_bytes(f.read_bytes())
    run = read_run(copy)
    first = next(r for r in run.of("action") if r["robot"] == 0 and r["phase"] == "completed")
    x, y = first["dst"]
    lines = (copy / "events.jsonl").read_text().splitlines()
    at = next(i for i, ln in enumerate(lines) if json.loads(ln) == first)
    vicon = {"t": first["t"], "k": "poses", "p": [[0, x + 0.3, y - 0.4, 0.0, "vicon", 0.02]]}
    lines.insert(at + 1, json.dumps(vicon))
    (copy / "events.jsonl").write_text("\n".join(lines) + "\n")
    deviation = charts_of(run_page(read_run(copy)))["deviation"].data
    assert deviation["vicon"][0] == {"t": [first["t"]], "dev": [pytest.approx(0.5)]}


def test_fleetctl_report_of_a_run_folder_and_its_errors(run_folder, tmp_path):
    html = tmp_path / "run.html"
    proc = fleetctl("report", run_folder, "-o", html)
    assert proc.returncode == 0, proc.stderr
    assert_self_contained(html, 3)
    assert "robot 2" in html.read_text() and "disabled" in html.read_text()
    empty = tmp_path / "empty"
    empty.mkdir()
    bad = fleetctl("report", empty, "-o", tmp_path / "x.html")
    assert bad.returncode == 2 and bad.stderr.strip() == (
        "fleetctl report: {}: neither a run folder (events.jsonl) nor a sweep's folder (results.csv)".format(empty))


def manager_log(folder, robots, starts):
    """A manager's run log written by hand: the log, and `at(t, kind, **fields)` to add to it."""
    from fleet_common.runlog.writer import RunLog

    now = [100.0]
    log = RunLog(folder, clock=lambda: now[0])
    log.run_started(source="manager", time_unit="s", plan="plan-1.txt", robots=robots,
                    strategy="adg", actions=[1] * len(robots), starts=starts)

    def at(t: float, kind: str, **fields) -> None:
        now[0] = 100.0 + t
        log.record(kind, **fields)
    return log, at


def test_robots_waiting_for_start_are_not_drawn_as_waiting_for_each_other(tmp_path):
    """A manager's run waits for an operator's Start; the chart's waits are waits on robots."""
    log, at = manager_log(tmp_path, [1, 2], [[0, 0], [1, 1]])
    at(0.0, "state", run="waiting")
    at(0.1, "waits", w=[[1, [], None, "waiting for Start"], [2, [], None, "waiting for Start"]])
    at(5.0, "state", run="running")
    at(5.0, "waits", w=[[2, [1], [0, 1], "its next cell"]])
    at(5.1, "action", robot=1, index=0, phase="started", src=[0, 0], dst=[0, 1])
    at(7.0, "action", robot=1, index=0, phase="completed", src=[0, 0], dst=[0, 1])
    at(7.0, "waits", w=[])
    at(9.0, "state", run="done")
    log.close()
    gantt = charts_of(run_page(read_run(tmp_path)))["gantt"].data
    assert gantt[2]["waiting"] == [(5.0, 7.0, [1])]
    assert "waiting" not in gantt[1]


def test_a_robot_stuck_in_its_move_is_drawn_stalled_and_a_turning_one_is_not(tmp_path):
    """The demo's stalled robot: its move goes on, its pose does not (others wait on it)."""
    log, at = manager_log(tmp_path, [1, 2], [[0, 0], [3, 3]])

    at(0.0, "state", run="running")
    at(0.0, "action", robot=1, index=0, phase="started", src=[0, 0], dst=[1, 0])
    at(0.0, "action", robot=2, index=0, phase="started", src=[3, 3], dst=[3, 4])
    for i in range(61):  # 6 s of poses at 10 Hz
        t = i / 10
        x = min(t, 1.0) * 0.5 if t < 4.0 else 0.5 + (t - 4.0) / 4  # robot 1: still from 1 s to 4 s
        heading = min(t, 3.0) * 0.5  # robot 2 turns on the spot for 3 s, then drives
        y = 3.0 if t < 3.0 else 3.0 + (t - 3.0) / 3
        at(t, "poses", p=[[1, round(x, 3), 0.0, 0.0, "robot", 0.0],
                          [2, 3.0, round(y, 3), round(heading, 3), "robot", 0.0]])
    at(6.0, "action", robot=1, index=0, phase="completed", src=[0, 0], dst=[1, 0])
    at(6.0, "action", robot=2, index=0, phase="completed", src=[3, 3], dst=[3, 4])
    at(6.0, "state", run="done")
    log.close()
    gantt = charts_of(run_page(read_run(tmp_path)))["gantt"].data
    [(since, until)] = gantt[1]["stalled"]
    assert since == pytest.approx(1.0) and until == pytest.approx(4.0)
    assert gantt[1]["moving"] == [(0.0, 6.0)]  # the move is still one move
    assert "stalled" not in gantt[2]
