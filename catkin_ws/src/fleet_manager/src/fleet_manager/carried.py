"""Robots moved by hand while a run is under way: found, named, and nobody driven into them.

Lab staff pick up a robot they disabled (or a visitor pushes one standing still) and put it
down elsewhere while the manager runs. The engine still has it on the cell of its last
completed move, so every other robot's plan treats the cell it now stands on as free: the
next robot whose path crosses it drives into it (found by hand: a disabled robot carried onto
the next cell of another robot's path, Start pressed, the two centres met).

Theory of operation. A robot *stands where the run has it* when its pose is within `AT_CELL`
of the cell the run holds for it (`Run.positions`); or between that cell and a neighbour (on
the line between their centres) no nearer the neighbour's centre than the safe distance (nobody
in that cell comes nearer: a follower halted at its hold point behind a robot on that centre, big
session 338); or nearer, or on the neighbour's centre, when the run put it there: the
neighbour is the target of its next move and it was sent that move (halted, stopped by a fault
or at its very end) or no other robot is due in that cell before it (a replan's first move,
finishing one it was half through: `replanning.going_on`; behind the robot in that cell, which
leaves it next), or the plan keeps that cell walled
off around it while it makes no move, out or with none left (`replanning.walled`: a robot a
replan or the way to the starts left between cells; not the walls a takeover raises for its
replan, which the plan being run does not keep off); and on the neighbour's centre also when the run holds that
cell for another robot (nobody else enters it while that robot holds it). Anywhere else
between two cells it was pushed: a robot standing half a cell towards a free neighbour that
nobody is kept out of is 0.5 cells from whoever drives through it next (a visitor's push of
0.45 cells let robot 5 pass robot 3 at 0.55 cells, the safe distance 0.65). Only robots standing
still are judged (a link, no command in flight, a pose taken since their last reply,
`Robot.pose_settled`, and received after it): a moving robot's pose is somewhere on its drive,
and a pose taken before its last reply may show it short of where that reply left it (an idle
robot's own pose names no command: one taken before a quick command began, received before its
reply, showed robot 28 of 50 virtual robots a cell back).
Any other standing robot was moved by hand (`carried`). Before a run's first move only robots
out are judged (the others must stand on their starts for Start: `Run.not_ready`).

When a robot is found moved:

- a run under way halts (running: no new move is sent; robots whose drive passes within the
  safe distance of where the moved robot stands stop where they are, `passes_near`; the others
  finish their moves and stand), and the operator is told once;
- Start, Step and Enable are refused, naming the robot, where it stands and where the run has
  it, and what to do: put it back; or, under way, a replan, which plans from where it stands if
  that is a free cell's centre nobody holds (`replanning.stood_on`) or a neighbour's line it
  can finish or be walled in on (`replanning.placed`), and is refused while it stands between
  other cells (put it on a cell); or, once the run is done, Reset.

Why it is safe: a robot's plan only ever sends it into cells the engine believes free, and
the moved robot's cell is believed free only while the run has it elsewhere; once found, no
move is released until it is back where the run has it or a replan has it where it stands,
and no drive already under way that would pass near it goes on. The robot on a neighbour's
centre it was not sent into, where another robot is due first, counts as moved: that robot would
drive in. A stale pose: a robot's pose stops counting while its link is down or a command is in
flight, so a moved robot is found with its first pose after it is put down (judged ten times a
second); until then only drives sent before it was picked up go on, and those passing near where
it is found stop short. On Vicon, a robot Vicon has not seen for `stale_after` longer than its own
localization (staff stand between it and the cameras while they carry it) is judged on its own
pose instead, and the operator is told to choose that pose to replan from it. A robot moved while its
link is down is found once the link is back: nothing tells the manager where it is meanwhile. A
robot with no pose the run may use (Vicon has not seen it since the manager started, its own
names a command) is not judged: Start and replans plan from the engine's record, which walls off the cell a robot out stopped half into
(`Run.halfway_cells`). A pose taken before the robot's last motion began, delivered late, names
the motion ended before that one (`PoseFeedback.ended`) and does not count (`Robot.pose_settled`).
While a manager taking the run over waits for its robots, it judges them itself (`off_plan`), by
the same rule once they have answered (big session 12: a robot halted a fifth of a cell short of
its next cell was judged off the plan by the manager taking over, "replanned from" that cell).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Dict, List, Optional, Set, Tuple

from fleet_common.execution.run import RunState
from fleet_common.grid import Coord

from .driver import AT_CELL
from .replanning import to_segment, towards
from .resume import passes_near
from .robot import VICON, Robot
from .run_phase import DONE, PAUSED, RUNNING, STOPPED, WAITING

if TYPE_CHECKING:
    from .run import Run

__all__ = ["Carried", "carried", "carried_words", "clear_of", "halt_near", "replan_refusal", "where_the_run_has_it", "UNDER_WAY"]

#: the phases of a run under way, whose engine has every robot on a cell of its plan
UNDER_WAY = (RUNNING, PAUSED, STOPPED)


@dataclass(frozen=True)
class Carried:
    """A robot standing away from where the run has it."""

    robot: Robot
    pose: Tuple[float, float]
    here: Coord  # where the run has it
    own: bool = False  # by its own pose, Vicon (the chosen source) not seeing it


def carried(run: "Run") -> List[Carried]:
    """The robots standing still away from where the run has them (the module's docstring).
    Before a run's first move (waiting) only robots out are judged: the others must stand on
    their starts for Start (`Run.not_ready`), while one out stays where the run has it."""
    if run.resuming is not None:
        return []  # a manager taking the run over judges where every robot stands itself (`off_plan`)
    waiting = run.phase.phase == WAITING
    held = run.positions()
    state = run.engine.run
    holding = {tuple(c): a for a, c in enumerate(held)}
    found: List[Carried] = []
    for robot in run.fleet:
        if not robot.link_up or robot.flight is not None or (waiting and state.out[robot.agent] is None):
            continue
        here = tuple(held[robot.agent])
        for (x, y), own in _standing_poses(robot, run.fleet.stale_after):
            if not where_the_run_has_it(run, robot, (x, y), here, holding):  # type: ignore[arg-type]
                found.append(Carried(robot, (x, y), here, own))  # type: ignore[arg-type]
                break
    return found


def _standing_poses(robot: Robot, stale_after: float) -> List[Tuple[Tuple[float, float], bool]]:
    """Where robot `robot` (no command in flight) stands by the poses received since its last
    reply, and whether by its own pose where Vicon is the chosen source: the chosen source's,
    taken since that reply (`Robot.pose_settled`); but on Vicon, its own pose instead while Vicon
    has not seen it for `stale_after` longer than its own localization has (staff carrying a
    robot stand between it and the cameras: Vicon session 107 of `--carrying`, where a robot
    carried while occluded was planned through; and 237, where one put back while occluded was
    still seen where Vicon had last seen it)."""
    ended = robot.ended_at
    own, vicon = robot.own, robot.vicon
    if (robot.source == VICON and own is not None and robot.own_current is None and robot.own_settled()
            and (ended is None or own.at >= ended)
            and (vicon is None or own.at - vicon.at > stale_after)):
        return [((own.pose.x, own.pose.y), True)]
    seen = robot.seen()
    if seen is not None and robot.pose_settled() and (ended is None or seen.at >= ended):
        return [((seen.pose.x, seen.pose.y), False)]
    return []


def where_the_run_has_it(run: "Run", robot: Robot, pose: Tuple[float, float], here: Coord,
                          holding: Dict[Coord, int]) -> bool:
    """Whether a robot standing at `pose` stands where the run has it (`here`: its cell; `holding`:
    cell -> the agent the run has on it)."""
    if math.hypot(pose[0] - here[0], pose[1] - here[1]) <= AT_CELL:
        return True
    far = towards(pose, here)
    if to_segment(pose, here, far) > AT_CELL:
        return False
    if clear_of(pose, far, run.settings.size.safe_cells):
        return True
    # between its cell and that neighbour, or on the neighbour's centre: only where the run put it
    state, table = run.engine.run, run.engine.table
    a, nxt = robot.agent, state.next_incomplete(robot.agent)
    entering = nxt >= 0 and tuple(table.coord(state.dst[nxt])) == far and (
        state.dispatched[a] > state.completed[a] or bool(state.halfway[a])  # a move it was sent
        or _first_in(state, nxt))  # (a replan's first move, finishing one it was half through)
    holder = holding.get(far)
    # a cell the run holds for another robot: nobody else enters it while that one holds it; from
    # between cells, only while it stays there (out, or home: session 226, a robot halted leaning
    # into the cell of one a fault stopped on its way out); once it moves on, this one is judged again
    stays = holder is not None and (state.out[holder] is not None or state.next_incomplete(holder) < 0)
    on_far = math.hypot(pose[0] - far[0], pose[1] - far[1]) <= AT_CELL
    return entering or (holder is not None and (on_far or stays)) or _walled_in(run, a, far)


def _walled_in(run: "Run", agent: int, far: Coord) -> bool:
    """Whether the plan being run keeps everyone off `far`, next to the cell of the robot of
    `agent`, while that robot makes no move (out, or with none left). Not the walls a takeover
    raises for the replan it asks for (`Run.walls`): the plan being run goes through them (big
    carrying session 673: a robot put down on a cell walled round it, enabled, was taken for home
    on the cell next to it, and another robot's plan drove through it)."""
    kept, state = run.rerouting.maps.grid, run.engine.run
    return (far not in run.walls and not (kept.in_bounds(far) and kept.is_free(far))
            and (state.out[agent] is not None or state.next_incomplete(agent) < 0))


def clear_of(pose: Tuple[float, float], far: Coord, safe: float) -> bool:
    """Whether a robot at `pose`, on the line from its cell towards the neighbour `far`, is the
    safe distance `safe` (cells) or more from that neighbour's centre: whoever is in it, on its
    centre or driving through it, is no nearer."""
    return math.hypot(pose[0] - far[0], pose[1] - far[1]) >= safe


def _first_in(state: RunState, action: int) -> bool:
    """No other robot is due in the cell `action` enters before it: the previous visitor's move
    out of it (`RunState.dep`) is made, or there is none, or that visitor is in the cell now and
    leaves it next (a replan has robots halted in a row finish their moves one behind the other:
    `replanning.going_on`)."""
    d = state.dep[action]
    return (d < 0 or bool(state.done[d]) or state.agent[d] == state.agent[action]
            or state.next_incomplete(state.agent[d]) == d)


def carried_words(run: "Run", found: List[Carried]) -> str:
    """What to tell the operator of the robots `found` ("" if none), and what to do: under way,
    a replan plans from where they stand; when done, a Reset does; before the first move, the
    run has them on their starts."""
    if not found:
        return ""
    phase = run.phase.phase
    # before the first move the run has each robot on its start: one off it need not have been
    # moved by anyone (disabled on the way to the starts, it stayed where it was: live session 704)
    where = "off its start {}" if phase == WAITING else "away from {} where the run has it"
    parts = ["robot {} stands at {}{}, {}".format(
        c.robot.id, run.where(*c.pose), " by its own pose (Vicon has not seen robot {} since: choose its own "
        "pose, position source, to replan from there)".format(c.robot.id) if c.own else "",
        where.format(run.loaded.show(c.here))) for c in found[:3]]
    more = "; and {} more".format(len(found) - 3) if len(found) > 3 else ""
    one = len(found) == 1
    them, they = ("it", "it stands") if one else ("them", "they stand")
    back = "put {} back where {} {}".format(them, "it" if one else "they", "was" if one else "were")
    todo = ("{}, or on a free cell and replan (planned from where {})".format(back, they)
            if phase in UNDER_WAY else "{}, or Reset (the way to the starts starts from where {})".format(
                back, they) if phase == DONE else "put {} on {} start{}, or enable {}: Go to starts drives {} there".format(
                    them, "its" if one else "their", "" if one else "s", them, them))
    return "{}{}: {}".format("; ".join(parts), more, todo)


def replan_refusal(run: "Run", found: List[Carried]) -> Optional[str]:
    """Why a replan cannot plan from where a moved robot of `found` (`carried`) stands: between
    two cells other than its own and a neighbour, or on a cell the run holds for another robot
    (None: it can, `replanning.stood_on`, `replanning.placed`)."""
    taken: Set[Coord] = {tuple(c) for c in run.positions()}  # type: ignore[misc]
    for c in found:
        if to_segment(c.pose, c.here, towards(c.pose, c.here)) <= AT_CELL:
            continue  # pushed towards a neighbour: walled in or finishing that move (`replanning.placed`)
        cell = (int(round(c.pose[0])), int(round(c.pose[1])))
        if (math.hypot(c.pose[0] - cell[0], c.pose[1] - cell[1]) <= AT_CELL and run.grid.in_bounds(cell)
                and run.grid.is_free(cell) and cell not in taken):
            taken.add(cell)
            continue
        return ("robot {} stands at {}, away from {} where the run has it and not on a free cell's centre: put "
                "it on one (or back), then replan".format(c.robot.id, run.where(*c.pose), run.loaded.show(c.here)))
    return None


def halt_near(run: "Run", found: List[Carried], reach: float) -> List[Robot]:
    """Stop the robots whose drive under way passes within `reach` (cells) of a robot `found`;
    which were stopped."""
    moved = {id(c.robot) for c in found}
    near = [r for r in run.fleet if r.flight is not None and r.flight.kind == "drive" and r.pose is not None
            and id(r) not in moved
            and any(passes_near((r.pose.x, r.pose.y), (r.flight.target[0], r.flight.target[1]), c.pose, reach)
                    for c in found)]
    if near:
        run.driver.halt(near)
    return near
