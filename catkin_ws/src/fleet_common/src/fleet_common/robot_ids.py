"""A part of the fleet named by robot ids and ranges: `1-150,300`.

Several `fleetctl virtual-fleet` processes, on one host or several, each
serve a part of one robot definitions file; the manager still reads the
whole file and sees one fleet. `parse_robot_ids` reads the text a user types
(ids and inclusive ranges, separated by commas), `select_robots` takes those
robots from the definitions, in file order, and refuses an id the file does
not define (or a range that holds none of its robots).
"""
from __future__ import annotations

import re
from typing import List, Sequence, Tuple

from .errors import RobotDefinitionsError
from .limits import MAX_INT_DIGITS, excerpt
from .robots import RobotDefinition

__all__ = ["IdRanges", "parse_robot_ids", "select_robots", "describe_ids"]

#: Longest id list a user may type (a thousand ids, one by one, take under 5,000 characters).
MAX_IDS_CHARS = 10_000

#: Inclusive (first, last) pairs; a single id is (id, id).
IdRanges = List[Tuple[int, int]]

_PART = re.compile(r"([0-9]{1,%d})(?:-([0-9]{1,%d}))?\Z" % (MAX_INT_DIGITS, MAX_INT_DIGITS))
FORM = "robot ids and ranges separated by commas, e.g. 1-150,300"


def parse_robot_ids(text: str) -> IdRanges:
    """The ranges of `text`; ValueError saying what was expected and where it went wrong."""
    if len(text) > MAX_IDS_CHARS:
        raise ValueError("expected {}, got {} characters (at most {})".format(FORM, len(text), MAX_IDS_CHARS))
    out: IdRanges = []
    for part in text.split(","):
        m = _PART.match(part.strip())
        if m is None:
            raise ValueError("expected {}, got {} in {}".format(FORM, excerpt(part.strip()), excerpt(text)))
        first = int(m.group(1))
        last = int(m.group(2)) if m.group(2) is not None else first
        if last < first:
            raise ValueError("range {} runs backwards; expected first-last with first <= last".format(
                excerpt(part.strip())))
        out.append((first, last))
    return out


def select_robots(robots: Sequence[RobotDefinition], ranges: IdRanges,
                  path: str = "robot_definitions.txt") -> List[RobotDefinition]:
    """The robots of `robots` whose ids `ranges` names, in file order."""
    ids = {r.id for r in robots}
    for first, last in ranges:
        if first == last and first not in ids:
            raise RobotDefinitionsError("robot {} is not defined (this file defines {})".format(
                first, describe_ids(sorted(ids))), path)
        if first != last and not any(first <= i <= last for i in ids):
            raise RobotDefinitionsError("no robot of {}-{} is defined (this file defines {})".format(
                first, last, describe_ids(sorted(ids))), path)
    return [r for r in robots if any(first <= r.id <= last for first, last in ranges)]


def describe_ids(ids: Sequence[int]) -> str:
    """Ascending ids as ranges, `1-150,300`, the form `parse_robot_ids` reads."""
    parts: List[str] = []
    start = prev = None
    for i in ids:
        if prev is not None and i == prev + 1:
            prev = i
            continue
        if start is not None:
            parts.append(str(start) if start == prev else "{}-{}".format(start, prev))
        start = prev = i
    if start is not None:
        parts.append(str(start) if start == prev else "{}-{}".format(start, prev))
    return ",".join(parts)
