"""A row of a sweep's results table: its columns, and the row made from a run's figures.

Engine cells (`cell.py`) and wire cells (`wire_cell.py`) both make their rows here, so the
two kinds of run fill the same columns the same way.
"""
from __future__ import annotations

import json
from typing import Any, Dict, List, Optional

from fleet_common.plan import Plan
from fleet_common.plan_loading import LoadedPlan

from .spec import Cell

#: Columns of the results table, in order.
COLUMNS = ("key", "plan", "solver", "agents", "strategy", "size", "delay", "p", "seed", "disable", "recover",
           "reroute", "reroute_scope", "trim", "plan_makespan", "plan_soc", "makespan", "soc", "makespan_ratio", "soc_ratio",
           "wait_total", "wait_mean", "wait_max", "waits", "held_time", "wait_by_robot", "blocked_by",
           "collisions", "closest_m", "reached", "finished", "replanned", "reroutes", "moves", "wall_s")
#: Columns added since tables were first written, and their value in the rows of an older table
#: (read back when a sweep resumes): older runs never rerouted.
ADDED = {"reroute": "none", "reroutes": 0, "reroute_scope": "held", "trim": False}

Row = Dict[str, Any]


def strategy_label(cell: Cell) -> str:
    """The strategy column: its name and settings, " (wire)" for a run through the manager and
    " [cell]" (or " [D:M]") for robots not of the lab's size, so reports show them side by side."""
    return cell.strategy + "".join(" {}={}".format(k, v) for k, v in cell.settings) + (
        " (wire)" if cell.chain == "wire" else "") + ("" if cell.reroute == "none" else " +reroute") + (
        " all" if cell.reroute != "none" and cell.reroute_scope != "held" else "") + (
        " +trim" if cell.trim else "") + ("" if cell.size == "turtlebot" else " [{}]".format(cell.size))


def make_row(cell: Cell, plan: LoadedPlan, p: Plan, *, makespan: float, soc: float,
             waits: List[float], count: int, held: float, blocked: Dict[int, float],
             collisions: int, reached: int, replanned: bool, moves: int,
             closest_m: Optional[float] = None, reroutes: int = 0) -> Row:
    """A results row (all but `wall_s`) from a run's figures, times in plan steps; `waits` per
    agent; `reroutes`: changes of plan mid-run (`reroute: auto`). Engine and wire cells both make
    their rows here."""
    n = p.num_agents
    return {
        "key": cell.key, "plan": cell.plan, "solver": plan.solver, "agents": n,
        "strategy": strategy_label(cell), "size": cell.size, "delay": cell.delay, "p": cell.p, "seed": cell.seed,
        "disable": cell.disable, "recover": cell.recover, "reroute": cell.reroute,
        "reroute_scope": cell.reroute_scope, "trim": cell.trim,
        "plan_makespan": p.makespan, "plan_soc": p.soc,
        "makespan": round(makespan, 6), "soc": round(soc, 6),
        "makespan_ratio": round(makespan / p.makespan, 6) if p.makespan else 1.0,
        "soc_ratio": round(soc / p.soc, 6) if p.soc else 1.0,
        "wait_total": round(sum(waits), 6), "wait_mean": round(sum(waits) / n, 6) if n else 0.0,
        "wait_max": round(max(waits), 6) if n else 0.0, "waits": count, "held_time": round(held, 6),
        "wait_by_robot": json.dumps([round(w, 4) for w in waits]),
        "blocked_by": json.dumps({str(q): round(t, 4) for q, t in sorted(blocked.items())}),
        "collisions": collisions, "closest_m": None if closest_m is None else round(closest_m, 4),
        "reached": reached, "finished": reached == n,
        "replanned": replanned, "reroutes": reroutes, "moves": moves,
    }
