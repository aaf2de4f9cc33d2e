"""The lab's floor nodes: bar-code id <-> base cell <-> robot-frame metres.

Every node of the floor grid has an id (printed in its bar code), a base cell
and a position in metres; cells without a node are blocked. The table is read
from `nodes.yaml` and checked against the base -> robot transform, so the
file and `frames.yaml` cannot silently disagree.
"""
from __future__ import annotations

from typing import Any, Dict, Iterable, List, Optional, Tuple

import numpy as np

from ..errors import FormatError
from ..limits import MAX_GRID_CELLS, excerpt
from ..grid import Coord, Grid
from ..transform2d import Transform2D
from ..yaml_lines import load_marked, where

Metres = Tuple[float, float]

#: How far (metres) a stored node position may be from where the transform puts its cell.
POSITION_TOLERANCE = 1e-3


class NodeTable:
    """Nodes of a `width` x `height` base grid, with `to_metres` (base -> robot frame)."""

    def __init__(self, width: int, height: int, nodes: Iterable[Tuple[int, Coord]],
                 to_metres: Transform2D) -> None:
        self.width, self.height = width, height
        self.to_metres = to_metres
        self._from_metres = to_metres.inverse()
        self._cell: Dict[int, Coord] = {}
        self._id: Dict[Coord, int] = {}
        for node_id, cell in nodes:
            if node_id in self._cell or cell in self._id or not self.in_bounds(cell):
                raise ValueError("node {} at {}: duplicate id or cell, or outside {}x{}".format(
                    node_id, cell, width, height))
            self._cell[node_id] = cell
            self._id[cell] = node_id

    def in_bounds(self, cell: Coord) -> bool:
        return 0 <= cell[0] < self.width and 0 <= cell[1] < self.height

    def ids(self) -> List[int]:
        return sorted(self._cell)

    def __len__(self) -> int:
        return len(self._cell)

    def cell_of(self, node_id: int) -> Coord:
        """The base cell of node `node_id` (KeyError naming it if unknown)."""
        try:
            return self._cell[node_id]
        except KeyError:
            raise KeyError("no node {} in the lab grid".format(node_id)) from None

    def node_at(self, cell: Coord) -> Optional[int]:
        """The node id at `cell`, None for a blocked cell or one outside the grid."""
        return self._id.get((int(cell[0]), int(cell[1])))

    def cell_to_metres(self, cell: Coord) -> Metres:
        """Robot-frame position of a cell centre (any cell, node or not)."""
        return self.to_metres.apply((float(cell[0]), float(cell[1])))

    def metres_to_cell(self, position: Metres, tolerance: float = 0.1) -> Optional[Coord]:
        """The grid cell whose centre is within `tolerance` metres of `position`, else None."""
        fx, fy = self._from_metres.apply(position)
        cell = (int(round(fx)), int(round(fy)))
        if not self.in_bounds(cell):
            return None
        cx, cy = self.cell_to_metres(cell)
        return cell if np.hypot(cx - position[0], cy - position[1]) <= tolerance else None

    def holes(self) -> List[Coord]:
        """Cells without a node (blocked), bottom row first."""
        return [(x, y) for y in range(self.height) for x in range(self.width)
                if (x, y) not in self._id]

    def grid(self) -> Grid:
        free = np.zeros((self.height, self.width), dtype=bool)
        for x, y in self._id:
            free[y, x] = True
        return Grid(free, name="lab")


def _int(value: Any, what: str, path: str, data: Any, key: Any) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or value < 0:
        raise FormatError("{} must be a non-negative integer, got {}".format(what, excerpt(value)),
                          path, *where(data, key))
    return value


def _pair(value: Any, what: str, path: str, data: Any, key: Any) -> List[Any]:
    if not isinstance(value, list) or len(value) != 2:
        raise FormatError("{} must be a pair [a, b], got {}".format(what, excerpt(value)),
                          path, *where(data, key))
    return value


def parse_node_table(text: str, path: str, to_metres: Transform2D) -> NodeTable:
    """The table in `text` (nodes.yaml format); FormatError naming the line if malformed."""
    data = load_marked(text, path)
    if not isinstance(data, dict) or not {"width", "height", "nodes"} <= set(data):
        raise FormatError("expected a mapping with width, height and nodes", path, *where(data))
    width = _int(data["width"], "width", path, data, "width")
    height = _int(data["height"], "height", path, data, "height")
    if width * height > MAX_GRID_CELLS:
        raise FormatError("a {:,} x {:,} grid is larger than the {:,} cells FleetControl "
                          "builds".format(width, height, MAX_GRID_CELLS), path, *where(data))
    nodes = data["nodes"]
    if not isinstance(nodes, list):
        raise FormatError("nodes must be a list", path, *where(data, "nodes"))
    seen: Dict[Any, int] = {}
    entries: List[Tuple[int, Coord]] = []
    for index, node in enumerate(nodes):
        line = where(nodes, index)[0]
        if not isinstance(node, dict) or set(node) != {"id", "cell", "position"}:
            raise FormatError("a node is {id: N, cell: [x, y], position: [X, Y]}", path, line)
        node_id = _int(node["id"], "id", path, node, "id")
        cell_xy = _pair(node["cell"], "cell", path, node, "cell")
        cell = (_int(cell_xy[0], "cell x", path, cell_xy, 0), _int(cell_xy[1], "cell y", path,
                                                                    cell_xy, 1))
        if not (cell[0] < width and cell[1] < height):
            raise FormatError("cell {} is outside the {}x{} grid".format(list(cell), width, height),
                              path, *where(node, "cell"))
        for key, value in (("id", node_id), ("cell", cell)):
            if (key, value) in seen:
                raise FormatError("{} {} is already used on line {}".format(
                    key, value, seen[(key, value)]), path, *where(node, key))
            seen[(key, value)] = line or 0
        position = _pair(node["position"], "position", path, node, "position")
        expected = to_metres.apply(cell)
        numeric = all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in position)
        if not numeric or np.hypot(position[0] - expected[0],
                                   position[1] - expected[1]) > POSITION_TOLERANCE:
            raise FormatError("position {} of node {} disagrees with {} ({:.3f}, {:.3f})".format(
                excerpt(position), node_id, to_metres.name(), *expected), path,
                *where(node, "position"))
        entries.append((node_id, cell))
    return NodeTable(width, height, entries, to_metres)
