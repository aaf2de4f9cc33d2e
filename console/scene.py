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
from typing import List, Optional, Sequence

from fleet_common.formats.header import MAPF_IR, read_text
from fleet_common.formats.instance import parse_instance
from fleet_common.formats.mapfile import read_map
from fleet_common.formats.solution import read_solution
from fleet_common.grid import Coord, Grid
from fleet_common.plan import Plan
from fleet_common.robots import RobotDefinition, read_robot_definitions
from fleet_common.validate import FOLLOWING, ROTATION, Finding, validate_plan

from .palette import agent_colours


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

    @property
    def num_agents(self) -> int:
        return len(self.starts)

    @property
    def makespan(self) -> int:
        return 0 if self.plan is None else self.plan.makespan


def lab_robots(grid: Grid, n: int) -> Optional[List[RobotDefinition]]:
    """The lab's robots when `grid` is the lab map and they are enough for `n` agents."""
    from fleet_common.lab import lab_map_path

    if grid != read_map(str(lab_map_path())).grid:
        return None
    robots = read_robot_definitions()
    return robots if n <= len(robots) else None


def _style(scene: Scene, robots: Optional[Sequence[RobotDefinition]]) -> None:
    n = scene.num_agents
    if robots is None:
        robots = lab_robots(scene.grid, n)
    scene.colours = agent_colours(n, robots)
    if robots is not None and n <= len(robots):
        scene.names = ["robot {}".format(r.id) for r in robots[:n]]
    else:
        scene.names = ["agent {}".format(i) for i in range(n)]


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
                  file_orientation=sol.orientation, title=Path(path).name)
    if plan is not None:
        report = validate_plan(plan, sol.grid, starts=sol.starts, goals=sol.goals, soc=sol.soc,
                               makespan=sol.makespan, strict_following=strict_following)
        scene.findings = report.errors
        scene.following, scene.rotations = report.count(FOLLOWING), report.count(ROTATION)
    _style(scene, robots)
    return scene


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
                  file_orientation=inst.orientation, title=Path(path).name)
    _style(scene, robots)
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
    _style(scene, robots)
    return scene


def _text(value: object) -> str:
    return "-" if value is None else str(value)
