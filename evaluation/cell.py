"""One cell of a sweep: one simulated run, and the row of the results table it gives
(a wire cell, `chain: wire`, runs in `wire_cell.py` instead).

Pure apart from the clock (`wall_s`): a cell is a plain `Cell` and a
`LoadedPlan`, so it runs the same in this process, a local worker or a Dask
worker. The delay draws depend on the plan, model and seed only, so the
strategies of one seed meet the very same delays (paired comparison).

With `disable`, the robot stops for good at that plan step; with `recover:
replan`, once the run stalls (nothing moves and robots wait for the disabled
one), the others are replanned from where they stand (`planning.replan`,
the disabled robot an obstacle) and the new plan runs under the same
strategy and delay model (seed + 1); times add up. With `reroute: auto`
robots a late one holds up get new paths mid-run when that pays
(`execution.reroute`); the row counts the changes of plan (`reroutes`).
"""
from __future__ import annotations

import time
from typing import Dict, List, Optional

from fleet_common.delays import parse_delay_model
from fleet_common.execution.reroute import RerouteRule
from fleet_common.execution.simulate import SimResult, simulate
from fleet_common.plan import Plan
from fleet_common.plan_loading import LoadedPlan
from fleet_common.planning.replan import replan

from .row import Row, make_row
from .spec import Cell
from .wire_cell import run_wire_cell


def run_cell(cell: Cell, plan: LoadedPlan) -> Row:
    """The results row of `cell`: simulated by the engine, or run through the manager (wire)."""
    if cell.chain == "wire":
        return run_wire_cell(cell, plan, cell.time_scale)
    began = time.perf_counter()
    model = parse_delay_model(cell.delay, default="none")
    p = plan.plan
    settings = dict(cell.settings)
    disable = {}
    if cell.disable != "none":
        robot, step = cell.disable.split("@")
        disable[int(robot) % p.num_agents] = int(step)
    size = cell.robot_size
    reroute = {} if cell.reroute == "none" else {"reroute": RerouteRule(scope=cell.reroute_scope, trim=cell.trim)}
    if cell.reroute != "none" or cell.trim:
        reroute.update(grid=plan.grid, trim=cell.trim)
    first = simulate(p, cell.strategy, model, seed=cell.seed, disable=disable, size=size, **reroute, **settings)
    second: Optional[SimResult] = None
    if cell.recover == "replan" and first.unfinished():
        current = first.trace.final_cells()
        result = replan(plan.grid, current, plan.goals, set(first.disabled_at), deadline=30.0,
                        seed=cell.seed)
        if result.plan is not None:
            second = simulate(result.plan, cell.strategy, model, seed=cell.seed + 1, size=size, **reroute,
                              **settings)
    row = _row(cell, plan, p, first, second)
    row["wall_s"] = round(time.perf_counter() - began, 4)
    return row


def _row(cell: Cell, plan: LoadedPlan, p: Plan, first: SimResult, second: Optional[SimResult]) -> Row:
    m1 = first.metrics
    waits = [r.wait_time for r in m1.agents]
    held = sum(r.held_time for r in m1.agents)
    blocked: Dict[int, float] = {}
    for r in m1.agents:
        for q, t in r.blocked_by.items():
            blocked[q] = blocked.get(q, 0.0) + t
    arrival: List[Optional[float]] = [r.arrival for r in m1.agents]
    makespan, collisions, count = m1.makespan, len(first.collisions), m1.total_waits
    moves = sum(r.moves for r in m1.agents)
    if second is not None:
        t0, m2 = first.end_time, second.metrics
        for r, rm in enumerate(m2.agents):
            waits[r] += rm.wait_time
            held += rm.held_time
            for q, t in rm.blocked_by.items():
                blocked[q] = blocked.get(q, 0.0) + t
        final = second.trace.final_cells()
        for r, rm in enumerate(m2.agents):
            if tuple(final[r]) != tuple(plan.goals[r]) or r in first.disabled_at or rm.arrival is None:
                arrival[r] = None  # stranded, or the robot that is out
            elif second.engine.table.count(r) or arrival[r] is None:
                arrival[r] = t0 + rm.arrival
        makespan = max(makespan, t0 + m2.makespan) if m2.last_completion is not None else makespan
        collisions += len(second.collisions)
        count += m2.total_waits
        moves += sum(r.moves for r in m2.agents)
    reached = [a for a in arrival if a is not None]
    closest = [r.closest.distance for r in (first, second) if r is not None and r.closest is not None]
    cell_m = cell.robot_size.cell
    return make_row(cell, plan, p, makespan=makespan, soc=float(sum(reached)), waits=waits,
                    count=count, held=held, blocked=blocked, collisions=collisions,
                    reached=len(reached), replanned=second is not None, moves=moves,
                    closest_m=min(closest) * cell_m if closest else None,
                    reroutes=sum(len(r.reroutes) for r in (first, second) if r is not None))
