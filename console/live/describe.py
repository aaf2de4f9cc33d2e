"""What the live console says about a robot, in words: list rows, details, who blocks whom.

Pure functions of the protocol's `RobotState` and `RunInfo` (and of whether
the manager is there at all), shared by the admin panel's robot list, the
robot panel and the labels on the map, so that all three say the same thing.

Positions are written through a `Place` (base cells -> the coordinates the
window shows: by default the plan file's own, as the manager's messages).

A robot is *greyed* when what the map shows of it cannot be trusted or it
takes no part: its link is down, it reports a fault, it is out (disabled or
failed), its pose is stale, or the manager itself is lost. It stays on the
map and in the list, with the reason (rmf-web#166: never silently vanish).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable, Dict, List, Optional, Sequence, Tuple

from fleet_common.control import RobotState, RunInfo

__all__ = ["BEHIND_MARK", "RobotRow", "Place", "greyed", "row", "details", "blocked_chain", "cell_text"]

#: A position in base cells -> as the window shows it (the plan file's coordinates by default).
Place = Callable[[float, float], Tuple[float, float]]


def as_is(x: float, y: float) -> Tuple[float, float]:
    return (x, y)

#: A robot this many plan steps behind the plan's clock is marked as late (ADG lets robots
#: drift a step from the clock in normal running; more is a hold-up).
BEHIND_MARK = 1.5


def cell_text(cell: Optional[Sequence[float]], place: Place = as_is) -> str:
    if cell is None:
        return "-"
    x, y = place(float(cell[0]), float(cell[1]))
    return "({:g}, {:g})".format(round(x, 1) + 0.0, round(y, 1) + 0.0)


def greyed(r: Optional[RobotState], connected: bool = True) -> Optional[str]:
    """Why robot `r` is greyed, or None if it is not."""
    if not connected:
        return "manager lost"
    if r is None:
        return "no state yet"
    if r.link != "up":
        return "link {}{}".format(r.link, ": " + r.link_reason if r.link_reason else "")
    if r.faults:
        return "fault: " + ", ".join(r.faults)
    if r.out is not None:
        return r.out
    if r.x is None:
        return "no pose yet"
    if r.stale:
        return "pose stale ({})".format(age_text(r.age))
    return None


def age_text(age: Optional[float]) -> str:
    return "never seen" if age is None else "{:.1f} s old".format(age)


def action_text(r: RobotState, place: Place = as_is) -> str:
    a = r.activity
    if a is None:
        if r.total and r.done >= r.total:
            return "at goal"
        return "-" if r.waiting is None else "waiting"
    if a.kind == "drive" and a.x is not None and a.y is not None:
        return "drive to {} (#{})".format(cell_text((a.x, a.y), place), (a.index or 0) + 1)
    if a.kind == "turn" and a.angle is not None:
        return "turn to {:.0f}\u00b0".format(math.degrees(a.angle) % 360)
    return a.kind


def waiting_text(r: RobotState) -> str:
    w = r.waiting
    if w is None:
        return ""
    if w.on:
        return "{} ({})".format(", ".join(str(o) for o in w.on), w.reason)
    return w.reason


@dataclass(frozen=True)
class RobotRow:
    """One line of the admin panel's robot list."""

    id: int
    link: str
    pose: str         # source and age
    enabled: bool
    action: str
    waiting: str
    grey: Optional[str]
    behind: bool
    blocked: bool = False  # waits for other robots (not for a pause or its own link)


def row(robot_id: int, r: Optional[RobotState], connected: bool = True, place: Place = as_is) -> RobotRow:
    grey = greyed(r, connected)
    if r is None:
        return RobotRow(robot_id, "?", "-", True, "-", "", grey, False)
    pose = "{} {}".format(r.source, "-" if r.age is None else "{:.1f} s".format(r.age))
    if r.stale:
        pose += " stale"
    return RobotRow(robot_id, r.link, pose, r.out != "disabled", action_text(r, place), waiting_text(r),
                    grey, r.behind >= BEHIND_MARK, r.waiting is not None and bool(r.waiting.on))


def details(r: RobotState, run: Optional[RunInfo], place: Place = as_is) -> List[Tuple[str, str]]:
    """(label, value) pairs for the robot panel."""
    pose = "-" if r.x is None or r.y is None else "({:.2f}, {:.2f}){}".format(
        *place(r.x, r.y), "" if r.theta is None else ", {:.0f}\u00b0".format(math.degrees(r.theta) % 360))
    out = [
        ("link", r.link + (": " + r.link_reason if r.link_reason else "")),
        ("pose", pose),
        ("source", "{}, {}{}".format(r.source, age_text(r.age), ", STALE" if r.stale else "")),
        ("Vicon", "not seen" if r.vicon_age is None else age_text(r.vicon_age)
         + (", DISAGREES with the robot" if r.disagree else "")),
        ("faults", ", ".join(r.faults) or "none"),
        ("state", r.out or "enabled"),
        ("action", action_text(r, place)),
        ("progress", "{} of {} moves, next at plan step {:g}".format(
            r.done, r.total, round(r.step + (run.plan_start if run is not None else 0.0), 1))),
        ("timing", "{:.1f} steps behind the plan".format(r.behind) if r.behind > 0 else "on time"),
    ]
    if r.waiting is not None:
        out.append(("waiting", "{}{}{}".format(
            r.waiting.reason, " to enter " + cell_text(r.waiting.cell, place) if r.waiting.cell else "",
            " for " + ", ".join("robot {}".format(o) for o in r.waiting.on) if r.waiting.on else "")))
    return out


def blocked_chain(robots: Dict[int, RobotState], robot_id: int, limit: int = 8,
                  place: Place = as_is) -> List[str]:
    """Who `robot_id` waits for, who that one waits for, and so on, as sentences."""
    lines: List[str] = []
    seen = {robot_id}
    current = robots.get(robot_id)
    while current is not None and len(lines) < limit:
        w = current.waiting
        if w is None:
            if current.id != robot_id:
                grey = greyed(current)
                lines.append("robot {} {}".format(current.id, grey if grey else action_text(current, place)))
            break
        where = " to enter " + cell_text(w.cell, place) if w.cell else ""
        if not w.on:
            lines.append("robot {} waits ({}){}".format(current.id, w.reason, where))
            break
        lines.append("robot {} waits for robot{} {}{} ({})".format(
            current.id, "s" if len(w.on) > 1 else "", ", ".join(str(o) for o in w.on), where, w.reason))
        nxt = w.on[0]
        if nxt in seen:
            lines.append("... robot {} again: a cycle".format(nxt))
            break
        seen.add(nxt)
        current = robots.get(nxt)
    return lines
