"""Legacy FleetControl data as FleetControl grids and plans.

Node maps: each node's position (metres, robot frame) goes through the
inverse of the base -> robot transform (the lab's by default) and must land
on a cell centre; cells with a node are free, all others blocked.

Execution plans: legacy coordinates become base cells as (x - origin) / scale.
A plan converts only if it runs between grid nodes: every section starts and
ends on a cell and moves straight along x or along y. Time is discretised per
agent with one rule, so the result is easy to predict:

- one time step = the time to move one cell at the agent's speed,
  scale / movespeed seconds;
- a move of k cells takes k steps (its legacy duration is not used);
- a turn or wait (same start and end position) of d seconds takes
  floor(d / step + 1/2) steps; a quick turn takes none and counts as done
  by the end of the step before.

Agents keep file order (agent i of the plan is the i-th <agent>). Legacy
headings turn clockwise from +x (thesis fig. 3.1: a move by (+2, -1) has
heading 26.57), so heading h is the base-frame direction -h; headings on a
grid axis become `Orientation`s, others "no orientation".
"""
from __future__ import annotations

import math
from typing import Dict, List, Optional, Sequence, Tuple

import numpy as np

from ..errors import LegacyFormatError, NotConvertibleError
from ..grid import Coord, Grid
from ..limits import MAX_GRID_CELLS, MAX_GRID_SIDE, MAX_PLAN_STEPS
from ..plan import NO_ORIENTATION, Plan
from ..transform2d import Transform2D
from .legacy_xml import HEADING_TOL, LegacyAgent, LegacyNodeMap, LegacyPlan, LegacySection, Pose

#: How far (legacy units after scaling, i.e. cells) a plan point may be from a cell centre.
CELL_TOL = 1e-6


def legacy_nodes_to_grid(nodemap: LegacyNodeMap, transform: Optional[Transform2D] = None,
                         tolerance: float = 0.05) -> Tuple[Grid, Dict[int, Coord]]:
    """The grid of `nodemap` and node id -> cell; `transform` is base -> the nodes' frame.

    A node farther than `tolerance` cells from a cell centre, outside the base
    grid, or on the same cell as another node is an error naming its line.
    """
    if transform is None:
        from ..lab import base_to_robot  # the lab's transform, read only when needed
        transform = base_to_robot()
    if transform.source != "base":
        raise ValueError("expected a transform from the base frame, got {}".format(
            transform.name()))
    to_cells = transform.inverse()
    cells: Dict[int, Coord] = {}
    lines: Dict[Coord, int] = {}
    for node in nodemap.nodes:
        fx, fy = to_cells.apply((node.x, node.y))
        where = "node {} at ({:g}, {:g})".format(node.id, node.x, node.y)
        if not (abs(fx) < MAX_GRID_SIDE and abs(fy) < MAX_GRID_SIDE):
            raise LegacyFormatError("{} is beyond the largest grid FleetControl builds ({:,} "
                                    "cells a side)".format(where, MAX_GRID_SIDE),
                                    nodemap.path, node.line)
        cell = (int(round(fx)), int(round(fy)))
        if max(abs(fx - cell[0]), abs(fy - cell[1])) > tolerance:
            raise LegacyFormatError("{} is not on a cell centre: it maps to cell ({}, {}) "
                                    "through {}".format(where, _fmt(fx), _fmt(fy),
                                                        transform.name()),
                                    nodemap.path, node.line)
        if cell[0] < 0 or cell[1] < 0:
            raise LegacyFormatError("{} maps to cell {}, left of or below the base grid".format(
                where, cell), nodemap.path, node.line)
        if cell in lines:
            raise LegacyFormatError("{} is on cell {}, as the node on line {}".format(
                where, cell, lines[cell]), nodemap.path, node.line)
        lines[cell] = node.line
        cells[node.id] = cell
    width = max(c[0] for c in cells.values()) + 1
    height = max(c[1] for c in cells.values()) + 1
    if width * height > MAX_GRID_CELLS:
        raise LegacyFormatError("the nodes span {:,} x {:,} cells, more than the {:,} of the "
                                "largest grid FleetControl builds".format(
                                    width, height, MAX_GRID_CELLS), nodemap.path, 1)
    free = np.zeros((height, width), dtype=bool)
    for x, y in cells.values():
        free[y, x] = True
    return Grid(free, name="legacy"), cells


def _fmt(value: float) -> str:
    return "{:.3f}".format(value if abs(value) >= 5e-4 else 0.0)  # never "-0.000"


def _orientation(heading: float) -> int:
    quarter = -heading / 90.0
    nearest = round(quarter)
    if abs(quarter - nearest) * 90.0 > HEADING_TOL:
        return NO_ORIENTATION
    return int(nearest) % 4


class _Converter:
    """One agent's sections -> cells and orientations per time step."""

    def __init__(self, agent: LegacyAgent, scale: float, origin: Tuple[float, float]) -> None:
        self.agent, self.scale, self.origin = agent, scale, origin

    def fail(self, section: Optional[LegacySection], why: str) -> NotConvertibleError:
        where = "agent {}".format(self.agent.id)
        if section is not None:
            where += " section {}".format(section.id)
        return NotConvertibleError("{}: {}".format(where, why))

    def cell(self, pose: Pose, section: Optional[LegacySection], what: str) -> Coord:
        fx = (pose.x - self.origin[0]) / self.scale
        fy = (pose.y - self.origin[1]) / self.scale
        if not (abs(fx) < MAX_GRID_SIDE and abs(fy) < MAX_GRID_SIDE):
            raise self.fail(section, "{} ({:g}, {:g}) is beyond the largest grid FleetControl "
                            "builds ({:,} cells a side)".format(what, pose.x, pose.y, MAX_GRID_SIDE))
        cell = (int(round(fx)), int(round(fy)))
        if max(abs(fx - cell[0]), abs(fy - cell[1])) > CELL_TOL:
            raise self.fail(section, "{} ({:g}, {:g}) is not on a grid cell: it is at cell "
                            "({:g}, {:g}) with scale {:g}, origin {}".format(
                                what, pose.x, pose.y, fx, fy, self.scale, self.origin))
        if cell[0] < 0 or cell[1] < 0:
            raise self.fail(section, "{} ({:g}, {:g}) is at cell {}, left of or below the base "
                            "grid".format(what, pose.x, pose.y, cell))
        return cell

    def steps(self) -> Tuple[List[Coord], List[int]]:
        agent = self.agent
        if not agent.path_found:
            raise self.fail(None, "the planner found no path (pathfound=false)")
        step_time = self.scale / agent.movespeed
        if not 0 < step_time < math.inf:
            raise self.fail(None, "movespeed {:g} makes a step of {:g} s".format(
                agent.movespeed, step_time))
        cells = [self.cell(agent.start, None, "start")]
        headings = [_orientation(agent.start.heading)]
        for section in agent.sections:
            a = self.cell(section.start, section, "start point")
            b = self.cell(section.goal, section, "end point")
            heading = _orientation(section.goal.heading)
            if a == b:
                count = section.duration / step_time + 0.5
                if not count < MAX_PLAN_STEPS - len(cells):
                    raise self.fail(section, "waits {:g} s, more than the {:,} steps of the longest "
                                    "plan FleetControl builds".format(section.duration,
                                                                      MAX_PLAN_STEPS))
                count = int(math.floor(count))
                cells += [a] * count
                if count == 0:  # a quick turn: done by the end of the step before
                    headings[-1] = heading
            elif a[0] == b[0] or a[1] == b[1]:
                dx, dy = np.sign(b[0] - a[0]), np.sign(b[1] - a[1])
                count = abs(b[0] - a[0]) + abs(b[1] - a[1])
                if count >= MAX_PLAN_STEPS - len(cells):
                    raise self.fail(section, "the plan gets longer than the {:,} steps of the "
                                    "longest plan FleetControl builds".format(MAX_PLAN_STEPS))
                cells += [(a[0] + int(dx) * i, a[1] + int(dy) * i) for i in range(1, count + 1)]
            else:
                raise self.fail(section, "diagonal move ({},{})->({},{}) is not along a grid "
                                "line".format(a[0], a[1], b[0], b[1]))
            headings += [heading] * count
        return cells, headings


def legacy_plan_to_plan(
    plan: LegacyPlan, scale: float = 1.0, origin: Sequence[float] = (0.0, 0.0)
) -> Tuple[Plan, List[Coord], List[Coord]]:
    """(Plan, starts, goals) in the base grid, or NotConvertibleError naming agent and section.

    `scale` is the legacy length of one cell and `origin` the legacy position
    of cell (0, 0): for plans in the lab's robot-frame metres, 0.7 and (0.7, 2.1).
    """
    if not scale > 0:
        raise ValueError("scale must be positive, got {!r}".format(scale))
    converters = [_Converter(a, scale, (float(origin[0]), float(origin[1]))) for a in plan.agents]
    runs = [c.steps() for c in converters]
    result = Plan.from_paths([cells for cells, _ in runs])
    orientations = np.full(result.positions.shape[:2], NO_ORIENTATION, dtype=np.int8)
    for i, (_, headings) in enumerate(runs):
        orientations[:len(headings), i] = headings
        orientations[len(headings):, i] = headings[-1]
    if np.any(orientations != NO_ORIENTATION):
        result = Plan(result.positions, orientations)
    starts = [c.cell(c.agent.start, None, "start") for c in converters]
    goals = [c.cell(c.agent.goal, None, "goal") for c in converters]
    return result, starts, goals
