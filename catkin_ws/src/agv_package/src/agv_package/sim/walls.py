"""Where the simulated base bumps into something: blocked cells and the edge of the grid.

The Kobuki's bumper covers the front half of the base, in three parts (left,
centre, right). A part is pressed when a point of the front rim in its sector
lies in a blocked grid cell or outside the grid. The rim is checked in the
base grid (via `GridFrame`), where a cell is a unit square around its centre.
"""
from __future__ import annotations

import math
from typing import List, Tuple

from fleet_common.grid import Grid

from ..geometry import Pose2D
from ..grid_frame import GridFrame

#: Bumper bits, as in the Kobuki's sensor state (`bumper` field): 1 right, 2 centre, 4 left.
RIGHT, CENTRE, LEFT = 1, 2, 4
#: TurtleBot 2 (Kobuki) base radius, metres.
BASE_RADIUS = 0.177

# Rim points: angle from the heading, and which bumper part they press.
_RIM: List[Tuple[float, int]] = [
    (math.radians(a), RIGHT if a < -30 else LEFT if a > 30 else CENTRE)
    for a in range(-90, 91, 15)
]


class Walls:
    """Contact test of the base's front rim against the grid's blocked cells."""

    def __init__(self, grid: Grid, frame: GridFrame, radius: float = BASE_RADIUS) -> None:
        self.grid = grid
        self.frame = frame
        self.radius = radius

    def _solid(self, x: float, y: float) -> bool:
        bx, by = self.frame.point_to_base(x, y)
        cell = (int(math.floor(bx + 0.5)), int(math.floor(by + 0.5)))
        if not (0 <= cell[0] < self.grid.width and 0 <= cell[1] < self.grid.height):
            return True
        return not bool(self.grid.free[cell[1], cell[0]])

    def bumper(self, pose: Pose2D) -> int:
        """Bitmask of the bumper parts pressed with the base at `pose` (world metres)."""
        mask = 0
        for angle, part in _RIM:
            heading = pose.theta + angle
            if self._solid(pose.x + self.radius * math.cos(heading),
                           pose.y + self.radius * math.sin(heading)):
                mask |= part
        return mask

    def touching(self, pose: Pose2D) -> bool:
        return self.bumper(pose) != 0
