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


def test_a_manager_runs_report_reads_in_words_with_the_consoles_colours_and_its_marks(tmp_path):
    """The report a person reads: robots in the colours the live console gives them, the events
    in words (cells as the plan file writes them) in a table filterable by robot and kind, the
    operator's actions and the replans marked on the timelines, and a legend for what is drawn."""
    from console.live.scene import scene_from_manager
    from evaluation.report.html import render
    from fleet_common.control import PlanData, RobotInfo, RunSetup
    from fleet_common.formats.instance import read_instance
    from fleet_common.formats.solution import format_solution, make_solution
    from fleet_common.lab import lab_instance_path
    from fleet_common.plan import Plan

    inst = read_instance(str(lab_instance_path()))
    plan = Plan.from_paths([[inst.starts[i], inst.starts[i]] for i in range(2)])
    (tmp_path / "plan-1.txt").write_text(format_solution(make_solution(
        inst.grid, "lab.map", plan, inst.starts[:2], inst.starts[:2], "hand", True, 0)))
    (tmp_path / "robot_definitions.txt").write_text("1 127.0.0.1 9001 u tb1 red\n2 127.0.0.1 9002 u tb2 dodgerblue\n")
    log, at = manager_log(tmp_path, [1, 2], [[1, 8], [11, 5]])
    at(0.0, "state", run="running")
    at(1.0, "operator", console="console@lab", action="disable", args={"robot": 2}, ok=True, reason="")
    at(1.0, "out", robot=2, why="disabled", reason="disabled by operator")
    at(1.5, "operator", console="console@lab", action="start", args={}, ok=False, reason="already running")
    at(2.0, "plan", file="plan-2.txt", robots=[1, 2], reason="replan", at=None, actions=[1, 0], starts=[[1, 8], [11, 5]])
    at(2.5, "action", robot=1, index=0, phase="started", src=[1, 8], dst=[2, 8])
    at(4.0, "action", robot=1, index=0, phase="completed", src=[1, 8], dst=[2, 8])
    at(4.0, "state", run="done")
    log.close()
    run = read_run(tmp_path)
    page = run_page(run)
    gantt = charts_of(page)["gantt"]
    assert (1.0, 2, "disable robot 2") in gantt.data["marks"] and (2.0, None, "replan") in gantt.data["marks"]
    assert all(m[2] != "start refused" for m in gantt.data["marks"])  # a refusal changed nothing
    assert "blue marks: the operator's actions" in gantt.caption and "a replan" in gantt.caption
    assert "stalled" not in gantt.caption  # the legend says what is drawn, no more
    progress = charts_of(page)["progress"]
    assert "dashed" not in progress.caption  # no step time in this log: no schedule drawn, none named
    setup = RunSetup("lab", tuple("." * 13 for _ in range(14)),
                     (RobotInfo(1, "red", "tb1"), RobotInfo(2, "dodgerblue", "tb2")),
                     PlanData(1, (1, 2), plan.positions), ("adg",), 2.0)
    from evaluation.report.run import robot_colours
    assert list(robot_colours(run).values()) == scene_from_manager(setup, "e").colours
    text = render(page)
    assert 'id="events-word"' in text and '<tr data-robot="2" data-kind="operator" class="operator">' in text
    assert "console@lab: disable robot 2" in text and "console@lab: start refused: already running" in text
    assert 'class="replan"' in text and "replan: plan-2.txt from here on" in text
    # the lab instance writes rows from the top: base (2, 8) is (2, 5) in the file
    assert "robot 1 ends move 1 from (1, 5) to (2, 5)" in text
    assert '{"' not in text.split("<h2>Events</h2>")[1]  # words, not raw JSON


def test_a_schedule_is_drawn_for_a_manager_run_that_says_its_step_time(tmp_path):
    from fleet_common.runlog.writer import RunLog

    log = RunLog(tmp_path, clock=lambda: 0.0)
    log.run_started(source="manager", time_unit="s", plan="plan-1.txt", robots=[1], strategy="adg",
                    actions=[1], starts=[[0, 0]], step_time=2.0)
    log.record("state", run="running")
    log.record("dispatch", robot=1, index=0, step=0, src=[0, 0], dst=[1, 0], waited=0.0)
    log.record("action", robot=1, index=0, phase="completed", src=[0, 0], dst=[1, 0])
    log.close()
    progress = charts_of(run_page(read_run(tmp_path)))["progress"]
    assert "dashed: on schedule (a plan step every 2 s, from Start)" in progress.caption
