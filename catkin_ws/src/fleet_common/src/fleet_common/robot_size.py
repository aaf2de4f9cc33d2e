"""How large the robots are, and how far apart their centres must stay: data, per fleet.

A fleet's robots have one diameter and one safety margin, in metres, given by
an optional line of robot_definitions.txt:

    size  diameter=0.354  margin=0.10

(no line: a TurtleBot 2, below). The cell size comes from the frames (the
base -> robot scale, 0.7 m in the lab). A run is safe when no two robot
centres ever come closer than `safe` = diameter + margin. Everything that
judges or keeps distances (the engine, the simulator and its checker, the
manager, the virtual fleet, the console) takes one `RobotSize`.

Why 0.10 m of margin for a TurtleBot 2 in the lab. Two robots' centres are
known to the manager only through their own localization, and a follower
stops at a hold point by its own:

- localization: an AprilTag fix is good to about 2 cm in the lab, odometry
  between two markers drifts up to 1 cm more: 3 cm for each robot's belief
  against the truth, 6 cm for the pair;
- braking: a follower stops at its hold point under its own controller,
  which slows down as it approaches a target; on the TurtleBot base it
  overshoots by at most 2 cm at the lab's speeds (0.3 m/s);
- latency (the command and the pose feedback, up to 0.2 s) costs time, not
  distance: the manager releases a follower only as far as the leader's last
  reported position allows, and a leader only ever moves on along its path,
  so the truth is never behind the report. A late or lost pose makes the
  follower stop earlier, never closer;
- 2 cm rounded in for what the above leaves out (a robot a little off its
  line): 6 + 2 + 2 = 10 cm.

Robots as large as a cell (`cell_sized`: safe distance of a whole cell or
more) cannot follow one another into a cell at all; then the cell-occupancy
rule of the Action Dependency Graph holds alone, as before robots had a size.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Optional

from .errors import RobotDefinitionsError

__all__ = ["RobotSize", "TURTLEBOT2", "LAB_CELL_M", "parse_size_line", "cell_sized"]

#: The lab's cell, metres (frames.yaml: base -> robot scale).
LAB_CELL_M = 0.7
#: A TurtleBot 2 (Kobuki base): 354 mm across.
TURTLEBOT2_DIAMETER_M = 0.354
TURTLEBOT2_MARGIN_M = 0.10
#: How far past a hold point a robot's own controller may stop (the braking above). A robot on
#: the wire is held this much farther back, so that its stop keeps the safe distance itself and
#: the margin is left for what the manager cannot see (localization, a robot off its line).
STOP_OVERSHOOT_M = 0.02
_EPS = 1e-9


@dataclass(frozen=True)
class RobotSize:
    """Diameter and safety margin of a fleet's robots, and the cell they drive on (metres)."""

    diameter: float = TURTLEBOT2_DIAMETER_M
    margin: float = TURTLEBOT2_MARGIN_M
    cell: float = LAB_CELL_M

    def __post_init__(self) -> None:
        if not (self.diameter > 0 and self.margin >= 0 and self.cell > 0):
            raise ValueError("a robot size needs diameter > 0, margin >= 0 and cell > 0 metres")

    @property
    def safe(self) -> float:
        """The smallest allowed distance between two robot centres, metres."""
        return self.diameter + self.margin

    @property
    def safe_cells(self) -> float:
        """The same in cells."""
        return self.safe / self.cell

    @property
    def cell_sized(self) -> bool:
        """Too large to follow into a cell another robot is leaving: the cell rule alone."""
        return self.safe_cells >= 1.0 - _EPS

    def with_cell(self, cell: float) -> "RobotSize":
        return RobotSize(self.diameter, self.margin, cell)

    def describe(self) -> str:
        if self.cell_sized:
            return "robots as large as a cell ({:g} m)".format(self.cell)
        return "robots {:g} m across, {:g} m margin: centres at least {:.3g} m ({:.2f} cells) apart".format(
            self.diameter, self.margin, self.safe, self.safe_cells)


TURTLEBOT2 = RobotSize()


def cell_sized(cell: float = LAB_CELL_M) -> RobotSize:
    """Robots as large as a cell: the safe distance is one cell (today's cell rule)."""
    return RobotSize(cell, 0.0, cell)


def parse_size_line(fields: list, path: Optional[str], line: int) -> RobotSize:
    """`size diameter=D margin=M` from robot_definitions.txt (fields: (column, token) pairs)."""
    values = {}
    for column, token in fields[1:]:
        key, _, value = token.partition("=")
        if key not in ("diameter", "margin") or key in values:
            raise RobotDefinitionsError("bad size term {!r}: expected diameter=METRES and "
                                        "margin=METRES, once each".format(token[:40]), path, line, column)
        try:
            number = float(value)
        except ValueError:
            number = float("nan")
        if not (0.0 <= number < 100.0) or (key == "diameter" and number == 0.0):
            raise RobotDefinitionsError("bad {} {!r}: expected metres, a number above 0 and below "
                                        "100".format(key, value[:40]), path, line, column)
        values[key] = number
    if "diameter" not in values:
        raise RobotDefinitionsError("a size line needs diameter=METRES (and margin=METRES)", path, line)
    return RobotSize(values["diameter"], values.get("margin", TURTLEBOT2_MARGIN_M))
