"""Followers on the wire: the hold point a follower's drive carries, moved on as its leader goes.

Theory of operation. Robots smaller than a cell follow one another
(`fleet_common.execution.engine`): a robot may be sent into a cell that another
robot is still leaving. Its drive then carries a hold point, and it stops
there unless the manager lets it on. The hold point is the farthest point of
the follower's move from which it stays at least the safe distance (diameter
+ margin) from every point of the leader's path still ahead of the leader
(`fleet_common.execution.following.hold_fraction`). Where the leader is comes
from its last reported pose, read along the move the engine knows it is
making (not before its start: it completed the move before; not past its end:
it has not completed this one), and the point it really stands on or drives from
if that is off the line (a robot halted just into a move, planned from its cell since, leaves
the cell from where it stands: a follower held from the cell's centre came 0.55 cells from it;
its drive, from there to the end of its move, is part of its path). Each new pose of a leader
moves its followers' hold points on (a `Release`, sent when the point moved on by `STEP` or more),
and its completion of the move out of the cell lets them drive to the end.

Why it is safe, whatever the delays and latencies. A leader only ever moves
on along its path (a halted or restarted robot resumes the same move; a replan
starts from a safe point). So a reported position is never ahead of the
truth but for the localization error the margin covers, and a hold point
computed from it is never too far: the truth is at least as far from the
follower. A pose counts only when the robot took it while running the drive
of the very move the engine says it is making (the pose's `current`
command): a pose taken earlier, even one that arrives after the move's
predecessor completed, may lie anywhere on the robot's way here, also ahead
on a line it now drives back along. Otherwise, the leader is taken to stand
at the start of its move, and also where it was last seen, whatever it was
doing then: a point more on the leader's path only holds the follower
shorter, and the start alone is not always behind it (big operator session
716: a leader stopped 0.06 cells short of its cell's centre, towards its
follower, was turning in place; its last pose, taken before the turn, no
longer counted as settled, and the follower, held from the centre, stopped
0.62 cells from it, the safe distance 0.65). Without any pose, the start. A
late pose, a lost pose or a lost link only keeps the hold point where it
was; the follower then stops short and waits, and so does the robot behind
it. A follower's own stop at the hold point is its own controller's (the
robot holds the point even if it loses the manager), which may overshoot it a
little: the distance the hold point keeps (`safe`, given by the run) is the
safe distance plus that overshoot (`robot_size.STOP_OVERSHOOT_M`). The hold point is
computed from the follower's move start: a follower already closer than
that (it cannot be, but for localization error) is held where it stands.
A follower drives from where it stands, which may be off its cell's centre
(within `AT_CELL`), and its own controller stops at the hold point's
projection on that line: the distance kept grows by how far it stands off
the move's line (`_off_line`), so its own stop keeps the safe distance.
"""
from __future__ import annotations

import math
from typing import Dict, Optional, Set, Tuple

from fleet_common.execution import Dispatch, Engine
from fleet_common.execution.following import hold_fraction, point_at

from .robot import Fleet, Robot

__all__ = ["Following", "STEP"]

#: A hold point moved on by less than this (cells) is not worth a message.
STEP = 0.05

Point = Tuple[float, float]


class Following:
    """Who follows whom on the wire, and the hold point each follower's drive last had."""

    def __init__(self, engine: Engine, fleet: Fleet, safe: Optional[float]) -> None:
        self.engine = engine
        self.fleet = fleet
        self.safe = safe  # cells; None: robots as large as a cell, nobody follows
        #: follower agent -> its drive's hold point (None: released to the end)
        self.holds: Dict[int, Optional[Point]] = {}
        #: leader agent -> follower agents whose drives it holds
        self.followers: Dict[int, Set[int]] = {}
        #: follower agent -> its leader (the same pairs, looked up the other way: the loop asks
        #: for every held follower's leader each turn, so no scan of `followers`)
        self._leader: Dict[int, int] = {}

    def hold_for(self, d: Dispatch) -> Optional[Point]:
        """The hold point of a drive for dispatch `d` (None: nothing holds it)."""
        if d.follows is None or self.safe is None:
            return None
        leader, index = d.follows
        run = self.engine.run
        lead = run.first[leader] + index
        if run.done[lead]:
            return None
        path = self._leader_path(leader, lead)
        f = hold_fraction(d.src, d.dst, path, self.safe + _off_line(self.fleet[d.agent], d.src, d.dst))
        return None if f >= 1.0 else point_at(d.src, d.dst, f)

    def sent(self, d: Dispatch, hold: Optional[Point]) -> None:
        """A drive for `d` went out with `hold`."""
        self._forget(d.agent)
        if hold is not None and d.follows is not None:
            self.holds[d.agent] = hold
            self.followers.setdefault(d.follows[0], set()).add(d.agent)
            self._leader[d.agent] = d.follows[0]

    def moved(self, leader: int) -> Dict[int, Optional[Point]]:
        """Leader `leader` reported a pose or completed a move: its followers whose hold point
        moved on enough to say so, and the new point (None: to the end of the move)."""
        out: Dict[int, Optional[Point]] = {}
        for agent in list(self.followers.get(leader, ())):
            robot = self.fleet[agent]
            d = robot.queue[0] if robot.queue else None
            if d is None or d.follows is None or d.follows[0] != leader:
                self._forget(agent)
                continue
            new = self.hold_for(d)
            old = self.holds.get(agent)
            if new is None:
                self._forget(agent)
                out[agent] = None
            elif old is None or math.hypot(new[0] - old[0], new[1] - old[1]) >= STEP:
                self.holds[agent] = new
                out[agent] = new
        return out

    def leader_of(self, agent: int) -> Optional[int]:
        return self._leader.get(agent)

    def _forget(self, agent: int) -> None:
        self.holds.pop(agent, None)
        leader = self._leader.pop(agent, None)
        if leader is not None:
            agents = self.followers[leader]
            agents.discard(agent)
            if not agents:
                del self.followers[leader]

    def _leader_path(self, leader: int, lead: int):
        """From where leader is known to be along the move it is making, to the end of `lead`."""
        run, table = self.engine.run, self.engine.table
        a0 = min(run.first[leader] + run.completed[leader], lead)
        src, dst = table.coord(run.src[a0]), table.coord(run.dst[a0])
        robot = self.fleet[leader]
        f = 0.0
        here: Optional[Point] = None  # where it stands or drives from, off the line of its move
        pose, flight = robot.own, robot.flight
        if (pose is not None and flight is not None and flight.kind == "drive"
                and flight.index == a0 - run.first[leader] and robot.own_current == flight.id):
            dx, dy = dst[0] - src[0], dst[1] - src[1]
            f = min(1.0, max(0.0, (pose.pose.x - src[0]) * dx + (pose.pose.y - src[1]) * dy))
            here = (pose.pose.x, pose.pose.y)
        elif (flight is None or flight.kind == "turn") and robot.pose is not None and robot.pose_settled():
            here = (robot.pose.x, robot.pose.y)
        else:
            here = _last_seen(robot)
        start = point_at(src, dst, f)
        ahead = [table.coord(run.dst[a]) for a in range(a0, lead + 1)]
        if here is None or math.hypot(here[0] - start[0], here[1] - start[1]) < 1e-6:
            return [start] + ahead
        return [start, here] + ahead


def _last_seen(robot: Robot) -> Optional[Point]:
    """Where `robot` was last seen, whatever it was doing then (None: never): a point more on a
    leader's path to keep away from only holds its follower shorter."""
    pose = robot.pose
    return None if pose is None else (pose.x, pose.y)


def _off_line(robot: Robot, src: Point, dst: Point) -> float:
    """How far `robot`'s pose (0: none) stands off the line of its move src -> dst. It drives from
    where it stands, so every point of its drive ahead is at most that far from the point of the
    move the hold is reckoned on, and a hold point kept that much farther off is safe on its own
    line (big session 2330: a follower 0.24 cells off its cell's centre, held on the move's line,
    stopped on its own 0.63 cells from its leader, the safe distance 0.65)."""
    pose = robot.pose
    if pose is None:
        return 0.0
    dx, dy = dst[0] - src[0], dst[1] - src[1]
    length = math.hypot(dx, dy)
    if length < 1e-9:
        return 0.0
    return abs((pose.x - src[0]) * dy - (pose.y - src[1]) * dx) / length
