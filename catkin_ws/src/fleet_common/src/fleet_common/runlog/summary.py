"""A run's figures from its records alone: arrivals, makespan, costs, waits, collisions, distances.

The manager feeds each record to a `SummaryBuilder` as it writes it, and
`fleetctl trace` feeds the records read back from a run folder: one
computation, so what the manager printed at the end and what the folder says
later are the same numbers.

- the run begins at its first `state` record with run "running"; times are
  seconds (or plan steps) from there;
- a robot *arrives* when it completes the last action of the current plan
  (a robot with none has arrived at the start); the executed makespan is the
  latest arrival, the sum of costs adds the arrivals of the robots that
  arrived, as mapf-IR counts them for plans;
- total wait adds the `waited` of every dispatch: the time robots were ready
  to move but not allowed to; of it, *held* when the operator released the
  robot (`released_by` null), *forced* as each dispatch's `forced` says (the
  robot ahead in the cell, or on its way into it, or the cell the robot's
  goal: no change of order could have helped), *avoidable* the rest;
- each robot's *own time* adds, move by move, the time from its dispatch (or
  its previous completion, if it had the move already) to its completion; the
  *lower bound* is the largest own time: the makespan had every robot run
  alone with its own delays, and the executed makespan is compared with it;
- *passes* count the `pass` records: a re-ordering strategy let a robot into
  a cell before one that was due first and was late;
- for robots as large as a cell (a `run` record without a size, or with a
  cell-sized one), collisions are judged from the executed moves (drive sent
  until completed: a robot holds both cells meanwhile) by
  `fleet_common.execution.trace`, the checker `fleetctl simulate` uses,
  counted move by move so that reading the summary mid-run costs nothing;
- for robots of their real size, a collision is a pair of robots whose
  reported centres were ever closer than the safe distance (diameter +
  margin) in a `poses` record: the live count from poses. Two poses of one
  record were reported at different moments (each record gives their age):
  a pair counts only when closer than the safe distance less what either
  robot could cover in between, at the fastest its own poses showed it go,
  and less the record's rounding (`POSE_ROUNDING`), so that a follower
  standing at its hold point, exactly the safe distance away, is not counted;
- the smallest distance between two robots is taken over every `poses`
  record (the positions the run used: robot feedback or Vicon), in cells and,
  with the robots' size, metres;
- a run its manager did not live to finish and another resumed (`resume`
  records) is one run: its times include the time it stood still, and the
  summary says how often and how long.
- a run that began and ended (an `end` record: Ctrl-C, another plan, a reset)
  before it was done was interrupted: the summary says when and why, and how
  many of the plan's moves were executed by then.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Dict, List, Optional, Set, Tuple

from ..execution.trace import CollisionCount
from ..spacing import closest_pair, pairs_within

__all__ = ["RunSummary", "SummaryBuilder", "POSE_ROUNDING"]

#: How much a distance between two centres of a `poses` record may be off (cells): each
#: coordinate is written to 3 decimals (the manager's `log_poses`), off by 0.0005 at most.
POSE_ROUNDING = 2 * math.sqrt(2) * 0.0005

Record = Dict[str, Any]


@dataclass
class RunSummary:
    unit: str
    robots: int
    arrived: List[int]
    enabled: int
    makespan: float
    soc: float
    wait: float
    collisions: int
    swaps: int
    min_distance: Optional[float]
    closest: Optional[Tuple[int, int, float]]  # robots and the time
    disabled: List[int] = field(default_factory=list)
    failed: List[int] = field(default_factory=list)
    cell_m: Optional[float] = None   # metres a cell; None: a run of old, robots as large as a cell
    safe_m: Optional[float] = None   # the safe distance between centres, metres
    forced: Optional[float] = None   # of the wait: forced (None: a log of old, not split)
    held: float = 0.0                # of the wait: held by the operator
    lower_bound: float = 0.0         # the largest own time (every robot alone)
    passes: int = 0
    resumes: int = 0                 # managers started again on the run's folder
    downtime: float = 0.0            # time without a manager, in all
    interrupted: Optional[str] = None  # why the run ended before it was done (None: it was not)
    ended_at: float = 0.0            # when it ended, from its start
    moves: Tuple[int, int] = (0, 0)  # the plan's moves executed, and in all

    @property
    def avoidable(self) -> Optional[float]:
        return None if self.forced is None else max(0.0, self.wait - self.forced - self.held)

    def lines(self) -> List[str]:
        unit = "s" if self.unit == "s" else "steps"
        out = []
        if self.interrupted is not None:
            out.append("interrupted at {:.1f} {} ({}): {} of {} moves executed, {} of {} robots at their "
                       "goals".format(self.ended_at, unit, self.interrupted, self.moves[0], self.moves[1],
                                      len(self.arrived), self.enabled))
        out += ["arrived: {}/{}{}".format(len(self.arrived), self.enabled, "" if self.enabled == self.robots
                                          else " (of {} robots; {} out)".format(self.robots, self.robots - self.enabled)),
               ("executed so far: {:.2f} {} (the latest arrival {:.2f} {})".format(
                   self.ended_at, unit, self.makespan, unit) if self.interrupted is not None
                else "executed makespan: {:.2f} {}".format(self.makespan, unit)),
               "lower bound: {:.2f} {} (every robot alone, with its own delays){}".format(
                   self.lower_bound, unit, "" if self.lower_bound <= 0 or self.interrupted is not None else
                   "; executed makespan {:.2f}x it".format(self.makespan / self.lower_bound)),
               "sum of costs: {:.2f} {}".format(self.soc, unit),
               "total wait: {:.2f} {}{}".format(self.wait, unit, "" if self.forced is None else
                                                 " (forced {:.2f}: the robot ahead was in or on its way into the "
                                                 "cell, or it was the robot's goal; avoidable {:.2f}; held by the "
                                                 "operator {:.2f})".format(self.forced, self.avoidable, self.held)),
               "collisions: {}{}{}".format(self.collisions, " ({} swaps)".format(self.swaps) if self.swaps else "",
                                          "" if self.safe_m is None else
                                          " (pairs closer than {:.3f} m)".format(self.safe_m))]
        if self.min_distance is None:
            out.append("min distance: - (fewer than two robots seen)")
        else:
            a, b, t = self.closest or (0, 0, 0.0)
            metres = "" if self.cell_m is None else "{:.3f} m, ".format(self.min_distance * self.cell_m)
            out.append("min distance: {}{:.2f} cells (robots {} and {} at {:.1f} {})".format(
                metres, self.min_distance, a, b, t, unit))
        if self.passes:
            out.append("passes: {} (a robot went into a cell before a late one that was due first)".format(
                self.passes))
        if self.resumes:
            out.append("resumed: {} time{} after its manager stopped ({:.1f} {} without one)".format(
                self.resumes, "s" if self.resumes > 1 else "", self.downtime, unit))
        if self.disabled:
            out.append("disabled: robots {}".format(", ".join(map(str, self.disabled))))
        if self.failed:
            out.append("failed: robots {}".format(", ".join(map(str, self.failed))))
        return out

    def as_dict(self) -> Dict[str, Any]:
        return {"arrived": len(self.arrived), "enabled": self.enabled, "robots": self.robots,
                "makespan": round(self.makespan, 3), "soc": round(self.soc, 3),
                "wait": round(self.wait, 3), "collisions": self.collisions,
                "forced": None if self.forced is None else round(self.forced, 3),
                "avoidable": None if self.avoidable is None else round(self.avoidable, 3),
                "held": round(self.held, 3), "lower_bound": round(self.lower_bound, 3),
                "passes": self.passes,
                "min_distance": None if self.min_distance is None else round(self.min_distance, 3),
                "min_distance_m": None if self.min_distance is None or self.cell_m is None
                else round(self.min_distance * self.cell_m, 4),
                "safe_m": self.safe_m, "resumes": self.resumes, "downtime": round(self.downtime, 3),
                "unit": self.unit, "interrupted": self.interrupted,
                "moves": list(self.moves), "lines": self.lines()}  # as printed, for reports


class SummaryBuilder:
    """Fed records in order (`feed`); `summary()` at any time."""

    def __init__(self) -> None:
        self.unit = "s"
        self.robots: List[int] = []           # robot id by agent
        self.agent: Dict[int, int] = {}       # robot id -> agent
        self.actions: List[int] = []          # actions per agent in the current plan
        self.done: List[int] = []             # of them completed
        self.begin: Optional[float] = None
        self.arrival: Dict[int, float] = {}   # agent -> arrival (absolute t)
        self.last_completion: Dict[int, float] = {}
        self.out: Dict[int, str] = {}         # robot id -> "disabled" | "failed"
        self.wait = 0.0
        self.forced: Optional[float] = 0.0  # None once a dispatch without the split was seen
        self.held = 0.0
        self.passes = 0
        self.own: Dict[int, float] = {}              # agent -> own time so far
        self.busy: Dict[int, float] = {}             # agent -> since when on its current move
        self.ahead: Dict[int, int] = {}              # agent -> actions dispatched (current plan)
        self.counted: Optional[CollisionCount] = None  # the executed moves' collisions
        self.sent: Dict[Tuple[int, int], float] = {}  # (robot, action) -> drive sent
        self.started: Dict[int, Tuple[float, Tuple[int, int], Tuple[int, int]]] = {}
        self.min_distance: Optional[float] = None
        self.closest: Optional[Tuple[int, int, float]] = None
        self.cell_m: Optional[float] = None
        self.safe: Optional[float] = None         # cells; None: robots as large as a cell
        self.too_close: Set[Tuple[int, int]] = set()  # pairs of robot ids seen closer than safe
        self._reported: Dict[int, Tuple[float, float, float, float]] = {}  # robot -> t, x, y, speed
        self.resumes = 0
        self.downtime = 0.0
        self.done_at: Optional[float] = None      # the run was done (a `state` record "done")
        self.end: Optional[Tuple[str, float]] = None  # the `end` record: why, when
        self.moves_before = 0                     # moves executed under earlier plans (replans)

    def feed(self, record: Record) -> None:
        kind = record.get("k")
        t = float(record.get("t", 0.0))
        if kind == "run":
            self.unit = str(record.get("time_unit", "s"))
            self._size(record.get("size"))
            self._plan(record, t, first=True)
        elif kind == "plan" and record.get("reason") != "loaded":
            self._plan(record, t, first=False)
        elif kind == "state":
            if record.get("run") == "running":
                if self.begin is None:
                    self.begin = t
                self.done_at = None  # a new leg after the end
            elif record.get("run") == "done":
                self.done_at = t
        elif kind == "end":
            self.end = (str(record.get("reason") or "ended"), t)
        elif kind == "dispatch":
            self._dispatch(record, t)
        elif kind == "pass":
            self.passes += 1
            i = self.agent.get(record.get("passed"))  # type: ignore[arg-type]
            since = self.busy.pop(i, None) if record.get("taken_back") and i is not None else None
            if since is not None:  # it gave its move back: its own time stops until sent again
                self.own[i] = self.own.get(i, 0.0) + max(0.0, t - since)  # type: ignore[index]
        elif kind == "command" and record.get("type") == "drive" and record.get("action") is not None:
            self.sent.setdefault((record["robot"], record["action"]), t)
        elif kind == "action":
            self._action(record, t)
        elif kind == "out":
            why = record.get("why")
            if why is None:
                self.out.pop(record["robot"], None)
            else:
                self.out[record["robot"]] = why
        elif kind == "poses":
            self._poses(record, t)
        elif kind == "resume":
            self.resumes += 1
            self.downtime += float(record.get("downtime") or 0.0)

    def _dispatch(self, record: Record, t: float) -> None:
        waited = float(record.get("waited") or 0.0)
        self.wait += waited
        if record.get("released_by") is None and record.get("cause") is None:
            self.held += waited  # no robot released it, nor the rerouting: the operator did
        elif "forced" not in record:
            self.forced = None
        elif self.forced is not None:
            self.forced += min(float(record.get("forced") or 0.0), waited)
        i = self.agent.get(record.get("robot"))  # type: ignore[arg-type]
        index = record.get("index")
        if i is None or not isinstance(index, int) or i >= len(self.done):
            return
        self.ahead[i] = max(self.ahead.get(i, 0), index + 1)
        if index == self.done[i] and i not in self.busy:
            self.busy[i] = t

    def _size(self, size: Any) -> None:
        try:
            cell, safe = float(size["cell_m"]), float(size["safe_m"])
        except (TypeError, KeyError, ValueError):
            return  # a run of old: robots as large as a cell
        if cell > 0 and 0 < safe:
            self.cell_m = cell
            self.safe = None if safe >= cell else safe / cell

    def _plan(self, record: Record, t: float, first: bool) -> None:
        self.moves_before += sum(self.done)
        robots = list(record.get("robots") or [])
        self.robots = robots
        self.agent = {r: i for i, r in enumerate(robots)}
        self.actions = list(record.get("actions") or [0] * len(robots))
        self.done = [0] * len(robots)
        base, done = record.get("base"), record.get("done")
        if _counts(base, len(robots)) and _counts(done, len(robots)):
            # a reroute: the robots went on mid-move, their moves renumbered from `base`; a
            # follower's move made before its leader left is the new plan's first, done already
            # (counted under the plan before)
            self.done = [max(0, min(d, n)) for d, n in zip(done, self.actions)]
            self.moves_before -= sum(self.done)
            ids = {r: i for i, r in enumerate(robots)}
            self.sent = {(r, k - base[ids[r]]): t for (r, k), t in self.sent.items()
                         if r in ids and isinstance(k, int) and k >= base[ids[r]]}
            self.ahead = {i: max(0, n - base[i]) for i, n in self.ahead.items() if i < len(base)}
        else:
            self.sent.clear()
            self.busy.clear()
            self.ahead.clear()
        starts = [tuple(c) for c in record.get("starts") or []]
        if first and len(starts) == len(robots):
            self.counted = CollisionCount(starts)
        elif self.counted is not None and len(starts) == len(robots) and not _counts(base, len(robots)):
            # a replan starts each robot where it stands: one stopped near the end of a move it
            # never completed (a halt, a fault) stands on that move's target, one moved by hand
            # elsewhere; either held both cells from the move's start (or now) until now
            for i, cell in enumerate(starts):
                began = self.started.pop(i, None)
                self.counted.stood(i, cell, began[0] if began is not None else t, t)  # type: ignore[arg-type]
        # robots the plan leaves where they stand, away from their goals (out when a replan was
        # made: `fleet_manager.run.Run.stranded`) have not arrived
        stranded = {self.agent[r] for r in record.get("stranded") or [] if r in self.agent}
        for i, n in enumerate(self.actions):
            if n <= self.done[i] and i not in stranded:
                self.arrival.setdefault(i, self.last_completion.get(i, t if not first else t))
            else:
                self.arrival.pop(i, None)

    def _action(self, record: Record, t: float) -> None:
        i = self.agent.get(record.get("robot"))  # type: ignore[arg-type]
        if i is None:
            return
        src, dst = record.get("src"), record.get("dst")
        if record.get("phase") == "started" and src is not None and dst is not None:
            since = self.sent.get((record["robot"], record.get("index")), t)
            self.started[i] = (since, tuple(src), tuple(dst))  # type: ignore[assignment]
        elif record.get("phase") == "completed":
            began = self.started.pop(i, None)
            if self.counted is not None and src is not None and dst is not None:
                start = began[0] if began is not None else t
                try:
                    self.counted.add(i, start, t, tuple(src), tuple(dst))  # type: ignore[arg-type]
                except ValueError:
                    pass  # a hole in the log (a crash): the count skips the move, not the run
            self.done[i] = min(self.done[i] + 1, self.actions[i] if i < len(self.actions) else 0)
            since = self.busy.pop(i, None)
            if since is not None:
                self.own[i] = self.own.get(i, 0.0) + max(0.0, t - since)
            if self.ahead.get(i, 0) > self.done[i]:
                self.busy[i] = t
            self.last_completion[i] = t
            if i < len(self.actions) and self.done[i] >= self.actions[i]:
                self.arrival[i] = t

    def _poses(self, record: Record, t: float) -> None:
        points = {}
        taken: Dict[int, float] = {}
        for entry in record.get("p") or []:
            if isinstance(entry, list) and len(entry) >= 3 and entry[1] is not None and entry[2] is not None:
                points[entry[0]] = (float(entry[1]), float(entry[2]))
                age = entry[5] if len(entry) >= 6 and isinstance(entry[5], (int, float)) else 0.0
                taken[entry[0]] = t - float(age)
        found = closest_pair(points)
        if found is not None and (self.min_distance is None or found[0] < self.min_distance):
            self.min_distance = found[0]
            self.closest = (found[1], found[2], t)
        if self.safe is not None:
            speed = self._speeds(points, taken)
            if found is not None and found[0] < self.safe - POSE_ROUNDING:
                for a, b in pairs_within(points, self.safe):
                    moved = max(speed.get(a, 0.0), speed.get(b, 0.0)) * abs(taken[a] - taken[b])
                    d = math.hypot(points[a][0] - points[b][0], points[a][1] - points[b][1])
                    if d < self.safe - moved - POSE_ROUNDING:
                        self.too_close.add((a, b))

    def _speeds(self, points: Dict[int, Tuple[float, float]], taken: Dict[int, float]) -> Dict[int, float]:
        """Each robot's top speed so far (cells a time unit), from its consecutive poses."""
        out = {}
        for r, (x, y) in points.items():
            last = self._reported.get(r)
            when = taken[r]
            if last is None or when > last[0] + 1e-6:
                speed = 0.0 if last is None else math.hypot(x - last[1], y - last[2]) / (when - last[0])
                self._reported[r] = (when, x, y, max(speed, last[3] if last is not None else 0.0))
            out[r] = self._reported[r][3]
        return out

    @property
    def collisions(self) -> int:
        """Collisions so far (cheap: counted as they come): pairs seen closer than the safe
        distance, or for robots as large as a cell, among the executed moves."""
        if self.safe is not None:
            return len(self.too_close)
        return self.counted.collisions if self.counted is not None else 0

    def summary(self) -> RunSummary:
        begin = self.begin if self.begin is not None else 0.0
        interrupted = None
        if self.begin is not None and self.done_at is None and self.end is not None:
            interrupted = self.end[0]
        # a robot held by a fault still takes part (it has not arrived); disabled ones do not
        enabled = [i for i, r in enumerate(self.robots) if self.out.get(r) != "disabled"]
        arrived = sorted(self.robots[i] for i in enabled if i in self.arrival)
        times = [max(0.0, self.arrival[i] - begin) for i in enabled if i in self.arrival]
        return RunSummary(
            unit=self.unit, robots=len(self.robots), arrived=arrived, enabled=len(enabled),
            makespan=max(times, default=0.0), soc=sum(times), wait=self.wait,
            collisions=self.collisions, swaps=self.counted.swaps if self.counted is not None else 0,
            min_distance=self.min_distance,
            closest=None if self.closest is None else (
                self.closest[0], self.closest[1], max(0.0, self.closest[2] - begin)),
            disabled=sorted(r for r, why in self.out.items() if why == "disabled"),
            failed=sorted(r for r, why in self.out.items() if why == "failed"),
            cell_m=self.cell_m, safe_m=None if self.safe is None or self.cell_m is None
            else round(self.safe * self.cell_m, 6),
            forced=self.forced, held=self.held, lower_bound=max(self.own.values(), default=0.0),
            passes=self.passes, resumes=self.resumes, downtime=self.downtime, interrupted=interrupted,
            ended_at=0.0 if self.end is None else max(0.0, self.end[1] - begin),
            moves=(self.moves_before + sum(self.done), self.moves_before + sum(self.actions)))


def _counts(value: Any, n: int) -> bool:
    """A list of `n` whole numbers (a record's per-agent counts)."""
    return isinstance(value, list) and len(value) == n and all(
        isinstance(v, int) and not isinstance(v, bool) and v >= 0 for v in value)
