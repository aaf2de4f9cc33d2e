"""Where each floor AprilTag lies: tag id -> position and yaw in the robot frame (metres).

The lab's tags carry their node ids (thesis 3.6.1: the bar-code numbers are
the node ids), so the default map is the lab's node table. The tag36h11
family has ids 0..586 only, so a node numbered 587 or more carries tag
`id - 587` (the lab's 597..623 become 10..36, which no node uses). A YAML
file can describe any other floor:

    # tag id -> where it lies on the floor, robot frame
    tags:
      - {id: 419, position: [1.4, 2.1]}            # yaw_deg defaults to 0
      - {id: 433, position: [2.1, 2.1], yaw_deg: 90}

A tag with yaw 0 is laid so that its printed top edge faces +y of the robot
frame. Malformed files raise `FormatError` naming the file and line.
"""
from __future__ import annotations

import math
from pathlib import Path
from typing import Any, Dict, Iterator, NamedTuple, Optional, Union

from fleet_common.errors import FormatError
from fleet_common.lab import NodeTable, node_table
from fleet_common.limits import excerpt
from fleet_common.yaml_lines import load_marked, read_yaml_text, where

#: The `tag_map` setting that selects the lab's node table.
LAB = "lab"
#: Number of distinct tags in the tag36h11 family.
FAMILY_SIZE = 587


class TagPlacement(NamedTuple):
    """A tag on the floor: centre (x, y) in metres and yaw (radians) in the robot frame."""

    x: float
    y: float
    yaw: float


class TagMap:
    """Tag id -> `TagPlacement`."""

    def __init__(self, tags: Dict[int, TagPlacement], source: str) -> None:
        self._tags = dict(tags)
        self.source = source

    def __contains__(self, tag_id: object) -> bool:
        return tag_id in self._tags

    def __len__(self) -> int:
        return len(self._tags)

    def __iter__(self) -> Iterator[int]:
        return iter(sorted(self._tags))

    def get(self, tag_id: int) -> Optional[TagPlacement]:
        return self._tags.get(tag_id)

    def items(self) -> Iterator[tuple]:
        return iter(sorted(self._tags.items()))

    @classmethod
    def from_node_table(cls, table: NodeTable, source: str = LAB) -> "TagMap":
        tags: Dict[int, TagPlacement] = {}
        owner: Dict[int, int] = {}
        for node_id in table.ids():
            tag_id = node_tag_id(node_id)
            if tag_id in owner:
                raise ValueError("nodes {} and {} would carry the same tag {}: give a tag map "
                                 "file".format(owner[tag_id], node_id, tag_id))
            owner[tag_id] = node_id
            x, y = table.cell_to_metres(table.cell_of(node_id))
            tags[tag_id] = TagPlacement(x, y, 0.0)
        return cls(tags, source)


def node_tag_id(node_id: int) -> int:
    """The tag36h11 id printed at lab node `node_id`."""
    return node_id % FAMILY_SIZE


def _number(value: Any, what: str, path: str, data: Any, key: Any) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise FormatError("{} must be a number, got {}".format(what, excerpt(value)), path,
                          *where(data, key))
    return float(value)


def parse_tag_map(text: str, path: str) -> TagMap:
    """The tag map in `text` (format above)."""
    data = load_marked(text, path)
    if not isinstance(data, dict) or set(data) != {"tags"} or not isinstance(data["tags"], list):
        raise FormatError("expected a mapping with one key, tags: a list of "
                          "{id: N, position: [X, Y], yaw_deg: A}", path, *where(data))
    tags: Dict[int, TagPlacement] = {}
    for index, entry in enumerate(data["tags"]):
        if not isinstance(entry, dict) or not {"id", "position"} <= set(entry) <= {
                "id", "position", "yaw_deg"}:
            raise FormatError("a tag is {id: N, position: [X, Y]} with an optional yaw_deg",
                              path, *where(data["tags"], index))
        tag_id = entry["id"]
        if isinstance(tag_id, bool) or not isinstance(tag_id, int) or tag_id < 0:
            raise FormatError("id must be a non-negative integer, got {}".format(excerpt(tag_id)),
                              path, *where(entry, "id"))
        if tag_id in tags:
            raise FormatError("tag {} is listed twice".format(tag_id), path, *where(entry, "id"))
        position = entry["position"]
        if not isinstance(position, list) or len(position) != 2:
            raise FormatError("position must be [X, Y] in metres, got {}".format(excerpt(position)),
                              path, *where(entry, "position"))
        x = _number(position[0], "position X", path, position, 0)
        y = _number(position[1], "position Y", path, position, 1)
        yaw = _number(entry.get("yaw_deg", 0.0), "yaw_deg", path, entry, "yaw_deg")
        tags[tag_id] = TagPlacement(x, y, math.radians(yaw))
    if not tags:
        raise FormatError("the tag map lists no tags", path, *where(data, "tags"))
    return TagMap(tags, path)


def load_tag_map(source: Union[str, Path] = LAB) -> TagMap:
    """`"lab"`: the lab's node table; anything else: a YAML tag map file."""
    if str(source) == LAB:
        return TagMap.from_node_table(node_table())
    if not Path(source).is_file():
        raise FormatError("cannot read the tag map: no such file (or give tag_map: {})".format(
            LAB), str(source))
    return parse_tag_map(read_yaml_text(str(source)), str(source))
