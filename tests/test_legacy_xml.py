"""The original FleetControl's XML: node maps and execution plans, and converting them."""
from __future__ import annotations

from pathlib import Path
from typing import List, Tuple

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from fleet_common.errors import LegacyFormatError, NotConvertibleError
from fleet_common.formats.legacy_convert import legacy_nodes_to_grid, legacy_plan_to_plan
from fleet_common.formats.legacy_xml import (
    parse_legacy_node_map,
    parse_legacy_plan,
    read_legacy_node_map,
    read_legacy_plan,
)
from fleet_common.frames import scale_translate
from fleet_common.lab import node_table
from fleet_common.plan import Orientation
from fleet_common.validate import validate_plan

DATA = Path(__file__).resolve().parent / "data" / "legacy"
LAB_SCALE, LAB_ORIGIN = 0.7, (0.7, 2.1)


def test_lab_node_map_gives_the_lab_grid() -> None:
    nodemap = read_legacy_node_map(DATA / "lab_nodes.xml")
    assert len(nodemap.nodes) == 164
    assert nodemap.nodes[0].kind == "PickStationNode" and nodemap.nodes[0].line == 7
    grid, cells = legacy_nodes_to_grid(nodemap)
    table = node_table()
    assert grid == table.grid()
    assert cells == {node_id: table.cell_of(node_id) for node_id in table.ids()}
    # Edges are not used, but counted: one per pair of neighbouring nodes.
    assert nodemap.other_elements["Edge"] == sum(map(len, grid.adjacency())) // 2 == 293


def test_thesis_node_example_lands_on_its_cell() -> None:
    text = '<Map><PickStationNode Id="464" X="3.5" Y="2.1"></PickStationNode>\n<Edge/></Map>'
    nodemap = parse_legacy_node_map(text)
    grid, cells = legacy_nodes_to_grid(nodemap)
    assert cells == {464: (4, 0)}
    assert (grid.width, grid.height) == (5, 1) and grid.is_free((4, 0))
    # Another transform: a node map already in cells.
    in_cells = scale_translate(1.0, 0.0, 0.0, "base", "robot")
    assert legacy_nodes_to_grid(parse_legacy_node_map(
        '<m><ANode Id="1" X="2" Y="3"/></m>'), in_cells)[1] == {1: (2, 3)}


def test_lab_plan_converts_with_the_documented_time_steps() -> None:
    legacy = read_legacy_plan(DATA / "lab_plan.xml")
    assert [a.id for a in legacy.agents] == [1, 2, 7]
    assert [len(a.sections) for a in legacy.agents] == [3, 2, 2]
    plan, starts, goals = legacy_plan_to_plan(legacy, LAB_SCALE, LAB_ORIGIN)
    assert starts == [(1, 2), (6, 4), (10, 10)] and goals == [(4, 5), (2, 4), (10, 6)]
    assert plan.path(0) == [(1, 2), (2, 2), (3, 2), (4, 2), (4, 2), (4, 2), (4, 3), (4, 4), (4, 5)]
    assert plan.path(1) == [(6, 4), (6, 4), (6, 4), (5, 4), (4, 4), (3, 4), (2, 4), (2, 4), (2, 4)]
    assert plan.path(2)[:5] == [(10, 10), (10, 9), (10, 8), (10, 7), (10, 6)]
    x_plus, y_plus, x_minus, y_minus = (int(o) for o in Orientation)
    assert plan.orientations[:, 0].tolist() == [x_plus] * 4 + [y_plus] * 5
    assert plan.orientations[:, 1].tolist() == [x_minus] * 9
    # Agent 7's quick final turn (0 steps) is done by the end of its last move.
    assert plan.orientations[:, 2].tolist() == [y_minus] * 4 + [x_minus] * 5
    assert validate_plan(plan, node_table().grid(), starts, goals).ok


def test_thesis_figure_plan_is_read_but_not_convertible() -> None:
    legacy = read_legacy_plan(DATA / "thesis_fig3_1_plan.xml")
    agent = legacy.agents[0]
    assert (agent.id, agent.movespeed, agent.path_found, len(agent.sections)) == (5, 0.25, True, 9)
    assert agent.sections[8].line == 15
    with pytest.raises(NotConvertibleError) as err:
        legacy_plan_to_plan(legacy)
    assert str(err.value) == (
        "agent 5 section 1: diagonal move (37,37)->(36,31) is not along a grid line")


def agent_xml(agent_id: int, poses: List[Tuple[float, float, float, float]],
              speed: float = 1.0, found: str = "true") -> str:
    """An <agent> whose sections run pose to pose; a pose is (x, y, heading, duration)."""
    (x0, y0, h0, _), (xn, yn, hn, _) = poses[0], poses[-1]
    sections = "".join(
        '<section id="{}" start.x="{}" start.y="{}" start.heading="{}" goal.x="{}" goal.y="{}" '
        'goal.heading="{}" duration="{}"/>\n'.format(i, a[0], a[1], a[2], b[0], b[1], b[2], b[3])
        for i, (a, b) in enumerate(zip(poses, poses[1:])))
    return ('<agent id="{}" start.x="{}" start.y="{}" start.heading="{}" goal.x="{}" goal.y="{}" '
            'goal.heading="{}" size="0.4" movespeed="{}" rotationspeed="0.2">\n'
            '<path pathfound="{}" runtime="0" duration="0">\n{}</path>\n</agent>\n').format(
                agent_id, x0, y0, h0, xn, yn, hn, speed, found, sections)


@pytest.mark.parametrize(
    "agents, scale, origin, message",
    [
        ([(3, [(1.4, 3.5, 0, 0), (2.45, 3.5, 0, 3)])], LAB_SCALE, LAB_ORIGIN,
         "agent 3 section 0: end point (2.45, 3.5) is not on a grid cell"),
        ([(3, [(1, 1, 0, 0), (1, 1, 90, 1)], "false")], 1.0, (0, 0),
         "agent 3: the planner found no path (pathfound=false)"),
        ([(4, [(0.7, 2.1, 0, 0), (0.0, 2.1, 180, 1)])], LAB_SCALE, LAB_ORIGIN,
         "agent 4 section 0: end point (0, 2.1) is at cell (-1, 0), left of or below the base"),
        ([(1, [(0, 0, 0, 0), (2, 0, 0, 2)]), (9, [(5, 5, 0, 0), (6, 6, 0, 2)])], 1.0, (0, 0),
         "agent 9 section 0: diagonal move (5,5)->(6,6) is not along a grid line"),
    ],
)
def test_plans_off_the_grid_are_not_convertible(agents: list, scale: float, origin: tuple,
                                                 message: str) -> None:
    text = "<plan>{}</plan>".format("".join(
        agent_xml(a[0], a[1], found=a[2] if len(a) > 2 else "true") for a in agents))
    with pytest.raises(NotConvertibleError) as err:
        legacy_plan_to_plan(parse_legacy_plan(text), scale, origin)
    assert message in str(err.value)


# A grid walk (steps of one cell or waits) written as a legacy plan converts back to itself.
walks = st.lists(st.sampled_from([(0, 0), (1, 0), (-1, 0), (0, 1), (0, -1)]), max_size=25)


def walk_to_poses(start: Tuple[int, int], moves: List[Tuple[int, int]], scale: float,
                  origin: Tuple[float, float], step: float) -> Tuple[list, List[Tuple[int, int]]]:
    cells = [start]
    for dx, dy in moves:
        cells.append((cells[-1][0] + dx, cells[-1][1] + dy))
    to_legacy = lambda c: (origin[0] + scale * c[0], origin[1] + scale * c[1])  # noqa: E731
    poses = [(*to_legacy(start), 0.0, 0.0)]
    for cell in cells[1:]:
        # One section per step: a move of one cell, or a wait of one step's duration.
        poses.append((*to_legacy(cell), 0.0, step))
    return poses, cells


@given(st.lists(walks, min_size=1, max_size=4), st.sampled_from([1.0, 0.7, 2.5]),
       st.sampled_from([0.25, 0.35, 1.0]))
def test_grid_walks_round_trip_through_legacy_xml(agent_walks: list, scale: float,
                                                  speed: float) -> None:
    origin = (0.7, 2.1)
    expected = []
    xml = []
    for i, moves in enumerate(agent_walks):
        start = (30 + 3 * i, 30)  # far from the origin: walks never reach negative cells
        poses, cells = walk_to_poses(start, moves, scale, origin, scale / speed)
        xml.append(agent_xml(i, poses, speed))
        expected.append(cells)
    plan, starts, goals = legacy_plan_to_plan(
        parse_legacy_plan("<plan>" + "".join(xml) + "</plan>"), scale, origin)
    assert [plan.path(i)[:len(cells)] for i, cells in enumerate(expected)] == expected
    assert starts == [c[0] for c in expected] and goals == [c[-1] for c in expected]
    assert np.all(plan.orientations == int(Orientation.X_PLUS))


# ---- malformed files: errors name the file, the line and what was expected ----

SECTION = ('<section id="0" start.x="1" start.y="1" start.heading="0" goal.x="2" goal.y="1" '
           'goal.heading="0" duration="1"/>\n')
AGENT = ('<agent id="1" start.x="1" start.y="1" start.heading="0" goal.x="2" goal.y="1" '
         'goal.heading="0" size="0.4" movespeed="1" rotationspeed="1">\n')
PATH = '<path pathfound="true" runtime="0" duration="1">\n'


def plan_text(sections: str = SECTION, agent: str = AGENT, more: str = "") -> str:
    return "<plan>\n" + agent + PATH + sections + "</path>\n</agent>\n" + more + "</plan>\n"


@pytest.mark.parametrize(
    "text, line, fragment",
    [
        ("<plan>\n<agent id='1'>\n</plan>\n", 3, "not well-formed XML: mismatched tag"),
        ("", 1, "not well-formed XML: no element found"),
        (plan_text(SECTION.replace(' duration="1"', "")), 4,
         '<section> lacks the attribute duration="..."'),
        (plan_text(SECTION.replace('start.x="1"', 'start.x="one"')), 4,
         '<section> start.x="one": expected a number'),
        (plan_text(SECTION.replace('duration="1"', 'duration="-2"')), 4,
         '<section> duration="-2": expected a duration >= 0'),
        (plan_text(agent=AGENT.replace('movespeed="1"', 'movespeed="0"')), 2,
         '<agent> movespeed="0": expected a speed > 0'),
        (plan_text(agent=AGENT.replace('id="1"', 'id="1.5"')), 2,
         '<agent> id="1.5": expected an integer'),
        (plan_text(SECTION + SECTION.replace('id="0" start.x="1"', 'id="1" start.x="3"')), 5,
         "agent 1 section 1: starts at (3, 1, heading 0) but the previous section ended at "
         "(2, 1, heading 0)"),
        (plan_text(SECTION + SECTION.replace('id="0" start.x="1"', 'id="1" start.x="2"')
                   .replace('goal.x="2"', 'goal.x="3"').replace('start.heading="0"',
                                                                'start.heading="90"')), 5,
         "section 1: starts at (2, 1, heading 90) but the previous section ended"),
        (plan_text(SECTION + SECTION.replace('start.x="1"', 'start.x="2"')), 5,
         "agent 1: section id 0 appears twice"),
        (plan_text(agent=AGENT.replace('start.y="1"', 'start.y="0"')), 4,
         "agent 1 section 0: starts at (1, 1, heading 0) but the agent starts at (1, 0,"),
        (plan_text(agent=AGENT.replace('goal.x="2"', 'goal.x="5"')), 4,
         "agent 1 section 0: ends at (2, 1, heading 0) but the agent's goal is (5, 1,"),
        (plan_text(more=AGENT + PATH + SECTION + "</path></agent>\n"), 7,
         "agent id 1 is already used on line 2"),
        ("<plan>\n" + AGENT + "</agent></plan>", 2, "agent 1 has 0 <path> elements, expected one"),
        ("<plan>\n<robot/>\n</plan>", 1, "no <agent> elements: is this an execution plan?"),
    ],
)
def test_malformed_plan(text: str, line: int, fragment: str) -> None:
    with pytest.raises(LegacyFormatError) as err:
        parse_legacy_plan(text, "plan.xml")
    assert (err.value.path, err.value.line) == ("plan.xml", line)
    assert fragment in err.value.message


@pytest.mark.parametrize(
    "text, line, fragment",
    [
        ('<Map>\n<PickStationNode Id="1" X="0.7"/>\n</Map>', 2,
         '<PickStationNode> lacks the attribute Y="..."'),
        ('<Map>\n<ANode Id="1" X="0.7" Y="2.1"/>\n<ANode Id="1" X="1.4" Y="2.1"/>\n</Map>', 3,
         "node Id 1 is already defined on line 2"),
        ('<Map>\n<Edge From="1" To="2"/>\n</Map>', 1, "no node elements"),
        ('<Map>\n<ANode Id="1" X="0.7" Y="2.1"/>\n<ANode Id="2" X="1.0" Y="2.1"/>\n</Map>', 3,
         "node 2 at (1, 2.1) is not on a cell centre: it maps to cell (0.429, 0.000)"),
        ('<Map>\n<ANode Id="1" X="0.7" Y="2.1"/>\n<ANode Id="2" X="0.7" Y="2.1"/>\n</Map>', 3,
         "node 2 at (0.7, 2.1) is on cell (0, 0), as the node on line 2"),
        ('<Map>\n\n<ANode Id="1" X="0" Y="2.1"/>\n</Map>', 3,
         "node 1 at (0, 2.1) maps to cell (-1, 0), left of or below the base grid"),
        ('<Map>\n  <ANode Id="1" X="0.7" Y="2.1">\n</Map>', 3, "mismatched tag"),
    ],
)
def test_malformed_node_map(text: str, line: int, fragment: str) -> None:
    with pytest.raises(LegacyFormatError) as err:
        legacy_nodes_to_grid(parse_legacy_node_map(text, "Projekt_mapa4.xml"))
    assert (err.value.path, err.value.line) == ("Projekt_mapa4.xml", line)
    assert fragment in err.value.message
    assert str(err.value).startswith("Projekt_mapa4.xml:{}:".format(line))


def test_unreadable_files_name_their_path(tmp_path: Path) -> None:
    for reader in (read_legacy_plan, read_legacy_node_map):
        with pytest.raises(LegacyFormatError, match="nope.xml: cannot read"):
            reader(tmp_path / "nope.xml")
