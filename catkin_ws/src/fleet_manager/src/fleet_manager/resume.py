"""A manager started again on a run folder: where the run stood, and where the robots stand.

Theory of operation. A manager may die mid-run (SIGKILL, a crash, the lab
PC's power button) while the robots go on: each finishes the command it
was running and waits, a follower at its hold point. Its run folder holds
every decision it made: the records a restart needs reach the file as they
are made (`fleet_common.runlog.records.DURABLE`), and the `run` record names
the manager's command epoch. A new manager started on the folder
(`fleetctl manager --resume RUNDIR`):

1. reads the records (`read_resume`): the plan being run (the last
   plan-N.txt), the actions of it each robot completed, began and was sent,
   the commands no reply settled (at most each robot's running motion), the
   robots out and why, the strategy, whether the run had started;
2. rebuilds the engine's progress from them (`Engine.restore`) and speaks to
   the robots as the same manager (the same epoch, command ids above the
   old ones): it sends each unsettled command again with its id, so a robot
   still running one reports its outcome to the new manager, one that
   finished reports that, and none runs a command twice;
3. once every robot has answered and reported a pose (`Resuming.waiting_for`
   says for whom it waits), compares where each robot stands with where the
   run left it (`off_plan`): on the cell of its last completed action, or on
   the move it is making. Robots elsewhere are named; one standing on a cell
   is replanned from there with everyone else (a proposal, as any replan);
   one between cells cannot be driven to a cell without a plan for it, so
   it is held and planned around, its neighbouring cells walled off.

Nothing moves until that check is done: no release of a follower, no new
action (the resumed run is paused until Start). The run log goes on in the
same folder after a `resume` record, on the same clock.

A way to the starts (Go to starts, Reset) is a run of its own folder, and is
taken over the same way: the new manager drives the robots on to the starts
of the plan it was for (`ResumePoint.for_plan`), which then waits for Start
in a new folder, as it would have had its manager lived.

A rerouted run changed plan with robots mid-move (`handover`): the reroute's
`plan` record says, by robot, which move of the old plan the new plan starts
it with (`base`) and how many of the new plan's moves it has done already
(`done`: a follower's move made before its leader left). At that record the
progress read so far is renumbered into the new plan as the live manager
renumbered it (`renumber`): completed = done, begun = begun - base, each
unsettled command's move = its move - base; the records after it are in the
new numbering already. A record that lacks those fields or does not fit the
progress before it is refused in one line, as is a folder whose plan file
its records never reached, or that lost one (`resume_folder`).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Dict, List, Optional, Set, Tuple

from fleet_common.errors import FleetError
from fleet_common.grid import Coord, Grid
from fleet_common.runlog.reader import RunFolder
from fleet_common.runlog.records import plan_file
from fleet_common.wire import Command, DriveToPosition, Stop, Turn

from .driver import AT_CELL
from .replanning import to_segment
from .robot import Fleet, Robot

__all__ = ["ResumePoint", "Unsettled", "read_resume", "Resuming", "OffPlan", "off_plan", "walls_around",
           "ID_MARGIN"]

Record = Dict[str, Any]
Point = Tuple[float, float]

#: Command ids the new manager skips past the highest one in the log: releases of hold points
#: are not logged, and a robot refuses an id at or below one it has seen from the epoch.
ID_MARGIN = 10000


@dataclass
class Unsettled:
    """A command the old manager sent that no reply settled."""

    robot: int
    command: Command
    action: Optional[int]
    hold: Optional[Point]
    accepted: bool = False


@dataclass
class ResumePoint:
    """Where a run stood when its manager stopped, from its folder's records alone."""

    folder: Path
    run: Record
    records: List[Record]
    plan: str = plan_file(1)                        # the plan being run
    completed: Dict[int, int] = field(default_factory=dict)   # robot id -> actions completed
    started: Dict[int, int] = field(default_factory=dict)     # robot id -> actions begun
    unsettled: Dict[int, List[Unsettled]] = field(default_factory=dict)
    next_id: Dict[int, int] = field(default_factory=dict)     # robot id -> first id to use
    out: Dict[int, Tuple[str, str]] = field(default_factory=dict)  # robot id -> (why, reason)
    strategy: str = "adg"
    settings: Dict[str, Any] = field(default_factory=dict)
    reroute: str = "off"                            # the reroute mode the run had last
    reroute_scope: str = "held"                     # and its scope
    trim: bool = False                              # whether its plans were trimmed (`ManagerSettings.trim`)
    phase: str = "waiting"
    #: a re-ordering strategy's passes, in order: (robot id, index, robot id passed, its index)
    passes: List[Tuple[int, int, int, int]] = field(default_factory=list)
    began: Optional[float] = None                   # t the run left "waiting" (Start or Step)
    #: the current plan's step 0 (t), and the seconds the run's earlier plans ran before it: the
    #: plan clock a console shows goes on from them (`Run.next_plan_clock` keeps it so live)
    plan_since: Optional[float] = None
    earlier_plans: float = 0.0
    #: robot ids the plan leaves away from their goals (`Run.stranded`)
    stranded: List[int] = field(default_factory=list)
    #: the cells the plan keeps off (`Run.kept_walls`), None in folders from before they were recorded
    walls: Optional[List[Coord]] = None
    #: robot ids whose move begun was taken back by a fault (or a halt) and not begun again: they
    #: stand between two cells, that move not under way (`RunState.halfway`)
    taken_back: Set[int] = field(default_factory=set)
    last_t: float = 0.0
    torn: bool = False

    @property
    def epoch(self) -> Optional[str]:
        epoch = self.run.get("epoch")
        return epoch if isinstance(epoch, str) and epoch else None

    @property
    def robots(self) -> List[int]:
        return [int(r) for r in self.run.get("robots") or []]

    @property
    def for_plan(self) -> Optional[str]:
        """The plan whose starts the run drove the robots to (a way to the starts, the run's
        `purpose` "to-starts"), None for a run of a plan."""
        name = self.run.get("for_plan")
        return name if self.run.get("purpose") == "to-starts" and isinstance(name, str) and name else None

    @property
    def plan_number(self) -> int:
        try:
            return int(self.plan.rsplit("-", 1)[1].split(".")[0])
        except (IndexError, ValueError):
            return 1

    def dispatched(self, robot: int) -> int:
        """Actions of the current plan robot `robot` was sent a drive for (or began)."""
        sent = [u.action + 1 for u in self.unsettled.get(robot, ())
                if isinstance(u.command, DriveToPosition) and u.action is not None]
        return max(sent + [self.started.get(robot, 0), self.completed.get(robot, 0)])


def _cells(value: Any) -> Optional[List[Coord]]:
    """A record's list of [x, y] cells (None: not there, or not such a list)."""
    if not isinstance(value, list) or not all(isinstance(c, list) and len(c) == 2 and all(
            isinstance(v, int) and not isinstance(v, bool) for v in c) for c in value):
        return None
    return [(c[0], c[1]) for c in value]


def read_resume(run: RunFolder) -> ResumePoint:
    """Where the run of `run` (a folder read back) stood at its last record."""
    point = ResumePoint(run.folder, run.run, run.records, torn=run.torn)
    point.strategy = str(run.run.get("strategy") or "adg")
    point.settings = dict(run.run.get("settings") or {})
    point.reroute = _mode(run.run.get("reroute"), "off")
    point.reroute_scope = _scope(run.run.get("reroute_scope"), "held")
    point.trim = run.run.get("trim") is True
    pending: Dict[int, Dict[int, Unsettled]] = {}
    highest: Dict[int, int] = {}
    # the ids the manager had used before this folder (runs it drove before a reset or a load, in
    # the same epoch): a robot answers an id it remembers with that command's outcome, unrun
    _ids_used(point, run.run, highest)
    for r in run.records:
        kind = r.get("k")
        if kind == "resume":  # a manager that took over before: ids from where it started
            _ids_used(point, r, highest)
        point.last_t = max(point.last_t, _number(r.get("t")))
        robot = r.get("robot")
        if kind == "plan" and r.get("reason") != "loaded" and point.plan_since is not None:
            t = _number(r.get("t"))
            point.earlier_plans += max(0.0, t - point.plan_since)
            point.plan_since = t
        if kind == "plan":
            point.stranded = [x for x in r.get("stranded") or [] if isinstance(x, int)]
        if kind == "plan" or r is run.run:
            point.walls = _cells(r.get("walls"))
        if kind == "plan" and r.get("reason") == "reroute":
            handed_over(point, r, pending)
        elif kind == "plan" and r.get("reason") != "loaded":
            point.plan = str(r.get("file") or point.plan)
            point.completed.clear()
            point.started.clear()
            point.taken_back.clear()
            point.passes.clear()
        elif kind == "pass" and all(isinstance(r.get(f), int) for f in ("robot", "index", "passed",
                                                                           "passed_index")):
            point.passes.append((r["robot"], r["index"], r["passed"], r["passed_index"]))
        elif kind == "action" and isinstance(robot, int) and isinstance(r.get("index"), int):
            counts = point.completed if r.get("phase") == "completed" else point.started
            counts[robot] = max(counts.get(robot, 0), r["index"] + 1)
            point.taken_back.discard(robot)
        elif kind == "command" and isinstance(robot, int) and isinstance(r.get("id"), int):
            highest[robot] = max(highest.get(robot, 0), r["id"])
            command = _command(r)
            if command is not None:
                action = r.get("action") if isinstance(r.get("action"), int) else None
                pending.setdefault(robot, {})[r["id"]] = Unsettled(robot, command, action, _point(r.get("hold")))
        elif kind == "reply" and isinstance(robot, int) and isinstance(r.get("id"), int):
            highest[robot] = max(highest.get(robot, 0), r["id"])
            sent = pending.get(robot, {}).get(r["id"])
            if r.get("type") in ("completed", "failed"):
                pending.get(robot, {}).pop(r["id"], None)
            elif r.get("type") == "accepted" and sent is not None:
                sent.accepted = True
        elif kind == "out" and isinstance(robot, int):
            if (r.get("why") == "failed" or r.get("taken_back")) and \
                    point.started.get(robot, 0) > point.completed.get(robot, 0):
                point.taken_back.add(robot)  # a fault takes the move begun back (`Engine._failed`)
            if r.get("why") is None:
                point.out.pop(robot, None)
            else:
                point.out[robot] = (str(r["why"]), str(r.get("reason") or ""))
        elif kind == "reroute_mode":
            point.reroute = _mode(r.get("mode"), point.reroute)
            point.reroute_scope = _scope(r.get("scope"), point.reroute_scope)
            if isinstance(r.get("trim"), bool):
                point.trim = r["trim"]
        elif kind == "strategy" and isinstance(r.get("name"), str):
            point.strategy = r["name"]
            point.settings.update(r.get("settings") or {})
        elif kind == "state" and isinstance(r.get("run"), str):
            point.phase = r["run"]
            if r["run"] != "waiting" and point.began is None:  # a Start, or a Step (paused after it)
                point.began = point.plan_since = _number(r.get("t"))
    point.unsettled = {robot: [u for _, u in sorted(commands.items())]
                       for robot, commands in pending.items() if commands}
    point.next_id = {robot: top + 1 + ID_MARGIN for robot, top in highest.items()}
    return point


def _ids_used(point: ResumePoint, record: Record, highest: Dict[int, int]) -> None:
    """Raise `highest` (robot id -> highest command id used) to the ids a `run` or `resume`
    record says its manager's next ones were (`next_ids`, in the run's robot order)."""
    ids = record.get("next_ids")
    if isinstance(ids, list) and len(ids) == len(point.robots) and all(type(n) is int for n in ids):
        for robot, n in zip(point.robots, ids):
            highest[robot] = max(highest.get(robot, 0), n - 1)


def handed_over(point: ResumePoint, record: Record, pending: Dict[int, Dict[int, Unsettled]]) -> None:
    """The run went on with a reroute's plan from `record` (its `plan` record) on: the progress
    read so far, in the old plan's numbering, renumbered into the new plan's. FleetError, in one
    line, when the record cannot say how (fields missing, or progress it does not fit)."""
    robots, base, done = record.get("robots"), record.get("base"), record.get("done")
    actions = record.get("actions")
    name = record.get("file")
    n = len(point.robots)
    what = "cannot resume {}: the record of the reroute to {} at {:.1f} s".format(
        point.folder, name if isinstance(name, str) and name else "its next plan", _number(record.get("t")))
    if not isinstance(name, str) or not name:
        raise FleetError("{} names no plan file; Go to starts and run the plan again".format(what))
    missing = [f for f, v in (("robots", robots), ("base", base), ("done", done), ("actions", actions))
               if not _counts(v, n)]
    if missing:
        raise FleetError("{} lacks {} (a list of {} whole numbers, by robot): the moves in flight cannot "
                         "be renumbered into it; Go to starts and run the plan again".format(
                             what, " and ".join(missing), n))
    for a, rid in enumerate(robots):  # type: ignore[arg-type]
        had = point.completed.get(rid, 0)
        if base[a] > had or done[a] != had - base[a] or done[a] > actions[a]:  # type: ignore[index]
            raise FleetError("{} does not fit the records before it: robot {} had completed {} move{} of {}, "
                             "the reroute starts it with move {} and counts {} of {} done; Go to starts and "
                             "run the plan again".format(what, rid, had, "" if had == 1 else "s", point.plan,
                                                         base[a], done[a], actions[a]))  # type: ignore[index]
    renumber(point, record, pending)


def renumber(point: ResumePoint, record: Record, pending: Dict[int, Dict[int, Unsettled]]) -> None:
    """The progress and the unsettled commands of `point` in the numbering of the reroute's plan
    `record` (checked): it starts robot r with the old plan's move base[r], its first done[r] moves
    done already (as `Engine.adopt` counts them); a command's move beyond the new plan's is no
    move of it (as the driver's hand-over renumbers a turn in flight)."""
    robots, base, done, actions = record["robots"], record["base"], record["done"], record["actions"]
    started = dict(point.started)
    point.completed = {rid: done[a] for a, rid in enumerate(robots)}
    point.started = {rid: max(done[a], started.get(rid, 0) - base[a]) for a, rid in enumerate(robots)}
    for a, rid in enumerate(robots):
        for u in pending.get(rid, {}).values():
            if u.action is not None:
                k = u.action - base[a]
                u.action = k if 0 <= k < actions[a] else None
    point.plan = str(record["file"])
    point.passes.clear()


def _counts(value: Any, n: int) -> bool:
    """`value` is a list of `n` whole numbers, none negative."""
    return isinstance(value, list) and len(value) == n and all(
        isinstance(v, int) and not isinstance(v, bool) and v >= 0 for v in value)


def _mode(value: Any, otherwise: str) -> str:
    """A reroute mode read from a record (`otherwise` for anything else)."""
    from fleet_common.execution.reroute import MODES
    return value if isinstance(value, str) and value in MODES else otherwise


def _scope(value: Any, otherwise: str) -> str:
    """A reroute scope read from a record (`otherwise` for anything else)."""
    from fleet_common.execution.reroute import SCOPES
    return value if isinstance(value, str) and value in SCOPES else otherwise


def _number(value: Any) -> float:
    return float(value) if isinstance(value, (int, float)) and not isinstance(value, bool) else 0.0


def _point(value: Any) -> Optional[Point]:
    if isinstance(value, list) and len(value) == 2 and all(isinstance(v, (int, float)) for v in value):
        return float(value[0]), float(value[1])
    return None


def _command(r: Record) -> Optional[Command]:
    """The wire command a `command` record describes (None: one not to send again)."""
    kind, cid = r.get("type"), r["id"]
    try:
        if kind == "drive":
            return DriveToPosition(cid, float(r["x"]), float(r["y"]), float(r.get("time") or 0.0),
                                   _point(r.get("hold")))
        if kind == "turn":
            return Turn(cid, float(r["angle"]))
        if kind == "stop":
            return Stop(cid)
    except (KeyError, TypeError, ValueError):
        return None
    return None


class Resuming:
    """A resumed run before its check: whom it still waits for."""

    def __init__(self, point: ResumePoint, since: float) -> None:
        self.point = point
        self.since = since

    def waiting_for(self, fleet: Fleet, out: List[Optional[str]]) -> str:
        """Why the check cannot be made yet ("" when it can): robots not connected, without a
        pose since the restart, or that have not answered a command sent again."""
        reasons: Dict[str, List[int]] = {}
        for robot in fleet:
            if out[robot.agent] is not None:
                continue
            seen = robot.seen()
            if not robot.link_up:
                reasons.setdefault("not connected", []).append(robot.id)
            elif seen is None or seen.at < self.since:
                reasons.setdefault("no pose yet", []).append(robot.id)
            elif robot.flight is not None and not robot.flight.accepted:
                reasons.setdefault("no answer to its command yet", []).append(robot.id)
        if not reasons:
            return ""
        return "resuming {}: waiting for {}".format(self.point.folder.name, "; ".join(
            "robot{} {} ({})".format("s" if len(ids) > 1 else "", _ids(ids), why) for why, ids in reasons.items()))


@dataclass(frozen=True)
class OffPlan:
    """A robot not where the run left it: at `pose`, where its plan has it at `expected`
    (its last cell, or the move it makes), standing on `cell` (None: between cells)."""

    robot: Robot
    pose: Point
    expected: Coord
    cell: Optional[Coord]


def off_plan(fleet: Fleet, positions: List[Coord], out: List[Optional[str]], grid: Grid) -> List[OffPlan]:
    """The robots taking part that stand neither on the cell of their last completed action
    (`positions`, by agent) nor on the move they are making. A pose taken during a command
    that has completed since is older than the reply: the reply says where the robot is."""
    found: List[OffPlan] = []
    taken: Set[Coord] = set()
    for robot in fleet:
        pose = robot.pose
        if out[robot.agent] is not None or pose is None:
            continue
        if not robot.pose_settled():
            taken.add(positions[robot.agent])
            continue
        here = positions[robot.agent]
        flight = robot.flight
        if flight is not None and flight.kind == "drive" and robot.queue and robot.queue[0].index == flight.index:
            d = robot.queue[0]
            if to_segment((pose.x, pose.y), d.src, d.dst) <= AT_CELL:
                continue
        elif math.hypot(pose.x - here[0], pose.y - here[1]) <= AT_CELL:
            taken.add(here)
            continue
        cell = (int(round(pose.x)), int(round(pose.y)))
        on_cell = (math.hypot(pose.x - cell[0], pose.y - cell[1]) <= AT_CELL and grid.in_bounds(cell)
                   and bool(grid.free[cell[1], cell[0]]))
        found.append(OffPlan(robot, (pose.x, pose.y), here, cell if on_cell else None))
    # two robots cannot be replanned from one cell: the second is between cells for planning
    out_cells: List[OffPlan] = []
    for o in found:
        if o.cell is not None and o.cell in taken:
            o = OffPlan(o.robot, o.pose, o.expected, None)
        if o.cell is not None:
            taken.add(o.cell)
        out_cells.append(o)
    return out_cells


def walls_around(pose: Point, reach: float, grid: Grid, keep: Set[Coord]) -> Set[Coord]:
    """Cells whose centre is closer than `reach` (cells) to `pose`, but for those in `keep`
    (cells robots stand on): a robot between cells, planned around."""
    walls: Set[Coord] = set()
    r = int(math.ceil(reach))
    cx, cy = int(round(pose[0])), int(round(pose[1]))
    for x in range(cx - r, cx + r + 1):
        for y in range(cy - r, cy + r + 1):
            if (x, y) not in keep and grid.in_bounds((x, y)) and math.hypot(x - pose[0], y - pose[1]) < reach:
                walls.add((x, y))
    return walls


def passes_near(start: Point, end: Coord, pose: Point, distance: float) -> bool:
    """The straight drive from `start` to `end` comes closer than `distance` to `pose`."""
    return to_segment(pose, start, end) < distance


def _ids(ids: List[int]) -> str:
    return ", ".join(str(i) for i in ids)
