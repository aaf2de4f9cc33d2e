"""In-app replanning (thesis ch. 7): a new plan for the robots still in the run, proposed first.

When robots are out for good (a dead battery), the ones that wait for them
wait forever. A replan gets the others to their goals around them:

1. the run is paused and the replanner waits for a *safe point*: no robot
   in the middle of a command, so every robot that takes part stands on a
   cell of the plan and nobody is mid-move across the switch, and every
   connected robot's pose taken since its last reply (`Robot.pose_settled`:
   a late pose, taken before a bumper stopped the robot, shows it short of
   where it stands, and the cell it leans into would go unwalled);
2. it asks for planning (a `PlanJob`, which the manager's loop runs in a
   worker thread while it keeps serving robots and consoles): every robot
   that takes part from the cell it holds to its goal, with the out robots
   as obstacles (`fleet_common.planning.replan`, time-limited), walling off
   the second cell of every robot standing between two cells (`walled`),
   but for a robot taking part that leans into a cell free of everyone
   else: it is planned from that cell, the move into it first (`going_on`,
   `prefixed`), so that it finishes the move it is half through;
3. the result comes back (`finished`) and is proposed to the consoles;
   `accept` switches the run to it (and resumes if the run was running),
   `reject` goes back to the old plan. The cells walled off for it stay
   walled for every reroute of that plan (`Rerouting.keep_to`): a reroute
   planned on the whole map could send a robot into the cell an out robot
   leans into, or past a robot left between cells.

`Replanner` is the state machine of one replan at a time; it starts no
thread and reads no clock. The old and the new plan both stay in the run
folder (plan-1.txt, plan-2.txt).
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Dict, Iterable, Iterator, List, Optional, Sequence, Set, Tuple

import numpy as np

from fleet_common.grid import Coord, Grid
from fleet_common.plan import Plan
from fleet_common.planning.replan import ReplanResult

from .driver import AT_CELL
from .outbox import PlanJob
from .robot import Robot

__all__ = ["Replanner", "Pending", "IDLE", "SAFE_POINT", "PLANNING", "PROPOSED", "going_on", "placed",
           "prefixed", "stood_on", "to_segment", "towards", "walled"]

IDLE, SAFE_POINT, PLANNING, PROPOSED = "idle", "safe-point", "planning", "proposed"


@dataclass
class Pending:
    """A computed proposal awaiting the operator."""

    id: int
    result: ReplanResult
    current: List[Coord]
    out: Set[int]
    grid: Grid  # the map it was planned on: walls included (`walled`, `Run.walls`)
    #: the engine's progress when it was planned (`Run.progress`): a robot that moved since has
    #: left the cell the plan starts it on
    progress: Tuple[Tuple[int, ...], ...] = ()


class Replanner:
    def __init__(self, time_limit: float = 5.0, ids: Optional[Iterator[int]] = None) -> None:
        self.state = IDLE
        self._progress: Tuple[Tuple[int, ...], ...] = ()
        self.default_limit = time_limit
        self.time_limit = time_limit
        self.method = "pp"
        self.was_running = False
        self.pending: Optional[Pending] = None
        self._job: Optional[PlanJob] = None
        self._first: Dict[int, Coord] = {}
        self._ids = ids if ids is not None else iter(range(1, 2 ** 62))  # shared with other planning jobs

    @property
    def busy(self) -> bool:
        return self.state in (SAFE_POINT, PLANNING)

    @property
    def proposal_id(self) -> Optional[int]:
        return self.pending.id if self.state == PROPOSED and self.pending is not None else None

    @property
    def open(self) -> bool:
        """Being made or awaiting an answer: the run may not start or step meanwhile."""
        return self.busy or self.proposal_id is not None

    def request(self, was_running: bool, time_limit: Optional[float], method: Optional[str]) -> None:
        self.state = SAFE_POINT
        self.was_running = was_running
        self.time_limit = time_limit or self.default_limit
        self.method = method or "pp"

    def job(self, grid: Grid, current: List[Coord], goals: List[Coord], out: Set[int],
            first: Optional[Dict[int, Coord]] = None, progress: Tuple[Tuple[int, ...], ...] = ()) -> PlanJob:
        """At the safe point: the planning to run (and the replanner waits for its result);
        `first`: agents planned from a cell next to theirs, with the move into it first (`prefixed`);
        `progress`: the run's progress now (`Pending.progress`)."""
        self._job = PlanJob(next(self._ids), grid, current, goals, out, self.time_limit, self.method)
        self._first = dict(first or {})
        self._progress = progress
        self.state = PLANNING
        return self._job

    def finished(self, job_id: int, result: Optional[ReplanResult], error: Optional[str]) -> Optional[str]:
        """The job's outcome (a result, or why planning raised): a line for the operator."""
        job = self._job
        if self.state != PLANNING or job is None or job.id != job_id:
            return None  # a job for a replan that was given up
        self._job = None
        if error is not None or result is None:
            self.state = IDLE
            return "replanning failed: " + (error or "no result")
        if result.plan is None:
            self.state = IDLE
            return "replanning found no plan: {}".format(result.message)
        if self._first:
            result = dataclasses.replace(result, plan=prefixed(result.plan, self._first))
        current = [self._first.get(a, c) for a, c in enumerate(job.current)]
        self.pending = Pending(job.id, result, current, job.out, job.grid, self._progress)
        self.state = PROPOSED
        return "replan {} proposed: {}".format(job.id, result.message)

    def resolved(self) -> None:
        self.state = IDLE
        self.pending = None


def stood_on(grid: Grid, robots: Sequence[Robot], here: Sequence[Coord], keep: Set[int] = frozenset()) -> List[Coord]:
    """`here` (each robot's cell by the engine's record), with a robot whose pose is on another
    free cell, nobody's, in that cell: one halted or stopped by a fault at the very end of a
    move the engine took back stands in its target, and is planned from there (walled in at
    its old cell, it could never be planned into the target, were that its goal). But the
    agents `keep`: short of that cell's centre, they finish their move into it (`going_on`)."""
    out = list(here)
    taken = {tuple(c) for c in here}
    for robot in robots:
        pose = robot.pose
        if pose is None or robot.agent in keep:
            continue
        cell = (int(round(pose.x)), int(round(pose.y)))
        if (cell != tuple(here[robot.agent]) and cell not in taken and grid.in_bounds(cell) and grid.is_free(cell)
                and math.hypot(pose.x - cell[0], pose.y - cell[1]) <= AT_CELL):
            out[robot.agent] = cell
            taken.add(cell)
    return out


def leans_into(robot: Robot, cell: Coord) -> Optional[Coord]:
    """The neighbour of `cell` that `robot`'s pose leans towards, if it stands between two
    cells (farther than `AT_CELL` from `cell`'s centre); None if it stands on it, or its pose
    was taken before its last command ended (the callers wait for one taken since, or know
    from the reply that the move completed), or it has none."""
    pose = robot.pose
    if pose is None or not robot.pose_settled() or math.hypot(pose.x - cell[0], pose.y - cell[1]) <= AT_CELL:
        return None
    return towards((pose.x, pose.y), cell)


def towards(point: Tuple[float, float], cell: Coord) -> Coord:
    """The neighbour of `cell` that `point` (off its centre) lies towards, along the larger offset."""
    dx, dy = point[0] - cell[0], point[1] - cell[1]
    return ((cell[0] + (1 if dx > 0 else -1), cell[1]) if abs(dx) >= abs(dy)
            else (cell[0], cell[1] + (1 if dy > 0 else -1)))


def walled(grid: Grid, robots: Sequence[Robot], here: Sequence[Coord], skip: Set[int] = frozenset(),
           halfway: Iterable[Coord] = ()) -> Grid:
    """`grid` with the far cell of every robot standing between two cells blocked (but those of
    the agents `skip`: `going_on` plans them into it): the neighbour of its cell its pose
    leans towards. That is the target of the move an out robot stopped in,
    and the cell a robot leans into that an earlier replan left between cells (it gave it no
    move; out, or enabled since) or that was pushed off its cell. At a safe point nobody else
    stands between cells (a follower at its hold point is in the middle of its drive). The
    cells of `halfway` too (`Run.halfway_cells`: robots out with no pose, by the engine's record)."""
    free = grid.free.copy()
    # a robot's own cell stays its start; but not the cell one finishing its move leaves (wide
    # carrying seed 673: robot 4, halted leaning into the cell robot 2 was halted leaving, was
    # left there unwalled, a cell the others could be planned through half a cell from it)
    taken = {tuple(here[r.agent]) for r in robots if r.agent not in skip}
    fars = [None if robot.agent in skip else leans_into(robot, here[robot.agent]) for robot in robots]
    for far in fars + [tuple(c) for c in halfway]:
        if far is not None and grid.in_bounds(far) and far not in taken:  # a robot's own cell stays its start
            free[far[1], far[0]] = False
    return Grid(free, name=grid.name)


def going_on(grid: Grid, robots: Sequence[Robot], here: Sequence[Coord], out: Set[int],
             walls: Iterable[Coord] = ()) -> Dict[int, Coord]:
    """The robots taking part that stand between their cell and a free cell nobody else
    leans into or keeps walled (`walls`), and that nobody holds but a robot going on out of it:
    agent -> that cell. A replan plans each from that cell and gives it first the move into it
    (`prefixed`), so it finishes the move it is half through; behind a robot going on, in the
    same step, as a follower (big session 142: robots halted in a row, each half into the cell of
    the one ahead, that one half out of it; planned from its own cell, the last one stood half
    into a cell the others could be planned through once its holder left, found "moved by hand").
    Walled in, a robot halted half into its goal and then enabled could never be planned home;
    planned from the far cell with no move, the run would count it arrived while it stands
    between the two."""
    holder = {tuple(c): a for a, c in enumerate(here)}
    walls = set(walls)
    leaning = {robot.agent: leans_into(robot, here[robot.agent]) for robot in robots}
    wanted: Dict[Coord, List[int]] = {}  # every robot's, as `walled` walls them
    for agent, far in leaning.items():
        if far is not None:
            wanted.setdefault(far, []).append(agent)
    for robot in robots:  # between its cell and that one, not pushed off elsewhere
        far, pose = leaning[robot.agent], robot.pose
        if far is not None and pose is not None and to_segment((pose.x, pose.y), here[robot.agent], far) > AT_CELL:
            leaning[robot.agent] = None
    could = {agent: far for agent, far in leaning.items()
             if far is not None and agent not in out and grid.in_bounds(far) and grid.is_free(far)
             and far not in walls and len(wanted[far]) == 1}
    going: Dict[int, Coord] = {}
    grew = True
    while grew:  # into a free cell first, then behind those going on out of theirs (no cycle: none starts)
        grew = False
        for agent, far in could.items():
            if agent not in going and (far not in holder or holder[far] in going):
                going[agent] = far
                grew = True
    return going


def placed(grid: Grid, robot: Robot, here: Coord) -> bool:
    """Whether a replan can plan `robot` (the run has it on `here`) from where it stands: on
    `here` or another free cell's centre (`stood_on`), or between `here` and a neighbour
    (`going_on`, `walled`); not when it stands between two other cells, carried off its
    line. Without a pose taken since its last reply, as far as anyone knows."""
    pose = robot.pose
    if pose is None or not robot.pose_settled() or math.hypot(pose.x - here[0], pose.y - here[1]) <= AT_CELL:
        return True
    cell = (int(round(pose.x)), int(round(pose.y)))
    if math.hypot(pose.x - cell[0], pose.y - cell[1]) <= AT_CELL and grid.in_bounds(cell) and grid.is_free(cell):
        return True
    far = leans_into(robot, here)
    return far is not None and to_segment((pose.x, pose.y), here, far) <= AT_CELL


def prefixed(plan: Plan, first: Dict[int, Coord]) -> Plan:
    """`plan` (made with the agents of `first` standing in the cells `going_on` gave them) with
    one step before it: those agents at their cells of `first`, then moving into the cells the
    plan starts them in, while everyone else waits."""
    if not first:
        return plan
    row = plan.positions[:1].copy()
    for agent, cell in first.items():
        row[0, agent] = cell
    orientations = None if plan.orientations is None else np.concatenate(
        [plan.orientations[:1], plan.orientations])
    return Plan(np.concatenate([row, plan.positions]), orientations)


def to_segment(p: Tuple[float, float], a: Tuple[float, float], b: Tuple[float, float]) -> float:
    """Distance from point `p` to the segment between the centres of cells `a` and `b`."""
    dx, dy = b[0] - a[0], b[1] - a[1]
    length = dx * dx + dy * dy
    f = 0.0 if length == 0 else min(1.0, max(0.0, ((p[0] - a[0]) * dx + (p[1] - a[1]) * dy) / length))
    return math.hypot(p[0] - (a[0] + f * dx), p[1] - (a[1] + f * dy))
