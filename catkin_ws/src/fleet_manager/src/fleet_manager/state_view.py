"""What every console is told: the State (many times a second), the RunSetup and a Proposal.

Built from the run core's own records (its robots, the engine, the run's
phase) into the console protocol's messages; nothing here changes anything.
Robots are named by their robot_definitions.txt id throughout, also in who
waits for whom.
"""
from __future__ import annotations

import math
from typing import Dict, List, Optional, Sequence, Tuple

from fleet_common.control import (Activity, PlanData, Proposal, RobotInfo, RobotState, RunInfo, RunSetup,
                                  State, Waiting)
from fleet_common.execution import STRATEGIES, Engine
from fleet_common.execution.events import FOLLOW
from fleet_common.execution.reroute import Reroute
from fleet_common.grid import Grid
from fleet_common.plan import Plan
from fleet_common.robot_size import RobotSize

from .following import Following
from .replanning import Pending, Replanner
from .robot import VICON, Fleet
from .run_phase import RUNNING, RunPhase

__all__ = ["robot_waits", "build_state", "setup", "proposal", "reroute_proposal", "plan_data"]


#: A follower this close (cells) to its hold point stands there, waiting for its leader.
AT_HOLD = 0.08


def robot_waits(engine: Engine, fleet: Fleet, following: Following) -> Dict[int, Waiting]:
    """Who waits for whom, by robot id (engine waits, followers standing at their hold point, and
    robots held by their link or a restart)."""
    out: Dict[int, Waiting] = {}
    for w in engine.waiting():
        out[fleet[w.agent].id] = Waiting(tuple(fleet[a].id for a in w.on), w.cell, w.reason)
    for agent, hold in following.holds.items():
        robot = fleet[agent]
        pose, leader = robot.pose, following.leader_of(agent)
        if hold is not None and pose is not None and leader is not None and robot.queue \
                and math.hypot(pose.x - hold[0], pose.y - hold[1]) <= AT_HOLD:
            out[robot.id] = Waiting((fleet[leader].id,), robot.queue[0].dst, FOLLOW)
    run = engine.run
    for robot in fleet:
        if run.finished_agent(robot.agent) or run.out[robot.agent] is not None:
            continue
        if not robot.link_up:
            out[robot.id] = Waiting((), None, "link")
        elif robot.hold == "recover":
            out[robot.id] = Waiting((), None, "recovering")
    return out


def build_state(seq: int, version: int, now: float, clock: float, plan_steps: float, engine: Engine,
                fleet: Fleet, phase: RunPhase, plan_id: int, replanner: Replanner,
                min_distance: Optional[float], collisions: int,
                waits: Dict[int, Waiting], following: Following, purpose: str = "plan",
                allowed: Optional[Tuple[str, ...]] = None, why_not: Optional[Dict[str, str]] = None,
                reroute: str = "off",
                reroute_proposal: Optional[int] = None, plan_start: float = 0.0,
                reroute_scope: str = "held", trim: bool = False) -> State:
    """The State at `now`; `clock` is the seconds since the run started (0 before), `plan_steps`
    the plan steps since the current plan's step 0 (a robot's `behind` is measured from it; the
    plan's clock shown stops at the makespan), `plan_start` the run's plan steps before that step 0
    (earlier plans of the run: the clock a console shows goes on across a reroute); `why_not` says
    why the run actions not `allowed` would be refused (one line each)."""
    run = engine.run
    plan_time = plan_steps
    running = phase.phase == RUNNING
    leaders = {agent: following.leader_of(agent) for agent in following.holds}
    robots: List[RobotState] = []
    arrived = 0
    for robot in fleet:
        agent = robot.agent
        done, total = run.completed[agent], run.count(agent)
        finished = done >= total
        if finished and run.out[agent] is None:
            arrived += 1
        nxt = run.next_incomplete(agent)
        step = run.step[nxt] if nxt >= 0 else engine.table.makespan
        seen, source = fleet.shown(robot)
        pose = None if seen is None else seen.pose
        flight = robot.flight
        activity = None if flight is None else Activity(
            flight.kind, flight.index,
            *((flight.target[0], flight.target[1], None) if flight.kind == "drive"
              else (None, None, flight.target[0] if flight.target else None)))
        behind = max(0.0, plan_time - step) if running and not finished and run.out[agent] is None else 0.0
        robots.append(RobotState(
            id=robot.id, link=robot.link, link_reason=robot.link_reason,
            x=None if pose is None else pose.x, y=None if pose is None else pose.y,
            theta=None if pose is None or not math.isfinite(pose.theta) else pose.theta,
            source=source, age=robot.age(now, source), stale=fleet.stale(robot, now),
            faults=robot.faults, out=run.out[agent], activity=activity, done=done, total=total,
            step=step, waiting=waits.get(robot.id), behind=round(behind, 2),
            vicon_age=robot.age(now, VICON), disagree=robot.disagreeing,
            follows=None if leaders.get(agent) is None else fleet[leaders[agent]].id))
    info = RunInfo(
        state=phase.phase, reason=phase.reason, strategy=engine.strategy.name,
        lookahead=int(getattr(engine.strategy, "lookahead", 1)), clock=round(clock, 3),
        plan_time=round(min(plan_time, float(engine.table.makespan)), 3), plan_id=plan_id, arrived=arrived,
        robots=len(fleet), min_distance=min_distance, collisions=collisions,
        proposal=replanner.proposal_id if reroute_proposal is None else reroute_proposal,
        replanning=replanner.busy, purpose=purpose, allowed=allowed, reroute=reroute,
        plan_start=round(plan_start, 3), reroute_scope=reroute_scope, trim=trim, why_not=why_not)
    return State(seq, version, info, tuple(robots))


def plan_data(plan_id: int, plan: Plan, fleet: Fleet, name: str = "") -> PlanData:
    return PlanData(plan_id, tuple(fleet.ids), plan.positions, name)


def setup(grid: Grid, fleet: Fleet, plan_id: int, plan: Plan, name: str, step_time: float,
          size: RobotSize, orientation: str = "mapf-ir") -> RunSetup:
    rows = tuple("".join("." if grid.free[y, x] else "@" for x in range(grid.width))
                 for y in range(grid.height - 1, -1, -1))
    robots = tuple(RobotInfo(r.id, r.colour, r.vicon_name) for r in fleet)
    return RunSetup(grid.name or "map", rows, robots, plan_data(plan_id, plan, fleet, name),
                    tuple(STRATEGIES), step_time, (size.diameter, size.margin, size.cell),
                    "base" if orientation == "base" else "mapf-ir")


def reroute_proposal(pid: int, found: Reroute, fleet: Fleet, name: str) -> Proposal:
    """A reroute awaiting the operator, as the replan's proposal is shown (its message: the line
    saying who goes round whom)."""
    ids = fleet.ids
    plan = found.plan
    return Proposal(pid, plan_data(pid + 1000, plan, fleet, name), found.describe(lambda a: ids[a]),
                    int(plan.soc), int(plan.makespan), (), "reroute")


def proposal(pending: Pending, fleet: Fleet, name: str) -> Proposal:
    plan = pending.result.plan
    unreachable: Sequence[int] = tuple(fleet[a].id for a in sorted(pending.result.unreachable))
    return Proposal(pending.id, plan_data(pending.id + 1000, plan, fleet, name), pending.result.message,
                    int(plan.soc), int(plan.makespan), tuple(unreachable))
