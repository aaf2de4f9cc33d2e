"""The story of a run in words, for a visitor: "robot 2 stalled", "robot 3 waits for robot 2".

`Ticker` reads the manager's States as they arrive, with their arrival time,
and its notices, and says in a few words what a visitor has just watched:
the run starting and ending, a robot that stands still in the middle of a
drive (stalled) and moves again, a robot that waits for others or stops behind
the robot it follows (once the wait has lasted a moment: under the ADG robots
wait for a few milliseconds all the time), a robot disabled or enabled by the
operator, held by a fault, losing its link, replans and reroutes. The live
console puts the sentences in its event list and in the presentation view's
ticker. Pure (time comes with each State), and cheap enough for 300 robots
twenty times a second.
"""
from __future__ import annotations

import math
import re
from dataclasses import dataclass
from typing import Dict, List, Optional, Tuple

from fleet_common.control import Notice, RunInfo, State
from fleet_common.execution.events import FOLLOW

__all__ = ["Ticker", "STALL_AFTER", "WAIT_AFTER"]

#: Seconds a driving robot stands still before it counts as stalled (at least; and at least the
#: time a plan step is expected to take, as the manager says: a fast fleet stalls sooner).
STALL_AFTER = 0.8
#: Seconds a wait lasts before it is told (at least; and at least half a plan step).
WAIT_AFTER = 0.5
#: A robot that moved less than this (cells) stood still.
STILL = 0.03
#: Sentences of one kind told for one State; the rest are counted in one more.
CROWD = 2


@dataclass
class _Robot:
    x: Optional[float] = None
    y: Optional[float] = None
    still_since: float = 0.0    # where it stands, since when (any robot)
    stall_clock: float = 0.0    # since when it may drive and does not move (waiting stops the clock)
    may_drive: bool = False     # at the State before: driving, nobody to wait for
    stalled: bool = False
    wait: Tuple[int, ...] = ()
    wait_since: float = 0.0
    wait_told: bool = False
    out: Optional[str] = None
    link: str = "up"
    doing: Optional[Tuple[str, Optional[int]]] = None  # the command it carries out (kind, action)


def _robots(ids: Tuple[int, ...]) -> str:
    return "robot {}".format(ids[0]) if len(ids) == 1 else "robots {}".format(", ".join(map(str, ids)))


class Ticker:
    def __init__(self) -> None:
        self._robots: Dict[int, _Robot] = {}
        self._run: Optional[RunInfo] = None
        self.step_time = STALL_AFTER  # seconds a plan step takes (the run setup's)

    def stalled(self) -> List[int]:
        """The robots stalled now (standing still in the middle of a drive, as told)."""
        return [rid for rid, seen in self._robots.items() if seen.stalled]

    def reset(self) -> None:
        """Another manager, or another plan: what was seen no longer counts."""
        self._robots = {}
        self._run = None

    # ---- the run ------------------------------------------------------------------------

    def _run_news(self, run: RunInfo) -> List[str]:
        before, self._run = self._run, run
        if before is None or (before.state, before.purpose) == (run.state, run.purpose):
            return []
        if run.state == "running":
            if run.purpose == "to-starts":
                return ["the robots drive to their starts"]
            if before.state == "done":
                return []  # a new leg: the robot's own line says it
            if before.state in ("paused", "stopped"):
                return ["the run goes on"]
            return ["the run starts: {} robots".format(run.robots)]
        if run.state == "paused":
            return ["halted: every robot stops where it is" if "halt" in run.reason
                    else "paused: robots finish their move"]
        if run.state == "stopped":
            return ["stopped by the operator: robots finish their move"]
        if run.state == "done" and run.purpose == "plan":
            return ["every robot is home: done in {:.0f} s, {}".format(
                run.clock, "no collision" if run.collisions == 0 else "{} collision{}".format(
                    run.collisions, "" if run.collisions == 1 else "s"))]
        if run.state == "waiting" and before.purpose == "to-starts":
            return ["every robot is on its start: ready to run"]
        return []

    # ---- the robots ---------------------------------------------------------------------

    def state(self, state: State, at: float) -> List[str]:
        """The sentences `state`, arrived at `at` (seconds), gives rise to."""
        said = self._run_news(state.run)
        running = state.run.state == "running"
        stall_after = max(STALL_AFTER, self.step_time)
        wait_after = max(WAIT_AFTER, 0.5 * self.step_time)
        stalls: List[str] = []
        waits: List[str] = []
        others: List[str] = []
        for r in state.robots:
            seen = self._robots.get(r.id)
            if seen is None:
                seen = self._robots[r.id] = _Robot(r.x, r.y, at, at, out=r.out, link=r.link)
            # standing still in the middle of a drive: stalled (a follower at its hold point waits)
            doing = None if r.activity is None else (r.activity.kind, r.activity.index)
            if doing != seen.doing:  # a new command: standing still counts from now
                seen.doing, seen.stall_clock = doing, at
            if r.x is not None and r.y is not None and (
                    seen.x is None or seen.y is None or math.hypot(r.x - seen.x, r.y - seen.y) > STILL):
                seen.x, seen.y, seen.still_since, seen.stall_clock = r.x, r.y, at, at
                if seen.stalled:
                    seen.stalled = False
                    others.append("robot {} moves again".format(r.id))
            driving = r.activity is not None and r.activity.kind == "drive" and r.waiting is None
            if driving and r.follows is not None:  # a follower behind a leader that stands waits for it
                leader = self._robots.get(r.follows)
                driving = leader is None or at - leader.still_since < stall_after
            if not driving or not seen.may_drive:
                seen.stall_clock = at  # waiting is no stall: the clock starts when it may drive again
            seen.may_drive = driving
            if running and driving and not seen.stalled and at - seen.stall_clock >= stall_after \
                    and r.link == "up" and not r.faults:
                seen.stalled = True
                stalls.append("robot {} stalled".format(r.id))
            # waiting for other robots, once it has lasted
            on = tuple(r.waiting.on) if r.waiting is not None else ()
            if on != seen.wait:
                seen.wait, seen.wait_since, seen.wait_told = on, at, False
            if on and running and not seen.wait_told and at - seen.wait_since >= wait_after:
                seen.wait_told = True
                # a follower held at its hold point stops short behind its leader: say what is seen
                verb = "stops behind" if r.waiting is not None and r.waiting.reason == FOLLOW else "waits for"
                waits.append("robot {} {} {}".format(r.id, verb, _robots(on)))
            # taken out and back in, by the operator or a fault
            if r.out != seen.out:
                if r.out == "disabled":
                    others.append("robot {} disabled by the operator".format(r.id))
                elif r.out == "failed":
                    others.append("robot {} stopped{}".format(r.id, ": " + ", ".join(r.faults) if r.faults else ""))
                elif seen.out is not None:
                    others.append("robot {} {}".format(r.id, "enabled again" if seen.out == "disabled"
                                                        else "back in the run"))
                seen.out = r.out
            if r.link != seen.link:
                if r.link in ("down", "failed"):
                    others.append("robot {} lost its link".format(r.id))
                elif r.link == "up" and seen.link in ("down", "failed"):
                    others.append("robot {} is back".format(r.id))
                seen.link = r.link
        return said + _few(stalls, "stalled") + _few(waits, "wait for others") + others

    def notice(self, notice: Notice) -> List[str]:
        """The manager's notices a visitor should read: replans, a new strategy, a robot that
        goes before a late one, robots rerouted round a late one, the reroute mode and trim."""
        if notice.kind == "plan" and notice.text.startswith("replanned"):
            return [notice.text.split(":")[0]]
        if notice.kind == "strategy" and " -> " in notice.text:
            return ["strategy now {}".format(notice.text.rsplit(" -> ", 1)[1].split(" (")[0])]
        if notice.kind == "pass":
            return [notice.text.split(" at ")[0]]
        if notice.kind == "reroute":  # the mode switched, or robots given new paths (not proposals)
            if notice.text.startswith("reroute switched: "):
                return ["rerouting now {}".format(_DROPPED.sub("", notice.text.rsplit(" -> ", 1)[1]))]
            if notice.text.startswith("robot") and " rerouted" in notice.text:  # made, not proposed
                return [_SOONER.sub("", notice.text)]
            if notice.text.startswith("trim on"):
                return ["plans now trimmed: fewer moves, nobody later"]
            if notice.text.startswith("trim off"):
                return ["plans now run as they are made"]
        return []


#: The tail of a reroute's line a visitor need not read ("; 9 steps sooner").
_SOONER = re.compile(r"[:;] (the last robot )?\d+ steps? sooner$")
#: The tail of a mode switch that dropped a proposal (" (reroute 4 dropped)").
_DROPPED = re.compile(r" \(reroute \d+ dropped\)$")


def _few(lines: List[str], what: str) -> List[str]:
    """At most CROWD sentences of one kind, then how many more."""
    if len(lines) <= CROWD + 1:
        return lines
    return lines[:CROWD] + ["and {} more robots {}".format(len(lines) - CROWD, what)]
