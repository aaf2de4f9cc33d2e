"""A sweep cell through the real chain: virtual robots and the manager over loopback.

An engine cell (`cell.py`) says what the synchronization strategy does with
the delays; a wire cell says what the rest of the system adds to it: the
robots turn before they drive, commands and replies cross sockets, the
manager's loop decides when they go. The plan is written as a solution (and
its map) into a scratch folder; `fleetctl virtual-fleet` stands one virtual
robot on each start, meeting the delays the engine cell of the same model and
seed meets (`--paired`: robot i's k-th drive has the fate of agent i's k-th
move, in units of a nominal move), so engine and wire rows pair seed by seed;
`fleetctl manager --start
--until-done` runs the cell's strategy and writes its run folder, from which
the row is read (`runlog.summary`, the figures `fleetctl trace` prints).
With `reroute: auto` the manager reroutes (`--reroute auto`) and the row
counts its `reroute` records.

Times in the row are in plan steps, as in engine rows: the run's seconds
divided by a nominal move (one cell at the fleet's speed, in wall seconds at
its time scale), so a makespan ratio of 1.3 means the same in both kinds of
row. A wire cell takes wall time (the plan's makespan in moves, divided by
the time scale, plus a few seconds to start), and two processes; robots
cannot be disabled in it (that is an operator's act in the manager), so
`disable` and `recover` stay `none`.
"""
from __future__ import annotations

import tempfile
import time
from pathlib import Path
from typing import Dict, List

from fleet_common.children import Child
from fleet_common.errors import FleetError
from fleet_common.formats.mapfile import map_from_grid, write_map
from fleet_common.formats.solution import make_solution, write_solution
from fleet_common.local_fleet import local_definitions
from fleet_common.plan import Plan
from fleet_common.plan_loading import LoadedPlan
from fleet_common.robots import RobotDefinition
from fleet_common.runlog import read_run
from fleet_common.runlog.summary import SummaryBuilder

from .row import make_row
from .spec import Cell

#: The virtual robots' speed (cells a second of fleet time): a nominal move of 2 s, as in the lab.
SPEED = 0.5
_START_S = 60.0   # seconds the fleet and the manager may take to start and connect


def run_wire_cell(cell: Cell, plan: LoadedPlan, time_scale: float) -> Dict[str, object]:
    """The row of one run on virtual robots through the manager."""
    began = time.perf_counter()
    p = plan.plan
    move_s = 1.0 / SPEED / time_scale  # a nominal move, in wall seconds
    limit = _START_S + 5.0 * (p.makespan + 1) * move_s + 30.0
    with tempfile.TemporaryDirectory(prefix="fleetcontrol-wire-cell-") as scratch:
        work = Path(scratch)
        grid = plan.grid
        write_map(map_from_grid(grid), str(work / "plan.map"))
        starts = [tuple(int(v) for v in c) for c in p.positions[0]]
        write_solution(make_solution(grid, "plan.map", p, starts, plan.goals, plan.solver, True, 0),
                       str(work / "plan.txt"))
        robots = [RobotDefinition(i + 1, "127.0.0.1", 0, "virtual", "v{}".format(i + 1), "grey")
                  for i in range(p.num_agents)]
        definitions, feedback, port = local_definitions(robots, work / "robots.txt")
        fleet = Child.start("fleet", [
            "virtual-fleet", "--definitions", str(definitions), "--no-curve", "--instance",
            str(work / "plan.txt"), "--time-scale", "{:g}".format(time_scale), "--feedback-base",
            str(feedback), "--delay-model", cell.delay, "--seed", str(cell.seed), "--paired", "--speed",
            "{:g}".format(SPEED), "--log-level", "warning"], log=work / "fleet.log")
        try:
            manager = Child.start("manager", [
                "manager", str(work / "plan.txt"), "--definitions", str(definitions), "--no-curve",
                "--host", "127.0.0.1", "--bind", "tcp://127.0.0.1:{}".format(port), "--strategy",
                cell.strategy, *_settings(cell), "--robot-size", _size(cell), "--reroute",
                "off" if cell.reroute == "none" else cell.reroute, *_scope(cell), *(["--trim"] if cell.trim else []),
                "--start", "--until-done",
                "--time-limit",
                "{:g}".format(limit), "--connect-timeout", "{:g}".format(_START_S), "--log",
                str(work / "runs"), "--step-time", "{:.4f}".format(move_s)], log=work / "manager.log")
            if manager.wait(limit + _START_S) is None:
                manager.stop()
        finally:
            fleet.stop()
        folders = sorted((work / "runs").glob("*/events.jsonl"))
        if not folders:
            raise FleetError("cell {}: the manager wrote no run folder: {}".format(
                cell.key, _tail(work / "manager.log")))
        row = _row(cell, plan, p, read_run(folders[-1].parent), time_scale)
    row["wall_s"] = round(time.perf_counter() - began, 4)
    return row


def _scope(cell: Cell) -> List[str]:
    """The manager's --reroute-scope, given only when it is not the default (a manager that
    predates it still runs the held scope's cells)."""
    return [] if cell.reroute_scope == "held" else ["--reroute-scope", cell.reroute_scope]


def _settings(cell: Cell) -> List[str]:
    out: List[str] = []
    for key, value in cell.settings:
        out += ["--{}".format(key.replace("_", "-")), str(value)]
    return out


def _size(cell: Cell) -> str:
    size = cell.robot_size
    return "cell" if size.cell_sized else "{!r}:{!r}".format(size.diameter, size.margin)


def _tail(log: Path) -> str:
    try:
        lines = log.read_text().strip().splitlines()
    except OSError:
        return "no log"
    return " / ".join(lines[-3:]) or "no output"


def _row(cell: Cell, plan: LoadedPlan, p: Plan, run, time_scale: float) -> Dict[str, object]:
    steps = time_scale * SPEED  # plan steps per wall second
    builder = SummaryBuilder()
    for record in run.records:
        builder.feed(record)
    s = builder.summary()
    robots: List[int] = list(run.robots)
    waits = {r: 0.0 for r in robots}
    count = 0
    for rec in run.of("dispatch"):
        waited = float(rec.get("waited") or 0.0)
        if waited > 0:
            waits[rec["robot"]] = waits.get(rec["robot"], 0.0) + waited * steps
            count += 1
    moves = sum(1 for rec in run.of("action") if rec.get("phase") == "completed")
    return make_row(cell, plan, p, makespan=s.makespan * steps, soc=s.soc * steps,
                    waits=[waits.get(r, 0.0) for r in robots], count=count,
                    held=0.0, blocked={},  # the engine's held and blocked-by figures: engine cells only
                    collisions=s.collisions, reached=len(s.arrived), replanned=False, moves=moves,
                    closest_m=None if s.min_distance is None or s.cell_m is None else s.min_distance * s.cell_m,
                    reroutes=sum(1 for _ in run.of("reroute")))
