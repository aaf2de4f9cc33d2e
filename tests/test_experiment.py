"""`fleetctl experiment`: sweeps that repeat, resume, and give the same table on a Dask cluster.

Tiny sweeps (the lab plan solved by CBS, a 2-agent mapf-IR plan; both
strategies; two delay probabilities; a disabled robot with and without
replanning), run as a user runs them, in real processes.
"""
from __future__ import annotations

import csv
import io
import json
from pathlib import Path

import pytest

from evaluation.spec import read_experiment
from evaluation.sweep import run_sweep
from evaluation.table import read_table
from helpers import fleetctl

SPEC = """\
name: tiny
plans:
  - instance: lab
    solver: cbs
  - solution: {shared}/solutions/cbs_makespan-soc-pareto.txt
strategies: [adg, step]
delays: ["events=bernoulli:{{p}}:1-3", btpg]
p: [0, 0.3]
seeds: 2
disable: [none, "1@3"]
recover: [none, replan]
"""


@pytest.fixture
def spec(tmp_path, shared_data) -> Path:
    path = tmp_path / "tiny.yaml"
    path.write_text(SPEC.format(shared=shared_data))
    return path


def without_wall_time(rows):
    return [{k: v for k, v in r.items() if k != "wall_s"} for r in rows]


def test_the_spec_expands_to_every_combination(spec):
    exp = read_experiment(spec)
    # 2 plans x 2 strategies x (2 p + btpg) x 2 seeds x (none + 1@3 x {none, replan})
    assert len(exp.cells) == 2 * 2 * 3 * 2 * 3
    assert len({c.key for c in exp.cells}) == len(exp.cells)
    assert {c.delay for c in exp.cells} == {"events=bernoulli:0:1-3", "events=bernoulli:0.3:1-3", "btpg"}


def test_a_seeded_sweep_gives_the_same_table_twice_in_csv_and_parquet(spec, tmp_path):
    one = fleetctl("experiment", spec, "-o", tmp_path / "one")
    two = fleetctl("experiment", spec, "-o", tmp_path / "two", "--jobs", "1")
    assert one.returncode == 0 and two.returncode == 0, one.stderr + two.stderr
    assert "tiny: 72 cells (72 run now, 0 already done)" in one.stdout and "collisions: 0 in 72 runs" in one.stdout
    assert "tiny [##############################] 72/72 cells" in one.stderr  # the progress bar
    rows = read_table(tmp_path / "one" / "results.csv")
    assert without_wall_time(rows) == without_wall_time(read_table(tmp_path / "two" / "results.csv"))
    assert without_wall_time(rows) == without_wall_time(read_table(tmp_path / "one" / "results.parquet"))
    by = {(r["plan"], r["strategy"], r["delay"], r["seed"], r["disable"], r["recover"]): r for r in rows}
    # the strategies of one seed meet the same delays: the ADG is never slower than the time step
    for (plan, strategy, delay, seed, disable, recover), r in by.items():
        if strategy == "adg" and disable == "none":
            assert r["makespan"] <= by[(plan, "step", delay, seed, disable, recover)]["makespan"] + 1e-9
    clean = by[("lab-cbs", "adg", "events=bernoulli:0:1-3", 0, "none", "none")]
    assert clean["collisions"] == 0 and clean["finished"] and clean["makespan"] == clean["plan_makespan"] == 19
    assert len(json.loads(clean["wait_by_robot"])) == 5 == clean["agents"]
    # robot 1 of the lab out at step 3: someone is stuck behind it; replanning brings the others home
    stuck = by[("lab-cbs", "adg", "events=bernoulli:0:1-3", 0, "1@3", "none")]
    saved = by[("lab-cbs", "adg", "events=bernoulli:0:1-3", 0, "1@3", "replan")]
    assert not stuck["finished"] and stuck["reached"] < 4
    assert saved["replanned"] and saved["reached"] == 4 and saved["collisions"] == 0


def test_a_resumed_sweep_runs_only_what_is_missing(spec, tmp_path):
    out = tmp_path / "out"
    exp = read_experiment(spec)
    full = run_sweep(exp, out, jobs=1, progress=None)
    lines = (out / "results.csv").read_text().splitlines(keepends=True)
    (out / "results.csv").write_text("".join(lines[:31]) + lines[31][:40])  # 30 rows and a torn one
    again = run_sweep(exp, out, jobs=2, progress=None)
    assert (again.ran, again.resumed) == (42, 30)
    assert without_wall_time(again.rows) == without_wall_time(full.rows)
    assert [r["wall_s"] for r in again.rows[:30]] == [r["wall_s"] for r in full.rows[:30]]  # not run again
    done = fleetctl("experiment", spec, "-o", out)
    assert "72 cells (0 run now, 72 already done)" in done.stdout


def test_the_dask_path_gives_the_same_table_as_the_local_one(spec, tmp_path):
    from dask.distributed import LocalCluster

    local = run_sweep(read_experiment(spec), tmp_path / "local", jobs=1, progress=None)
    cluster = LocalCluster(n_workers=2, threads_per_worker=1, processes=False, protocol="tcp://", host="127.0.0.1",
                           scheduler_port=0, dashboard_address=None)
    try:
        proc = fleetctl("experiment", spec, "-o", tmp_path / "dask", "--scheduler", cluster.scheduler_address)
    finally:
        cluster.close()
    assert proc.returncode == 0, proc.stderr
    assert "on 2 worker(s)" in proc.stdout
    assert without_wall_time(read_table(tmp_path / "dask")) == without_wall_time(local.rows)


@pytest.mark.parametrize("text, message", [
    ("plans: []\nstrategies: [adg]\nseeds: 1\n", ":1:8: plans: expected a non-empty list"),
    ("plans: [{instance: lab, solver: fastest}]\nstrategies: [adg]\nseeds: 1\n",
     ":1:9: plans[0]: solver: expected one of pibt, lacam, cbs, ecbs, pp, pibt-turns, got 'fastest'"),
    ("plans: [{instance: lab, solver: cbs}]\nstrategies: [adg, warp]\nseeds: 1\n",
     ":2:13: strategies: expected strategies from "),
    ("plans: [{instance: lab, solver: cbs}]\nstrategies: [adg]\nseeds: 1\ndelays: [\"stall=2:1\"]\n",
     ":4:9: delays: delay model 'stall=2:1': stall=2:1: expected stall=P:S with P a probability 0..1"),
    ("plans: [{instance: lab, solver: cbs}]\nstrategies: [adg]\nseeds: -1\n", ":3:8: seeds: expected a count"),
    ("plans: [{instance: lab, solver: cbs}]\nstrategies: [adg]\nseeds: 1\ndisable: [\"1-3\"]\n",
     ":4:10: disable: expected none or ROBOT@STEP"),
    ("plans: [{instance: lab, solver: cbs}]\nstrategies: [adg]\nseed: 1\n", ":3:7: seed: unknown key 'seed'"),
    ("plans: [{instance: lab, solver: cbs}]\nstrategies: [adg]\nseeds: 1\nchain: [engine, radio]\n",
     ":4:8: chain: expected engine or wire"),
    ("plans: [{instance: lab, solver: cbs}]\nstrategies: [adg]\nseeds: 1\ndisable: [\"1@3\"]\nchain: [wire]\n",
     ":5:8: chain: wire cells cannot disable robots or replan"),
    ("plans: [{instance: lab, solver: cbs}]\nstrategies: [adg]\nseeds: 1\nchain: [wire]\ntime_scale: 0\n",
     ":5:13: time_scale: expected a number over 0 and at most 100"),
    ("plans: [{instance: lab, solver: cbs}]\nstrategies: [adg]\nseeds: 1\nreroute: [auto]\nreroute_scope: [few]\n",
     ":5:16: reroute_scope: expected held or all, got ['few']"),
    ("plans: [{instance: lab, solver: cbs}]\nstrategies: [adg]\nseeds: 1\nreroute_scope: [all]\n",
     ":4:16: reroute_scope: a scope needs reroute: [auto]"),
    ("plans: [{instance: lab, solver: cbs}]\nstrategies: [adg]\nseeds: 1\ntrim: [yes please]\n",
     ":4:7: trim: expected true or false, got ['yes please']"),
])
def test_a_bad_experiment_file_is_a_one_line_error_naming_line_and_key(tmp_path, text, message):
    path = tmp_path / "bad.yaml"
    path.write_text(text)
    proc = fleetctl("experiment", path, "-o", tmp_path / "out")
    assert proc.returncode == 2 and len(proc.stderr.strip().splitlines()) == 1
    assert proc.stderr.startswith(str(path) + message), proc.stderr


def test_a_wire_cell_runs_the_plan_on_virtual_robots_through_the_manager(tmp_path):
    """The real chain beside the engine: same plan, strategy, delays and seed; times in plan steps."""
    path = tmp_path / "wire.yaml"
    path.write_text("plans: [{instance: lab, solver: cbs}]\nstrategies: [adg]\n"
                    "delays: [\"events=bernoulli:0.2:1-3\"]\nseeds: [3]\nchain: [engine, wire]\n"
                    "time_scale: 10\n")
    proc = fleetctl("experiment", path, "-o", tmp_path / "out", "--jobs", "1", timeout=300)
    assert proc.returncode == 0, proc.stderr
    engine, wire = read_table(tmp_path / "out")
    assert (engine["strategy"], wire["strategy"]) == ("adg", "adg (wire)")
    assert wire["key"] == engine["key"].replace("|size=turtlebot", "|wire:x10|size=turtlebot")
    assert engine["size"] == wire["size"] == "turtlebot" and wire["closest_m"] >= 0.454 - 1e-6
    assert wire["finished"] and wire["reached"] == 5 and wire["collisions"] == 0
    assert wire["moves"] == engine["moves"]  # every planned move ran once, over the wire too
    # the robots turn and the commands cross sockets: slower than the engine, not wildly so
    assert engine["makespan_ratio"] <= wire["makespan_ratio"] < 3 * engine["makespan_ratio"]
    again = fleetctl("experiment", path, "-o", tmp_path / "out", "--jobs", "1", timeout=300)
    assert "0 run now, 2 already done" in again.stdout  # wire cells resume like the others


def test_a_wire_cell_reroutes_through_the_manager(tmp_path):
    """reroute: auto in a wire cell is the manager's --reroute auto; the row counts its reroutes (the
    virtual robots meet the engine cell's delays, paired: on this seed the engine reroutes twice,
    and so did the manager in every run tried)."""
    path = tmp_path / "wire.yaml"
    path.write_text("plans: [{instance: lab, solver: cbs}]\nstrategies: [adg]\n"
                    "delays: [\"events=bernoulli:0.2:1-3\"]\nseeds: [0]\nchain: [wire]\n"
                    "time_scale: 10\nreroute: [auto]\n")
    proc = fleetctl("experiment", path, "-o", tmp_path / "out", "--jobs", "1", timeout=300)
    assert proc.returncode == 0, proc.stderr
    rerouted, = read_table(tmp_path / "out")
    assert rerouted["strategy"] == "adg (wire) +reroute" and rerouted["finished"] and rerouted["reached"] == 5
    assert rerouted["collisions"] == 0 and rerouted["closest_m"] >= 0.454 - 1e-6 and rerouted["reroutes"] >= 1


def test_a_wire_cell_trims_through_the_manager(tmp_path):
    """trim: true in a wire cell is the manager's --trim: the lab as LaCAM plans it with seed 1 (one
    robot winds, 10 moves to spare) runs trimmed through the manager as in the engine, move for move."""
    from fleet_common.formats import default_map_dirs
    from fleet_common.formats.solution import format_solution, make_solution
    from fleet_common.lab import lab_instance_path
    from fleet_common.plan_loading import load_plan

    loaded = load_plan(lab_instance_path(), 5, "lab", default_map_dirs(), solver="lacam", seed=1)
    (tmp_path / "lab_lacam.txt").write_text(format_solution(make_solution(
        loaded.grid, "lab.map", loaded.plan, loaded.starts, loaded.goals, "lacam", True, 0)))
    _, _, rows = swept(tmp_path, "wire.yaml", "plans: [{solution: lab_lacam.txt}]\nstrategies: [adg]\n"
                       "delays: [none]\nseeds: [0]\nchain: [engine, wire]\ntime_scale: 10\ntrim: [true]\n")
    engine, wire = sorted(rows, key=lambda r: "(wire)" in r["strategy"])
    assert (engine["strategy"], wire["strategy"]) == ("adg +trim", "adg (wire) +trim")
    assert wire["finished"] and wire["reached"] == 5 and wire["collisions"] == 0 and wire["closest_m"] >= 0.454 - 1e-6
    assert wire["moves"] == engine["moves"] == 57  # 67 as planned: the manager ran the plan trimmed


def test_a_sweep_over_robot_sizes_shows_what_a_robot_as_large_as_a_cell_costs(tmp_path, shared_data):
    spec = tmp_path / "sizes.yaml"
    spec.write_text("plans: [{{solution: {}}}]\nstrategies: [adg, step]\ndelays: [none]\nseeds: [0]\n"
                    "sizes: [turtlebot, cell]\n".format(shared_data / "solutions" / "pibt_sample.txt"))
    proc = fleetctl("experiment", spec, "-o", tmp_path / "out", "--jobs", "1", timeout=300)
    assert proc.returncode == 0, proc.stderr
    rows = {(r["strategy"], r["size"]): r for r in read_table(tmp_path / "out")}
    assert set(rows) == {("adg", "turtlebot"), ("step", "turtlebot"), ("adg [cell]", "cell"), ("step [cell]", "cell")}
    for strategy in ("adg", "step"):
        real, cell = rows[(strategy, "turtlebot")], rows[(strategy + " [cell]", "cell")]
        assert real["makespan_ratio"] <= 1.02 < cell["makespan_ratio"]  # a train moves as one
        assert real["collisions"] == cell["collisions"] == 0 and real["closest_m"] >= 0.454 - 1e-6
    bad = tmp_path / "bad.yaml"
    bad.write_text("plans: [{instance: lab, solver: cbs}]\nstrategies: [adg]\nseeds: [0]\nsizes: [huge]\n")
    refused = fleetctl("experiment", bad, "-o", tmp_path / "o2")
    assert refused.returncode == 2 and "expected turtlebot, cell or DIAMETER:MARGIN" in refused.stderr


def swept(tmp_path: Path, name: str, text: str):
    """(the spec file, the output folder, the rows) of `fleetctl experiment` on a spec of `text`."""
    spec = tmp_path / name
    spec.write_text(text)
    out = tmp_path / "out"
    proc = fleetctl("experiment", spec, "-o", out, "--jobs", "1", timeout=300)
    assert proc.returncode == 0, proc.stderr
    return spec, out, read_table(out)


def test_a_trim_column_runs_the_plan_trimmed_beside_the_plan_as_given(tmp_path, shared_data):
    """trim: [false, true] on the same delays: the trimmed rows make fewer moves (LaCAM's plan of
    random-32-32-20 has robots to trim), say so in their key and strategy, and finish safely."""
    _, _, rows = swept(tmp_path, "trim.yaml", "plans: [{{instance: {}, solver: lacam}}]\nstrategies: [adg]\n"
                       "delays: [\"events=bernoulli:0.1:1-5\"]\nseeds: [0, 1]\nreroute: [none, auto]\n"
                       "reroute_scope: [held, all]\ntrim: [false, true]\n".format(
                           shared_data / "instances" / "random-32-32-20_70agents_1.txt"))
    assert len(rows) == 12 and all(r["finished"] and r["collisions"] == 0 for r in rows)
    for seed in (0, 1):
        plain = [r for r in rows if r["seed"] == seed and not r["trim"] and r["reroute"] == "none"]
        trimmed = [r for r in rows if r["seed"] == seed and r["trim"] and r["reroute"] == "none"]
        assert plain[0]["moves"] > trimmed[0]["moves"]
    assert {r["strategy"] for r in rows if r["trim"]} == {"adg +trim", "adg +reroute +trim", "adg +reroute all +trim"}
    assert all(r["key"].endswith("|trim") == r["trim"] for r in rows)


def test_a_reroute_column_sweeps_rerouting_beside_the_same_runs_without(tmp_path, shared_data):
    """reroute: [none, auto] on the same delays; the rows count the reroutes; a table written
    before the column existed resumes (its rows are the runs without rerouting)."""
    spec, out, rows = swept(tmp_path, "reroute.yaml", "plans: [{{solution: {}}}]\nstrategies: [adg, reorder]\n"
                            "delays: [\"events=bernoulli:0.1:1-5\"]\nseeds: [0, 1]\nreroute: [none, auto]\n".format(
                                shared_data / "solutions" / "ecbs_random-32-32-20_30agents_1.txt"))
    assert len(rows) == 8
    plain = [r for r in rows if r["reroute"] == "none"]
    auto = [r for r in rows if r["reroute"] == "auto"]
    assert {r["strategy"] for r in plain} == {"adg", "reorder"}
    assert {r["strategy"] for r in auto} == {"adg +reroute", "reorder +reroute"}
    assert all(r["reroutes"] == 0 and "reroute=" not in r["key"] for r in plain)
    assert all(r["key"].endswith("|reroute=auto") for r in auto) and sum(r["reroutes"] for r in auto) >= 2
    assert all(r["finished"] and r["collisions"] == 0 for r in rows)
    # a table from before the column: its header and rows without reroute and reroutes, and only the
    # runs without rerouting (the only ones it could have)
    written = list(csv.reader(io.StringIO((out / "results.csv").read_text())))
    keep = [i for i, c in enumerate(written[0]) if c not in ("reroute", "reroutes")]
    with open(out / "results.csv", "w", newline="") as f:
        writer = csv.writer(f, lineterminator="\n")
        for fields in written:
            if "reroute=" not in fields[0]:
                writer.writerow([fields[i] for i in keep])
    (out / "results.parquet").unlink()
    exp = read_experiment(spec)
    again = run_sweep(exp, out, jobs=1, progress=None)
    assert (again.ran, again.resumed) == (4, 4)
    assert without_wall_time(again.rows) == without_wall_time(rows)
