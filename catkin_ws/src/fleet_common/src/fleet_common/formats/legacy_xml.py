"""The original FleetControl's XML files (thesis 3.2): node maps and execution plans.

Node map (`Projekt_mapa4.xml`): every element whose tag ends in `Node` and has
any of `Id`, `X`, `Y` is a floor node and needs all three, e.g.
`<PickStationNode Id="464" X="3.5" Y="2.1">` (metres, robot frame). Edges and
everything else are not used, only counted per tag.

Execution plan (thesis fig. 3.1): `<agent id start.x start.y start.heading
goal.x goal.y goal.heading size movespeed rotationspeed>` elements (anywhere
in the document), each with one `<path pathfound runtime duration>` of
`<section id start.* goal.* duration>` elements. Sections must chain (each
starts where, and heading as, the previous one ended), the first must start at
the agent's start and the last end at its goal.

Files are read with expat so that every error names its line (and column for
XML syntax). Conversion to grids and plans: `formats.legacy_convert`.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Dict, List, Optional, Tuple, Union

from ..errors import LegacyFormatError
from .xml_tree import AttributeReader, Element, parse_xml, read_xml_bytes

#: Positions closer than this (legacy units) are the same; headings within HEADING_TOL degrees.
POSITION_TOL = 1e-6
HEADING_TOL = 1e-3


# ---- node map ------------------------------------------------------------------

@dataclass(frozen=True)
class LegacyNode:
    id: int
    kind: str  # the element's tag, e.g. "PickStationNode"
    x: float
    y: float
    line: int


@dataclass
class LegacyNodeMap:
    nodes: List[LegacyNode]
    #: tag -> how many elements of that tag are not nodes (edges, the root, ...)
    other_elements: Dict[str, int]
    path: Optional[str] = None


def parse_legacy_node_map(data: Union[str, bytes], path: Optional[str] = None) -> LegacyNodeMap:
    reader = AttributeReader(path, LegacyFormatError)
    nodes: List[LegacyNode] = []
    others: Dict[str, int] = {}
    first: Dict[int, int] = {}
    for el in parse_xml(data, path, LegacyFormatError).iter():
        if not (el.tag.endswith("Node") and {"Id", "X", "Y"} & set(el.attrs)):
            others[el.tag] = others.get(el.tag, 0) + 1
            continue
        node = LegacyNode(reader.integer(el, "Id"), el.tag, reader.number(el, "X"),
                          reader.number(el, "Y"), el.line)
        if node.id in first:
            raise reader.error(el, "node Id {} is already defined on line {}".format(
                node.id, first[node.id]))
        first[node.id] = el.line
        nodes.append(node)
    if not nodes:
        raise LegacyFormatError("no node elements (<...Node Id=\"..\" X=\"..\" Y=\"..\">): "
                                "is this a node map?", path, 1)
    return LegacyNodeMap(nodes, others, path)


def read_legacy_node_map(path: Union[str, Path]) -> LegacyNodeMap:
    return parse_legacy_node_map(read_xml_bytes(path, LegacyFormatError), str(path))


# ---- execution plan ----------------------------------------------------------------

@dataclass(frozen=True)
class Pose:
    x: float
    y: float
    heading: float  # degrees

    def same_place(self, other: "Pose") -> bool:
        return abs(self.x - other.x) <= POSITION_TOL and abs(self.y - other.y) <= POSITION_TOL

    def same(self, other: "Pose") -> bool:
        turn = (self.heading - other.heading + 180.0) % 360.0 - 180.0
        return self.same_place(other) and abs(turn) <= HEADING_TOL

    def __str__(self) -> str:
        return "({:g}, {:g}, heading {:g})".format(self.x, self.y, self.heading)


@dataclass(frozen=True)
class LegacySection:
    id: int
    start: Pose
    goal: Pose
    duration: float  # seconds
    line: int


@dataclass(frozen=True)
class LegacyAgent:
    id: int
    start: Pose
    goal: Pose
    size: float
    movespeed: float  # legacy units per second
    rotationspeed: float
    path_found: bool
    runtime: float
    duration: float
    sections: Tuple[LegacySection, ...]
    line: int


@dataclass
class LegacyPlan:
    agents: List[LegacyAgent]
    path: Optional[str] = None


def _pose(reader: AttributeReader, el: Element, prefix: str) -> Pose:
    return Pose(reader.number(el, prefix + ".x"), reader.number(el, prefix + ".y"),
                reader.number(el, prefix + ".heading"))


def _agent(reader: AttributeReader, el: Element) -> LegacyAgent:
    agent_id = reader.integer(el, "id")
    paths = [child for child in el.children if child.tag == "path"]
    if len(paths) != 1:
        raise reader.error(el, "agent {} has {} <path> elements, expected one".format(
            agent_id, len(paths)))
    path_el = paths[0]
    sections: List[LegacySection] = []
    for s in (child for child in path_el.children if child.tag == "section"):
        section = LegacySection(
            reader.integer(s, "id"), _pose(reader, s, "start"), _pose(reader, s, "goal"),
            reader.number(s, "duration", lambda v: v >= 0, "a duration >= 0"), s.line)
        if any(section.id == other.id for other in sections):
            raise reader.error(s, "agent {}: section id {} appears twice".format(
                agent_id, section.id))
        previous = sections[-1].goal if sections else None
        if previous is not None and not section.start.same(previous):
            raise reader.error(s, "agent {} section {}: starts at {} but the previous section "
                               "ended at {}".format(agent_id, section.id, section.start, previous))
        sections.append(section)
    agent = LegacyAgent(
        agent_id, _pose(reader, el, "start"), _pose(reader, el, "goal"),
        reader.number(el, "size", lambda v: v >= 0, "a size >= 0"),
        reader.number(el, "movespeed", lambda v: v > 0, "a speed > 0"),
        reader.number(el, "rotationspeed", lambda v: v > 0, "a speed > 0"),
        reader.flag(path_el, "pathfound"), reader.number(path_el, "runtime"),
        reader.number(path_el, "duration", lambda v: v >= 0, "a duration >= 0"),
        tuple(sections), el.line)
    _check_ends(reader, agent, path_el)
    return agent


def _check_ends(reader: AttributeReader, agent: LegacyAgent, path_el: Element) -> None:
    """The sections must lead from the agent's start to its goal."""
    if not agent.sections:
        if agent.path_found and not agent.start.same_place(agent.goal):
            raise reader.error(path_el, "agent {}: path has no sections but the start {} is not "
                               "the goal {}".format(agent.id, agent.start, agent.goal))
        return
    first, last = agent.sections[0], agent.sections[-1]
    if not first.start.same(agent.start):
        raise LegacyFormatError("agent {} section {}: starts at {} but the agent starts at "
                                "{}".format(agent.id, first.id, first.start, agent.start),
                                reader.path, first.line)
    if not last.goal.same(agent.goal):
        raise LegacyFormatError("agent {} section {}: ends at {} but the agent's goal is {}".format(
            agent.id, last.id, last.goal, agent.goal), reader.path, last.line)


def parse_legacy_plan(data: Union[str, bytes], path: Optional[str] = None) -> LegacyPlan:
    reader = AttributeReader(path, LegacyFormatError)
    agents: List[LegacyAgent] = []
    first: Dict[int, int] = {}
    for el in parse_xml(data, path, LegacyFormatError).iter():
        if el.tag != "agent":
            continue
        agent = _agent(reader, el)
        if agent.id in first:
            raise reader.error(el, "agent id {} is already used on line {}".format(
                agent.id, first[agent.id]))
        first[agent.id] = el.line
        agents.append(agent)
    if not agents:
        raise LegacyFormatError("no <agent> elements: is this an execution plan?", path, 1)
    return LegacyPlan(agents, path)


def read_legacy_plan(path: Union[str, Path]) -> LegacyPlan:
    return parse_legacy_plan(read_xml_bytes(path, LegacyFormatError), str(path))
