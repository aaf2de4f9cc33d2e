"""Scene: everything the player shows that does not change with time.

The map, each agent's start, goal, colour and name, the plan (None for a
plain instance or a failed run: agents then stand on their starts), the
solver's header figures and the validator's findings. Built from a mapf-IR
solution or instance file, or from values (the live console will build one
from the manager's plan). `file_orientation` remembers which frame the file's
coordinates were in, so the mapf-IR view can show them as mapf-IR does.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Dict, List, Optional, Sequence

from fleet_common.formats.header import MAPF_IR, read_text
from fleet_common.formats.instance import parse_instance
from fleet_common.formats.mapfile import read_map
from fleet_common.formats.solution import Solution, read_solution
from fleet_common.grid import Coord, Grid
from fleet_common.lab import node_table
from fleet_common.lab.fleet import lab_fleet, lab_grid
from fleet_common.plan import Plan
from fleet_common.robots import RobotDefinition
from fleet_common.validate import FOLLOWING, ROTATION, Finding, validate_plan

from .palette import agent_colours


#: `Scene.kind` values.
SOLUTION, INSTANCE, MAP = "solution", "instance", "map"


@dataclass
class Scene:
    """What the player shows; coordinates in the base frame."""

    grid: Grid
    starts: List[Coord]
    goals: List[Coord]
    plan: Optional[Plan] = None
    colours: List[str] = field(default_factory=list)
    names: List[str] = field(default_factory=list)
    #: the header line's parts, in display order ("soc 681", ...)
    info: List[str] = field(default_factory=list)
    #: the validator's errors (conflicts, off-map, jumps, ...), listed and marked
    findings: List[Finding] = field(default_factory=list)
    #: following moves and rotations: legal in mapf-IR, counted in the list's title
    following: int = 0
    rotations: int = 0
    file_orientation: str = MAPF_IR
    title: str = ""
    #: what the scene was read from: SOLUTION, INSTANCE or MAP (an instance can be solved)
    kind: str = SOLUTION
    #: the lab's floor-marker node id of each cell, on the lab map only
    node_ids: Dict[Coord, int] = field(default_factory=dict)
    #: a robot's diameter in cells, as its disc is drawn (None: the player's size for agents)
    robot_diameter: Optional[float] = None
    #: the map file the scene's file names (`map_file=`), for a plan solved here to name it too
    map_file: str = ""
    #: a plan solved in this window, as the mapf-IR solution File -> save the plan writes
    solution: Optional[Solution] = None

    @property
    def num_agents(self) -> int:
        return len(self.starts)

    @property
    def makespan(self) -> int:
        return 0 if self.plan is None else self.plan.makespan


def _style(scene: Scene, robots: Optional[Sequence[RobotDefinition]]) -> None:
    """Colours and names: the lab fleet's robots (`fleet_common.lab.fleet`), else agents by index."""
    n = scene.num_agents
    if robots is None:
        robots = lab_fleet(scene.grid, n)
    scene.colours = agent_colours(n, robots)
    if robots is not None and n <= len(robots):
        scene.names = ["robot {}".format(r.id) for r in robots[:n]]
    else:
        scene.names = ["agent {}".format(i) for i in range(n)]
    if scene.grid == lab_grid():
        table = node_table()
        scene.node_ids = {c: int(table.node_at(c) or 0) for c in scene.grid.free_cells()}


def scene_from_solution(path: Path, map_path: Optional[Path] = None,
                        map_dirs: Optional[Sequence[Path]] = None, strict_following: bool = False,
                        robots: Optional[Sequence[RobotDefinition]] = None) -> Scene:
    """Read a mapf-IR solution; `map_path` overrides its `map_file=`."""
    grid = None if map_path is None else read_map(str(map_path)).grid
    sol = read_solution(str(path), map_dirs=map_dirs, grid=grid)
    plan = sol.plan if sol.solved else None
    info = ["solver {}".format(sol.solver or "?"), "solved" if sol.solved else "NOT solved (failed run)",
            "soc {}".format(_text(sol.soc)), "makespan {}".format(_text(sol.makespan)),
            "comp_time {} ms".format(_text(sol.comp_time)),
            "{} agents".format(len(sol.starts)), sol.map_file or "-"]
    scene = Scene(sol.grid, list(sol.starts), list(sol.goals), plan, info=info,
                  file_orientation=sol.orientation, title=Path(path).name, map_file=sol.map_file or "")
    if plan is not None:
        report = validate_plan(plan, sol.grid, starts=sol.starts, goals=sol.goals, soc=sol.soc,
                               makespan=sol.makespan, strict_following=strict_following)
        scene.findings = report.errors
        scene.following, scene.rotations = report.count(FOLLOWING), report.count(ROTATION)
        info[1] = _verdict(scene)
    _style(scene, robots)
    return scene


def _verdict(scene: Scene) -> str:
    """The header's word on a solved plan: what the validator found, not only what the solver said."""
    n = len(scene.findings)
    if n:
        return "INVALID: {} conflict{} or error{} (listed)".format(n, "s" * (n > 1), "s" * (n > 1))
    if scene.rotations:
        return "solved, {} rotation{} (robots need them repaired)".format(
            scene.rotations, "s" if scene.rotations > 1 else "")
    return "solved"


def scene_from_instance(path: Path, map_path: Optional[Path] = None,
                        map_dirs: Optional[Sequence[Path]] = None,
                        robots: Optional[Sequence[RobotDefinition]] = None) -> Scene:
    """Read a mapf-IR instance: agents on their starts, goals marked."""
    grid = None if map_path is None else read_map(str(map_path)).grid
    inst = parse_instance(read_text(str(path)), str(path), map_dirs, grid)
    info = ["instance (no plan): agents on their starts, goals marked",
            "{} agents".format(len(inst.starts)), inst.map_file or "-"]
    if inst.random_problem:
        info[0] = "instance with random_problem=1: the solver draws starts and goals"
    scene = Scene(inst.grid, list(inst.starts), list(inst.goals), None, info=info,
                  file_orientation=inst.orientation, title=Path(path).name, kind=INSTANCE,
                  map_file=inst.map_file or "")
    _style(scene, robots)
    return scene


def scene_from_map(path: Path) -> Scene:
    """A map without agents (on the lab map: its node ids can be shown)."""
    grid = read_map(str(path)).grid
    scene = Scene(grid, [], [], None, info=["map: {} x {} cells, {} free".format(
        grid.width, grid.height, int(grid.free.sum())), Path(path).name], title=Path(path).name, kind=MAP)
    _style(scene, None)
    return scene


def scene_from_plan(grid: Grid, plan: Plan, goals: Optional[Sequence[Coord]] = None,
                    info: Sequence[str] = (), title: str = "",
                    robots: Optional[Sequence[RobotDefinition]] = None) -> Scene:
    """A scene for a plan in memory (a solver's result, the manager's plan), validated."""
    goals = list(plan.goals if goals is None else goals)
    scene = Scene(grid, plan.starts, goals, plan, info=list(info), title=title)
    report = validate_plan(plan, grid, goals=goals)
    scene.findings = report.errors
    scene.following, scene.rotations = report.count(FOLLOWING), report.count(ROTATION)
    if scene.findings or scene.rotations:
        scene.info.insert(min(1, len(scene.info)), _verdict(scene))
    _style(scene, robots)
    return scene


def _text(value: object) -> str:
    return "-" if value is None else str(value)
