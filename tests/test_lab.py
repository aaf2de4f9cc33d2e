"""The embedded lab (thesis figures 3.8 and 5.8): nodes, map, transforms, default instance."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from fleet_common.errors import FormatError
from fleet_common.formats.instance import read_instance
from fleet_common.formats.mapfile import read_map
from fleet_common.frames import scale_translate
from fleet_common.lab import (
    base_to_robot,
    lab_instance_path,
    lab_map_path,
    lab_nodes_path,
    lab_transforms,
    node_table,
)
from fleet_common.lab.node_table import parse_node_table

#: Nodes per row in figure 3.8, bottom row (Y = 2.1 m) first.
NODES_PER_ROW = [6, 10, 13, 13, 13, 13, 12, 13, 13, 13, 13, 13, 11, 8]


def test_node_table_is_the_13_by_14_figure() -> None:
    table = node_table()
    assert (table.width, table.height) == (13, 14)
    ids = table.ids()
    assert len(ids) == len(set(ids)) == sum(NODES_PER_ROW) == 164
    per_row = [sum(table.node_at((x, y)) is not None for x in range(13)) for y in range(14)]
    assert per_row == NODES_PER_ROW


def test_node_ids_transcribed_from_the_figure() -> None:
    table = node_table()
    row = lambda y: [table.node_at((x, y)) for x in range(13)]  # noqa: E731
    assert row(0) == [None, 419, 433, None, None, None, None, None, 524, 539, 554, 569, None]
    assert row(1) == [405, 605, 606, 607, None, 609, None, 623, None, 540, 555, 570, 585]
    assert row(13) == [None, 597, 598, 599, 600, None, None, None, 601, 602, 603, 604, None]
    assert table.node_at((6, 5)) == 612 and table.cell_of(612) == (6, 5)
    assert table.node_at((6, 6)) is None
    assert [table.node_at((0, y)) for y in range(1, 12)] == list(range(405, 416))
    with pytest.raises(KeyError, match="no node 464"):
        table.cell_of(464)  # the thesis's XML example node: no bar code on the floor


def test_lab_map_blocks_exactly_the_cells_without_nodes() -> None:
    grid = read_map(str(lab_map_path())).grid
    assert (grid.width, grid.height) == (13, 14)
    blocked = {(x, y) for y in range(14) for x in range(13) if not grid.is_free((x, y))}
    assert blocked == set(node_table().holes())
    assert grid == node_table().grid()
    first_rows = lab_map_path().read_text().splitlines()[:5]
    assert first_rows == ["type octile", "height 14", "width 13", "map", "@....@@@....@"]


def test_cells_and_metres_round_trip_through_the_lab_transform() -> None:
    table = node_table()
    assert table.cell_to_metres((0, 0)) == pytest.approx((0.7, 2.1))
    assert table.cell_to_metres((12, 13)) == pytest.approx((9.1, 11.2))
    assert table.cell_to_metres(table.cell_of(612)) == pytest.approx((4.9, 5.6))
    for y in range(14):
        for x in range(13):
            X, Y = table.cell_to_metres((x, y))
            assert table.metres_to_cell((X, Y)) == (x, y)
            assert table.metres_to_cell((X + 0.06, Y - 0.06), tolerance=0.1) == (x, y)
            assert table.metres_to_cell((X + 0.3, Y)) is None  # between two cells
    assert table.metres_to_cell((0.0, 2.1)) is None  # left of column 0
    assert table.metres_to_cell((9.1, 11.9)) is None  # above the top row


def test_lab_frames_file_holds_the_figure_5_8_transform() -> None:
    assert set(lab_transforms()) == {"base_to_robot", "vicon_to_base"}
    assert base_to_robot().is_close(scale_translate(0.7, 0.7, 2.1, "base", "robot"))


def test_default_instance_is_five_robots_crossing_the_lab() -> None:
    inst = read_instance(str(lab_instance_path()))
    assert inst.map_file == "lab.map" and not inst.random_problem and inst.num_agents == 5
    # Two robots cross left <-> right, two bottom <-> top, one corner to corner (base frame).
    assert inst.starts == [(1, 8), (11, 5), (5, 12), (9, 3), (1, 11)]
    assert inst.goals == [(11, 8), (1, 5), (5, 3), (9, 12), (11, 2)]
    table = node_table()
    assert all(table.node_at(c) is not None for c in inst.starts + inst.goals)
    assert len(set(inst.starts)) == len(set(inst.goals)) == 5
    # The file itself is in mapf-IR orientation: the first robot's start row is 13 - 8.
    assert lab_instance_path().read_text().splitlines()[6] == "1,5,11,5"


NODE = "- {id: 419, cell: [1, 0], position: [1.4, 2.1]}\n"


@pytest.mark.parametrize(
    "nodes, line, fragment",
    [
        (NODE + "- {id: 419, cell: [2, 0], position: [2.1, 2.1]}\n", 6,
         "id 419 is already used on line 5"),
        (NODE + "- {id: 433, cell: [1, 0], position: [1.4, 2.1]}\n", 6,
         "cell (1, 0) is already used on line 5"),
        ("- {id: 433, cell: [2, 0], position: [2.1, 2.8]}\n", 5,
         "position [2.1, 2.8] of node 433 disagrees with base->robot (2.100, 2.100)"),
        ("- {id: 433, cell: [13, 0], position: [9.8, 2.1]}\n", 5,
         "cell [13, 0] is outside the 13x14 grid"),
        ("- {id: -4, cell: [2, 0], position: [2.1, 2.1]}\n", 5,
         "id must be a non-negative integer"),
        ("- {id: 4, cell: [2, 0]}\n", 5, "a node is {id: N, cell: [x, y], position: [X, Y]}"),
    ],
)
def test_malformed_nodes_file(nodes: str, line: int, fragment: str) -> None:
    text = "# nodes\nwidth: 13\nheight: 14\nnodes:\n" + nodes
    with pytest.raises(FormatError) as err:
        parse_node_table(text, "nodes.yaml", base_to_robot())
    assert (err.value.path, err.value.line) == ("nodes.yaml", line)
    assert fragment in err.value.message


def test_shipped_nodes_file_positions_are_two_decimals(tmp_path: Path) -> None:
    # What a lab person reads in nodes.yaml is what the robots use (no float noise).
    text = lab_nodes_path().read_text()
    assert "position: [4.9, 5.6]" in text and "0000" not in text
    table = parse_node_table(text, "nodes.yaml", base_to_robot())
    assert np.array_equal(table.grid().free, node_table().grid().free)
