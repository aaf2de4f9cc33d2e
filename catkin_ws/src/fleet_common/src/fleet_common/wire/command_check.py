"""Commands checked against the robot's world before its navigator sees them.

Only the manager's key may drive a robot, but the manager can still be wrong
(a bug, a plan for another map, a replayed command), and a robot that drives
off its map or for ever is worse than one that says no. So the robot checks
each drive and turn here, the same way on the TurtleBot (agv_runner) and in
the virtual fleet, and refuses with a reason (the executor's `Failed`; the
robot stays free):

- a drive whose target is off the robot's map or on a blocked cell (the cell
  nearest the target), or whose straight path from where the robot stands
  crosses a blocked cell;
- a drive farther than `max_step` cells from where the robot stands: the
  manager sends one cell at a time, and a robot localized on the floor tags
  stands within a fraction of a cell of its node (None: any distance);
- a drive due later than `max_time` seconds, or with a negative time;
- a turn to a heading beyond one revolution either way.

Pure: a grid (None: the robot knows no map, only distances and times are
checked), the limits, the command and the robot's pose in; a reason or None
out.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Optional, Tuple

from .messages import Command, DriveToPosition, Pose, Turn

if TYPE_CHECKING:  # the wire stays importable without numpy
    from ..grid import Grid

__all__ = ["CommandLimits", "CommandCheck", "MAX_HEADING"]

#: Largest heading a turn may ask for, either way (radians).
MAX_HEADING = 2.0 * math.pi
_SAMPLE = 0.25  # cells between the points of a path checked for blocked cells


@dataclass(frozen=True)
class CommandLimits:
    """How far one drive may go (cells, Euclidean; None: any distance) and how long it may
    be given (seconds)."""

    max_step: Optional[float] = 1.5
    max_time: float = 120.0

    def __post_init__(self) -> None:
        if self.max_step is not None and not self.max_step > 0:
            raise ValueError("max_step must be positive or None, got {}".format(self.max_step))
        if not self.max_time > 0:
            raise ValueError("max_time must be positive, got {}".format(self.max_time))


class CommandCheck:
    """Says why a command must not run on a robot at `pose` (None: it may)."""

    def __init__(self, grid: Optional["Grid"] = None,
                 limits: CommandLimits = CommandLimits()) -> None:
        self.grid = grid
        self.limits = limits

    def refusal(self, command: Command, pose: Pose) -> Optional[str]:
        if isinstance(command, DriveToPosition):
            return self._drive(command, pose)
        if isinstance(command, Turn) and not abs(command.angle) <= MAX_HEADING:
            return "heading {:g} rad is beyond one revolution (at most {:.4g} either way)".format(
                command.angle, MAX_HEADING)
        return None

    def _drive(self, drive: DriveToPosition, pose: Pose) -> Optional[str]:
        if drive.time < 0:
            return "time must be 0 (as fast as allowed) or more seconds, got {:g}".format(drive.time)
        if drive.time > self.limits.max_time:
            return "time {:g} s is beyond this robot's limit of {:g} s".format(
                drive.time, self.limits.max_time)
        target = "target ({:g}, {:g})".format(drive.x, drive.y)
        grid = self.grid
        if grid is not None:
            cell = _cell(grid, drive.x, drive.y)
            if cell is None:
                return "{} is off the {}x{} map".format(target, grid.width, grid.height)
            if not grid.is_free(cell):
                return "{} is on the blocked cell {}".format(target, cell)
        distance = math.hypot(drive.x - pose.x, drive.y - pose.y)
        step = self.limits.max_step
        if step is not None and distance > step:
            return "{} is {:.3g} cells from the robot at ({:.3g}, {:.3g}); one drive goes at " \
                   "most {:g}".format(target, distance, pose.x, pose.y, step)
        if grid is not None:
            blocked = _blocked_on_path(grid, pose, drive.x, drive.y, distance)
            if blocked is not None:
                return "the way to {} crosses the blocked cell {}".format(target, blocked)
        return None


def _cell(grid: "Grid", x: float, y: float) -> Optional[Tuple[int, int]]:
    """The cell nearest (x, y), None when that is off the map."""
    if not (-0.5 <= x < grid.width - 0.5 and -0.5 <= y < grid.height - 0.5):
        return None
    return int(math.floor(x + 0.5)), int(math.floor(y + 0.5))


def _blocked_on_path(grid: "Grid", pose: Pose, x: float, y: float,
                     distance: float) -> Optional[Tuple[int, int]]:
    """The first blocked cell the straight line from the pose to (x, y) enters (the cell
    the robot stands on does not count: it may be a little off its node)."""
    start = _cell(grid, pose.x, pose.y)
    # a path longer than the map leaves it; checking that many points is enough
    points = min(int(math.ceil(distance / _SAMPLE)), int(4 * (grid.width + grid.height) / _SAMPLE))
    for i in range(1, points):
        f = i / points
        cell = _cell(grid, pose.x + (x - pose.x) * f, pose.y + (y - pose.y) * f)
        if cell is not None and cell != start and not grid.is_free(cell):
            return cell
    return None
