"""A manager that dies after rerouting a run, and another that takes the run over from its records.

A reroute hands the run over to a new plan with robots mid-move: the new
plan starts each robot with the old plan's move `base[r]`, the moves in
flight are renumbered, and a follower's move made before its leader left is
done already in the new plan. A manager killed at any moment after that
leaves records in two numberings; the one started again (`resume.read_resume`,
`Engine.restore`, as `fleetctl manager --resume`) must see exactly the
progress the live manager had: each robot's moves completed and begun, and
the command in flight with its move, all in the newest plan's numbering.

Runs are recorded in memory (`MemoryFleet`, a fake clock), the live
manager's state taken after every batch of records it wrote (what a
SIGKILL leaves: a batch's records reach the file before its commands go
out). Three runs: the crossing of `test_manager_reroute` (one reroute, the
moves in flight renumbered), a train whose slow leader a third robot is
rerouted around (a follower's move done at the hand-over), the lab plan
with two stalled robots (two reroutes). The negative control keeps the old
plan's numbers; the same checks catch it.
"""
from __future__ import annotations

import functools
import json
from dataclasses import dataclass
from pathlib import Path
from typing import Dict, List, Optional, Tuple

import numpy as np
import pytest
from hypothesis import HealthCheck, Phase, given, settings
from hypothesis import strategies as st

from fleet_common.errors import FleetError
from fleet_common.formats.solution import make_solution
from fleet_common.grid import Grid
from fleet_common.plan import Plan
from fleet_common.plan_loading import LoadedPlan
from fleet_common.robot_size import TURTLEBOT2, RobotSize, cell_sized
from fleet_common.runlog.reader import RunFolder
from fleet_common.runlog.records import DURABLE
from fleet_manager import resume as resume_module
from fleet_manager.core import RunCore
from fleet_manager.resume import read_resume
from fleet_manager.settings import ManagerSettings
from helpers import fleetctl, free_port
from memory_fleet import MemoryFleet, lab_fleet
from test_manager_reroute import crossing
from test_manager_core import closest_truth, run_recording
from test_manager_resume import executions, lab

Flight = Optional[Tuple[int, str, Optional[int]]]  # command id, kind, move


@dataclass(frozen=True)
class Live:
    """The live manager after a batch of records: how many records it had written, and its run."""

    records: int
    t: float
    plan: str
    completed: Tuple[int, ...]
    started: Tuple[int, ...]
    dispatched: Tuple[int, ...]
    flights: Tuple[Flight, ...]


def flights(core: RunCore) -> Tuple[Flight, ...]:
    return tuple(None if r.flight is None else (r.flight.id, r.flight.kind, r.flight.index) for r in core.fleet)


def live_of(f: MemoryFleet) -> Live:
    core = f.core
    run = core.run.engine.run
    return Live(len(f.records), f.now, "plan-{}.txt".format(core.run.plan_id), tuple(run.completed),
                tuple(run.started), tuple(run.dispatched), flights(core))


@dataclass
class Recorded:
    """A run recorded to its end, and the live manager's state after each batch of durable records."""

    fleet: MemoryFleet
    cuts: List[Live]

    def records(self, cut: Live) -> List[dict]:
        return [dict(fields, k=kind, t=t) for kind, t, fields in self.fleet.records[:cut.records]]

    def after_reroutes(self) -> List[Live]:
        """The cuts right after each hand-over (its `plan` record the newest), and the one before it."""
        kinds = [kind for kind, _, fields in self.fleet.records]
        out = []
        for i, (kind, _, fields) in enumerate(self.fleet.records):
            if kind == "plan" and fields.get("reason") == "reroute":
                first = next(c for c in self.cuts if c.records > i)
                before = [c for c in self.cuts if c.records <= i]
                out += before[-1:] + [first]
        assert kinds.count("plan") == len(out) // 2
        return out


def record(f: MemoryFleet, limit: float = 80.0) -> Recorded:
    """Run `f` (started) to its end, its state after every batch with a durable record in it."""
    cuts: List[Live] = []

    def after_batch() -> None:
        if any(kind in DURABLE for kind, _, _ in f.records[cuts[-1].records if cuts else 0:]):
            cuts.append(live_of(f))

    f.after_batch = after_batch
    assert f.run_until(lambda: f.phase == "done", limit) and f.at_goals()
    f.after_batch = None
    return Recorded(f, cuts)


def resumed(rec: Recorded, cut: Live) -> RunCore:
    """A manager started on the records `cut` leaves, as `fleetctl manager --resume` on its folder."""
    f = rec.fleet
    records = rec.records(cut)
    records[0].setdefault("started", None)
    point = read_resume(RunFolder(Path("memory-run"), records, torn=False))
    plan = f.loaded.plan if point.plan == "plan-1.txt" else f.replans[point.plan]
    return RunCore(f.loaded, f.definitions, f.settings, "session-2", cut.t, resume=(point, plan))


def assert_resumed_as_live(rec: Recorded, cut: Live) -> None:
    core = resumed(rec, cut)
    run = core.run.engine.run
    where = "cut after record {} at {:.2f} s".format(cut.records, cut.t)
    assert "plan-{}.txt".format(core.run.plan_id) == cut.plan, where
    assert tuple(run.completed) == cut.completed, where
    assert tuple(run.started) == cut.started, where
    assert flights(core) == cut.flights, where
    # decisions not sent yet are made again after Start; nothing more than the live run had is sent
    assert all(r <= c for r, c in zip(run.dispatched, cut.dispatched)), where
    sent = tuple(max(s, 0 if f is None or f[1] != "drive" else f[2] + 1) for s, f in zip(cut.started, cut.flights))
    assert all(r >= s for r, s in zip(run.dispatched, sent)), where


# ---- the runs ----------------------------------------------------------------------------------

def open5(paths: List[List[Tuple[int, int]]], name: str) -> LoadedPlan:
    plan = Plan.from_paths(paths)
    grid = Grid(np.ones((5, 5), dtype=bool), name="open5")
    sol = make_solution(grid, "open5.map", plan, plan.starts, plan.goals, "hand", True, 0)
    return LoadedPlan(plan, grid, list(plan.starts), list(plan.goals), name, sol, lambda c: c)


#: Robot 1 leads robot 2 east along row 1, slowly; robot 3 comes up to cross row 1 behind them.
SLOW_TRAIN = [[(1, 1), (2, 1), (3, 1), (4, 1), (4, 2), (4, 3)],
              [(0, 1), (1, 1), (2, 1), (3, 1), (4, 1)],
              [(0, 4), (1, 4), (2, 4), (3, 4), (3, 3), (3, 2), (3, 1), (3, 0)]]


def start(loaded: LoadedPlan, n: int, size: RobotSize, stalls: Dict[int, Tuple[int, float]],
          speeds: Optional[Dict[int, float]] = None, strategy: str = "adg") -> MemoryFleet:
    """`loaded` on `n` robots of `size`, rerouting automatically, robots stalled (robot id: (drive,
    seconds)) or slow (robot id: cells/s), started."""
    f = MemoryFleet(loaded, lab_fleet(n), ManagerSettings(step_time=0.5, size=size, reroute="auto",
                                                          reroute_timed=False, strategy=strategy), speed=1.0)
    for rid, (drive, seconds) in stalls.items():
        f.robots[rid].navigator.stalls = {drive: seconds}
    for rid, speed in (speeds or {}).items():
        f.robots[rid].navigator.speed = speed
    f.link_up()
    assert f.ask(f.console(), "start").ok
    return f


def crossing_run(size: RobotSize) -> MemoryFleet:
    return start(crossing(), 3, size, {1: (1, 6.0)})


def slow_train_run() -> MemoryFleet:
    # robot 2 catches up with robot 1 and makes its move before robot 1 has left the cell
    return start(open5(SLOW_TRAIN, "slow train"), 3, TURTLEBOT2, {}, {1: 0.15})


def lab_run(stalls: Dict[int, Tuple[int, float]], strategy: str = "adg") -> MemoryFleet:
    return start(lab(), 5, TURTLEBOT2, stalls, strategy=strategy)


_RUNS: Dict[str, Recorded] = {}


def recorded(name: str) -> Recorded:
    if name not in _RUNS:
        _RUNS[name] = record({"crossing": lambda: crossing_run(cell_sized()),
                              "crossing-tb2": lambda: crossing_run(TURTLEBOT2),
                              "slow-train": slow_train_run,
                              "lab-twice": lambda: lab_run({4: (3, 8.0), 3: (5, 8.0)})}[name]())
    return _RUNS[name]


@functools.lru_cache(maxsize=None)
def lab_recorded(strategy: str, rid: int, drive: int, seconds: float) -> Recorded:
    """The lab plan under `strategy`, robot `rid` stalled `seconds` in its `drive`-th drive (kept: a
    run is the same every time)."""
    return record(lab_run({rid: (drive, seconds)}, strategy))


# ---- from the records ----------------------------------------------------------------------------

@pytest.mark.parametrize("name", ["crossing", "crossing-tb2", "slow-train", "lab-twice"])
def test_a_manager_killed_after_any_batch_of_a_rerouted_run_is_resumed_with_the_live_progress(name):
    rec = recorded(name)
    assert rec.fleet.kinds("reroute"), "the run was not rerouted"
    reroutes = [fields for kind, _, fields in rec.fleet.records if kind == "plan" and fields["reason"] == "reroute"]
    if name == "lab-twice":
        assert len(reroutes) == 2
    if name == "slow-train":  # robot 2's move into the cell robot 1 was leaving: done at the hand-over
        assert reroutes[0]["done"][1] == 1
    else:  # moves in flight at the hand-over get new numbers
        assert any(b > 0 for b in reroutes[0]["base"])
    for cut in rec.cuts:
        assert_resumed_as_live(rec, cut)


# no shrinking: each new stall is a new run of the lab plan (half a second or so); a failing
# example is small already, and its message names its cut
@settings(max_examples=6, deadline=None, suppress_health_check=[HealthCheck.too_slow],
          phases=(Phase.explicit, Phase.reuse, Phase.generate))
@given(st.sampled_from(["adg", "reorder"]), st.sampled_from([1, 2, 3, 4, 5]), st.integers(2, 5),
       st.sampled_from([4.0, 8.0, 12.0]), st.data())
def test_any_cut_of_a_lab_run_with_a_stalled_robot_resumes_with_the_live_progress(strategy, rid, drive, seconds,
                                                                                  data):
    """Random stalls on the lab plan, under the ADG or the re-ordering strategy (whose passes after a
    hand-over are in the new plan's numbers): whether, when and how often the run is rerouted varies;
    cuts drawn at random and those about each hand-over resume with the live progress."""
    rec = lab_recorded(strategy, rid, drive, seconds)
    picked = data.draw(st.lists(st.sampled_from(rec.cuts), min_size=1, max_size=8))
    for cut in picked + rec.after_reroutes():
        assert_resumed_as_live(rec, cut)


def test_a_run_rerouted_twice_and_killed_later_is_resumed_on_its_third_plan_and_every_robot_arrives():
    f = lab_run({4: (3, 8.0), 3: (5, 8.0)})
    assert f.run_until(lambda: len(f.kinds("reroute")) == 2, 30)
    run = f.core.run.engine.run
    done = sum(run.completed)
    assert f.run_until(lambda: sum(run.completed) >= done + 3, 10)  # later: moves of plan 3 made
    driving = {r.id for r in f.core.fleet if r.flight is not None and r.flight.kind == "drive"}
    assert driving
    ran = executions(f)
    clock, killed = f.core.run.plan_start + f.core.run.plan_steps(f.now), f.now
    f.kill_manager()
    seen: List[float] = []
    for _ in range(40):  # two seconds without a manager: the robots finish their moves and wait
        f.advance(0.05)
        closest_truth(f, seen)
    f.resume_manager()
    (resume,) = f.kinds("resume")
    assert resume["plan"] == "plan-3.txt" and sum(resume["completed"]) == sum(run.completed)
    # the plan clock a console shows goes on across three plans and the time without a manager
    resumed_run = f.core.run
    assert resumed_run.plan_start > 0
    assert resumed_run.plan_start + resumed_run.plan_steps(f.now) == pytest.approx(
        clock + (f.now - killed) / 0.5, abs=0.02)
    assert {robot for robot, _, kind in resume["sent"] if kind == "drive"} == driving
    f.advance(0.2)
    assert "every robot where the run left it" in f.core.run.phase.reason
    assert f.ask(f.console(), "start").ok
    run_recording(f, 60, seen)
    assert f.phase == "done" and f.at_goals()
    assert min(seen) >= TURTLEBOT2.safe_cells - 0.01
    assert len(ran) == len(set(ran)), "a command ran twice"
    summary = f.core.summary()
    assert len(summary.arrived) == 5 and summary.collisions == 0 and summary.resumes == 1


def _keeps_old_numbers(point, record, pending):
    """Wrong on purpose: the new plan and its moves done, but begun moves and commands in flight keep
    the old plan's numbers."""
    point.plan = str(record["file"])
    point.completed = {rid: record["done"][a] for a, rid in enumerate(record["robots"])}
    point.passes.clear()


def test_a_resume_that_keeps_the_old_numbers_of_moves_in_flight_is_caught(monkeypatch):
    """The negative control: the same records, read back without renumbering; the comparison with
    the live manager fails (or the engine cannot place the progress and the resume refuses)."""
    rec = recorded("crossing")
    monkeypatch.setattr(resume_module, "renumber", _keeps_old_numbers)
    caught = 0
    for cut in rec.after_reroutes()[1::2]:
        with pytest.raises((AssertionError, FleetError)):
            assert_resumed_as_live(rec, cut)
        caught += 1
    assert caught == 1


# ---- refused: a reroute's records that cannot say how to renumber ----------------------------------

def _reroute_records(rec: Recorded) -> Tuple[List[dict], int]:
    cut = rec.after_reroutes()[1]
    records = rec.records(cut)
    records[0].setdefault("started", None)
    i = next(i for i, r in enumerate(records) if r["k"] == "plan" and r["reason"] == "reroute")
    return records, i


@pytest.mark.parametrize("broken, said", [
    (lambda r: r.pop("base"), "lacks base (a list of 3 whole numbers, by robot)"),
    (lambda r: r.update(done=[0, 1]), "lacks done (a list of 3 whole numbers, by robot)"),
    (lambda r: r.update(base=[0, 1, 2]), "does not fit the records before it: robot 3 had completed 1 move "
                                         "of plan-1.txt, the reroute starts it with move 2 and counts 0 of 5 done"),
], ids=["no-base", "short-done", "base-beyond-progress"])
def test_a_reroute_record_that_cannot_be_renumbered_is_refused_in_one_line(broken, said):
    records, i = _reroute_records(recorded("crossing"))
    broken(records[i])
    with pytest.raises(FleetError) as caught:
        read_resume(RunFolder(Path("memory-run"), records, torn=False))
    text = str(caught.value)
    assert "\n" not in text and text.startswith("cannot resume memory-run: the record of the reroute to "
                                                "plan-2.txt at "), text
    assert said in text, text


def _folder(rec: Recorded, cut: Live, path: Path) -> Path:
    """The run folder `cut` leaves on disk: events.jsonl and the plan files written by then."""
    path.mkdir()
    records = rec.records(cut)
    records[0].update(started="2026-01-01T00:00:00.000+00:00", epoch="memory", plan_name="crossing")
    (path / "events.jsonl").write_text("".join(json.dumps(r) + "\n" for r in records))
    (path / "plan-1.txt").write_text(rec.fleet.loaded.text())
    (path / "open5.map").write_text("type octile\nheight 5\nwidth 5\nmap\n" + ".....\n" * 5)
    for name, text in rec.fleet.files.items():
        (path / name).write_text(text)
    return path


def test_a_rerouted_folder_without_its_new_plan_file_or_with_its_plan_record_torn_is_refused(tmp_path: Path):
    from argparse import Namespace

    from fleet_manager.resume_folder import load_resume

    rec = recorded("crossing")
    cut = rec.after_reroutes()[1]
    definitions = tmp_path / "robots.txt"
    definitions.write_text("".join("{} 127.0.0.1 {} u tb{} red\n".format(i, 9000 + i, i) for i in (1, 2, 3)))
    args = Namespace(plan=None, robots=None, resume=None)

    folder = _folder(rec, cut, tmp_path / "ok")
    args.resume = str(folder)
    _, _, (point, plan) = load_resume(args, definitions, [], None, False)
    assert point.plan == "plan-2.txt" and plan.num_agents == 3

    folder = _folder(rec, cut, tmp_path / "lost")
    (folder / "plan-2.txt").unlink()
    args.resume = str(folder)
    with pytest.raises(FleetError, match=r"^cannot resume .*lost: plan-2.txt is missing, the plan its records "
                                         r"run since the reroute at [0-9.]+ s; Go to starts"):
        load_resume(args, definitions, [], None, False)

    before = rec.after_reroutes()[0]  # the last batch before the hand-over, and its plan record torn
    folder = _folder(rec, before, tmp_path / "torn")
    plan_line = next(json.dumps(dict(fields, k=kind, t=t)) for kind, t, fields in rec.fleet.records
                     if kind == "plan")
    with open(folder / "events.jsonl", "a") as events:
        events.write(plan_line[:40])
    # as the lab staff meet it: one line, exit 2 (a manager that took it over would serve on loopback
    # only, and be stopped by the timeout)
    refused = fleetctl("manager", "--resume", folder, "--no-curve", "--no-log", "--definitions", definitions,
                       "--map-dir", folder, "--host", "127.0.0.1", "--bind", "tcp://127.0.0.1:{}".format(free_port()),
                       timeout=30)
    assert refused.returncode == 2 and refused.stdout == ""
    assert refused.stderr == ("fleetctl manager: cannot resume {}: plan-2.txt was written but the run log has no "
                              "complete `plan` record for it (its last line is torn): the change to it was cut "
                              "off; Go to starts and run the plan again\n".format(folder)), refused.stderr
