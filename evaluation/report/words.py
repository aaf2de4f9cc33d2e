"""A run folder's records in words: what a person reads in the report's event table.

Each record of `events.jsonl` (but the poses and who-waits-for-whom, which the
charts show) becomes one line: when, which robot, what kind, and a sentence
("robot 3 disabled by the operator", "replan: plan-2.txt", "console@lab: start
refused: not connected: robot 4"). Cells are written in the plan file's own
coordinates, as the manager, `fleetctl validate` and the console write them.
Replans and operator actions are marked (`mark`), so the table can highlight
them and the timelines can show them. Pure: records in, lines out.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable, Dict, Iterable, List, Optional, Sequence, Tuple

__all__ = ["Line", "words", "OPERATOR", "REPLAN"]

#: Marks of the lines the timelines show too.
OPERATOR, REPLAN = "operator", "replan"

Show = Callable[[Sequence[float]], Tuple[float, float]]
Record = Dict[str, Any]


@dataclass(frozen=True)
class Line:
    t: float
    kind: str
    robot: Optional[int]
    text: str
    mark: str = ""   # OPERATOR, REPLAN or ""


def _as_is(cell: Sequence[float]) -> Tuple[float, float]:
    return (float(cell[0]), float(cell[1]))


def _cell(cell: Any, show: Show) -> str:
    if not isinstance(cell, (list, tuple)) or len(cell) < 2:
        return "?"
    x, y = show(cell)
    return "({:g}, {:g})".format(round(x, 2), round(y, 2))


def _operator(rec: Record) -> Tuple[str, Optional[int]]:
    args = rec.get("args") or {}
    action = str(rec.get("action"))
    robot = args.get("robot") if action in ("enable", "disable", "source") else None
    what = {"enable": "enable robot {}".format(robot), "disable": "disable robot {}".format(robot),
            "to_starts": "go to starts", "strategy": "strategy {}".format(args.get("name")),
            "source": "position source {}".format(args.get("source")),
            "load": "load {}".format(args.get("name") or args.get("path")),
            "accept": "accept replan {}".format(args.get("proposal")),
            "reject": "reject replan {}".format(args.get("proposal"))}.get(action, action)
    answer = "" if rec.get("ok") else " refused: {}".format(rec.get("reason"))
    if rec.get("ok") and rec.get("reason"):
        answer = " ({})".format(rec["reason"])
    return "{}: {}{}".format(rec.get("console") or "an operator", what, answer), robot


def _line(rec: Record, show: Show) -> Optional[Line]:
    k, t, robot = str(rec.get("k")), float(rec.get("t", 0.0)), rec.get("robot")
    if k == "run":
        text = "run of {} begins: {} robots, strategy {}{}".format(
            rec.get("plan_name") or rec.get("plan"), len(rec.get("robots") or []), rec.get("strategy"),
            " (the robots drive to the starts of {})".format(rec.get("for_plan")) if rec.get("purpose") == "to-starts"
            else "")
    elif k == "state":
        text = "run {}{}".format(rec.get("run"), ": " + rec["reason"] if rec.get("reason") else "")
    elif k == "operator":
        text, robot = _operator(rec)
        return Line(t, k, robot, text, OPERATOR if rec.get("ok") else "")
    elif k == "strategy":
        text = "strategy {}{}".format(rec.get("name"), " (by the operator)" if rec.get("by") == "operator" else "")
    elif k == "plan":
        return Line(t, k, None, "{}: {} from here on".format(
            "replan" if rec.get("reason") == "replan" else str(rec.get("reason")), rec.get("file")), REPLAN)
    elif k == "out":
        why = rec.get("why")
        text = "robot {} {}".format(robot, "back in the run ({})".format(rec.get("reason")) if why is None
                                    else "disabled ({})".format(rec.get("reason")) if why == "disabled"
                                    else "held: {}".format(rec.get("reason")))
    elif k == "fault":
        faults = rec.get("faults") or []
        text = "robot {} {}".format(robot, "reports " + ", ".join(faults) if faults else "fault cleared")
    elif k == "link":
        text = "robot {} link {}{}{}".format(robot, rec.get("state"), ": " + rec["reason"] if rec.get("reason") else "",
                                             " (restarted)" if rec.get("restarted") else "")
    elif k == "dispatch":
        waited = float(rec.get("waited") or 0.0)
        text = "robot {} may make move {} (plan step {}) to {}{}".format(
            robot, int(rec.get("index", 0)) + 1, rec.get("step"), _cell(rec.get("dst"), show),
            ", after waiting {:.1f} s".format(waited) if waited > 0.05 else "")
    elif k == "command":
        kind = rec.get("type")
        text = "robot {}: {}".format(robot, "drive to {}".format(_cell((rec.get("x"), rec.get("y")), show))
                                     if kind == "drive" else "turn to {:.0f} degrees".format(
                                         float(rec.get("angle") or 0.0) * 57.29578) if kind == "turn" else str(kind))
    elif k == "reply":
        text = "robot {}: command {} {}{}".format(robot, rec.get("id"), rec.get("type"),
                                                  ": " + rec["reason"] if rec.get("reason") else "")
    elif k == "action":
        text = "robot {} {} move {} from {} to {}".format(
            robot, "starts" if rec.get("phase") == "started" else "ends", int(rec.get("index", 0)) + 1,
            _cell(rec.get("src"), show), _cell(rec.get("dst"), show))
    elif k == "vicon":
        text = "robot {}: {}".format(robot, rec.get("what") or rec.get("state") or "Vicon")
    elif k == "end":
        text = "run ends: {}".format(rec.get("reason"))
    else:
        text = "{}".format({key: v for key, v in rec.items() if key not in ("k", "t", "robot")})[:160]
    return Line(t, k, robot if isinstance(robot, int) else None, text)


def words(records: Iterable[Record], show: Show = _as_is) -> List[Line]:
    """Every record but poses and waits, in words."""
    out: List[Line] = []
    for rec in records:
        if rec.get("k") in ("poses", "waits"):
            continue
        line = _line(rec, show)
        if line is not None:
            out.append(line)
    return out
