"""The state stream's content: what every console is told, many times a second.

Built from the manager's parts (engine, driver, links, positions) into the
console protocol's `State`; nothing here changes anything. Robots are named
by their robot_definitions.txt id throughout, also in who waits for whom.
"""
from __future__ import annotations

import math
from typing import TYPE_CHECKING, Dict, List, Optional, Tuple

from fleet_common.control import Activity, RobotState, RunInfo, State, Waiting
from fleet_common.execution import Wait

from .positions import ROBOT, VICON

if TYPE_CHECKING:  # only for annotations: the manager imports this module
    from .manager import Manager

__all__ = ["build_state", "robot_waits"]


def robot_waits(manager: "Manager") -> Dict[int, Waiting]:
    """Who waits for whom, by robot id (engine waits, and robots held by their own link or fault)."""
    slots = manager.driver.slots
    out: Dict[int, Waiting] = {}
    for w in manager.engine.waiting():
        out[slots[w.robot].robot_id] = _waiting(w, manager)
    run = manager.engine.run
    for slot in slots:
        if run.finished_robot(slot.agent) or run.out[slot.agent] is not None:
            continue
        if not slot.link_up:
            out[slot.robot_id] = Waiting((), None, "link")
        elif slot.hold == "recover":
            out[slot.robot_id] = Waiting((), None, "recovering")
    return out


def _waiting(w: Wait, manager: "Manager") -> Waiting:
    slots = manager.driver.slots
    return Waiting(tuple(slots[a].robot_id for a in w.on), w.cell, w.reason)


def build_state(manager: "Manager", now: float, seq: int,
                waits: Optional[Dict[int, Waiting]] = None) -> State:
    engine, driver, positions = manager.engine, manager.driver, manager.positions
    run = engine.run
    clock = manager.clock_now(now)
    plan_time = clock / manager.step_time if manager.step_time > 0 else 0.0
    waits = robot_waits(manager) if waits is None else waits
    robots: List[RobotState] = []
    arrived = 0
    for slot in driver.slots:
        r, rid = slot.agent, slot.robot_id
        done, total = run.completed[r], run.count(r)
        finished = done >= total
        if finished and run.out[r] is None:
            arrived += 1
        nxt = run.next_incomplete(r)
        step = run.step[nxt] if nxt >= 0 else engine.table.makespan
        x, y, theta, source = _pose(manager, rid)
        link = manager.links[rid]
        flight = slot.flight
        activity = None if flight is None else Activity(
            flight.kind, flight.index,
            *((flight.target[0], flight.target[1], None) if flight.kind == "drive"
              else (None, None, flight.target[0] if flight.target else None)))
        behind = 0.0
        if manager.run_state == "running" and not finished and run.out[r] is None:
            behind = max(0.0, plan_time - step)
        robots.append(RobotState(
            id=rid, link=link.state, link_reason=manager.link_reasons.get(rid, ""),
            x=x, y=y, theta=theta, source=source, age=positions.age(rid, now, source),
            stale=positions.stale(rid, now), faults=slot.faults, out=run.out[r],
            activity=activity, done=done, total=total, step=step, waiting=waits.get(rid),
            behind=round(behind, 2), vicon_age=positions.age(rid, now, VICON),
            disagree=positions.disagreeing.get(rid, False)))
    info = RunInfo(
        state=manager.run_state, reason=manager.run_reason, strategy=engine.strategy.name,
        lookahead=int(getattr(engine.strategy, "lookahead", 1)), clock=round(clock, 3),
        plan_time=round(plan_time, 3), plan_id=manager.plan_id, arrived=arrived,
        robots=len(driver.slots), min_distance=manager.min_distance, collisions=manager.collisions,
        proposal=manager.replanner.proposal_id, replanning=manager.replanner.busy)
    return State(seq, manager.desk.version, info, tuple(robots))


def _pose(manager: "Manager", rid: int) -> Tuple[Optional[float], Optional[float], Optional[float], str]:
    """The chosen source's pose; the other source's if the chosen one never saw the robot."""
    positions = manager.positions
    chosen = positions.source[rid]
    for source in (chosen, VICON if chosen == ROBOT else ROBOT):
        seen = (positions.vicon if source == VICON else positions.robot)[rid]
        if seen is not None:
            p = seen.pose
            theta = p.theta if math.isfinite(p.theta) else None
            return p.x, p.y, theta, source
    return None, None, None, chosen
