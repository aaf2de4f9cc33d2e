"""The fleet: `robot_definitions.txt`, the single source of truth (thesis 5.2).

One robot a line, six whitespace-separated fields in the thesis's order:

    id  host  command_port  ssh_user  vicon_name  colour
    1   192.168.2.11  10001  turtlebot  turtlebot1  red

`#` starts a comment (a whole line, or the rest of a line) when it begins a
field, except in the colour field, where `#` and letters or digits are a hex
colour (`#ff8800`; `#ggg` is then reported as a bad colour).
Blank lines are ignored. One optional line gives the robots' size for the
whole fleet (`size diameter=0.354 margin=0.10`, metres; see `robot_size`).
Every field is checked, and ids, host:port pairs and
Vicon names must be unique; a bad line raises `RobotDefinitionsError` naming
the file, line and column of the field and what was expected, quoting the
field as a short excerpt. Lines end at LF (a CR before it is dropped) and
nowhere else, so line numbers are an editor's; the file has at most
MAX_DEFINITIONS_BYTES of UTF-8.
"""
from __future__ import annotations

import os
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Dict, Iterable, List, Optional, Tuple, Union

from .colours import COLOUR_FORMS, colour_to_rgb, is_tk_colour
from .errors import RobotDefinitionsError
from .limits import (MAX_DEFINITIONS_BYTES, MAX_INT_DIGITS, MAX_NAME_CHARS, VICON_NAME_BYTES,
                     excerpt)
from .robot_size import RobotSize, parse_size_line

__all__ = [
    "RobotDefinition", "parse_robot_definitions", "read_robot_definitions",
    "format_robot_definitions", "default_definitions_path", "colour_to_rgb",
    "parse_robot_size", "read_robot_size",
]

FILE_NAME = "robot_definitions.txt"
ENV_VAR = "FLEETCONTROL_ROBOTS"
COLUMNS = ("id", "host", "command_port", "ssh_user", "vicon_name", "colour")
SIZE_LINE = "size"

_IPV4_LIKE = re.compile(r"[0-9.]+\Z")
_OCTET = re.compile(r"(?:0|[1-9][0-9]{0,2})\Z")
_LABEL = re.compile(r"[A-Za-z0-9](?:[A-Za-z0-9-]{0,61}[A-Za-z0-9])?\Z")
# POSIX portable user name (portable filename characters, no leading hyphen), as useradd caps it.
_USER = re.compile(r"[A-Za-z0-9._][A-Za-z0-9._-]{0,31}\Z")
_COLOUR_LIKE = re.compile(r"#[0-9A-Za-z]+\Z")
_TOKEN = re.compile(r"\S+")


@dataclass(frozen=True)
class RobotDefinition:
    """One robot of the fleet; `line` is where it was defined (0 when built in code)."""

    id: int
    host: str
    command_port: int
    ssh_user: str
    vicon_name: str
    colour: str
    line: int = field(default=0, compare=False)

    @property
    def address(self) -> str:
        return "{}:{}".format(self.host, self.command_port)


def _fields(text: str) -> List[Tuple[int, str]]:
    """(1-based column, token) of the fields of one line, comments removed."""
    out: List[Tuple[int, str]] = []
    for match in _TOKEN.finditer(text):
        token = match.group()
        if token.startswith("#") and not (len(out) == 5 and _COLOUR_LIKE.match(token)):
            break
        out.append((match.start() + 1, token))
    return out


def _valid_host(host: str) -> bool:
    if _IPV4_LIKE.match(host):  # all digits and dots: must be a dotted quad
        octets = host.split(".")
        return len(octets) == 4 and all(_OCTET.match(o) and int(o) <= 255 for o in octets)
    labels = host.split(".")
    # RFC 1123 2.1: the last label is never all digits, so a name cannot pass for an address.
    return (len(host) <= 253 and all(_LABEL.match(label) for label in labels)
            and not labels[-1].isdigit())


def _check_field(name: str, token: str) -> Optional[str]:
    """None when `token` is a valid `name` field, else what was expected."""
    if not token.isprintable():
        return "printable characters only"
    if name == "id":
        ok = token.isdigit() and token.isascii() and len(token) <= MAX_INT_DIGITS
        return None if ok else "a non-negative integer of at most {} digits".format(MAX_INT_DIGITS)
    if name == "host":
        return None if _valid_host(token) else (
            "an IPv4 address (four numbers 0-255, e.g. 192.168.2.11) or a host name "
            "(letters, digits, hyphens; dot-separated labels)"
        )
    if name == "command_port":
        ok = token.isdigit() and token.isascii() and len(token) <= 5 and 1 <= int(token) <= 65535
        return None if ok else "a port number 1..65535"
    if name == "ssh_user":
        return None if _USER.match(token) else (
            "a user name (letters, digits, '.', '_', '-'; not starting with '-'; at most 32)"
        )
    if name == "colour":
        return None if len(token) <= MAX_NAME_CHARS and is_tk_colour(token) else COLOUR_FORMS
    # vicon_name: Tracker's UDP stream carries at most VICON_NAME_BYTES of name
    if len(token.encode("utf-8")) <= VICON_NAME_BYTES:
        return None
    return "a name of at most {} bytes".format(VICON_NAME_BYTES)


def parse_robot_definitions(text: str, path: Optional[str] = None) -> List[RobotDefinition]:
    """The robots defined in `text`, in file order; RobotDefinitionsError if malformed."""
    robots: List[RobotDefinition] = []
    first: Dict[Tuple[str, str], RobotDefinition] = {}  # (what, key) -> first robot using it
    for number, line in enumerate(text.split("\n"), 1):
        line = line[:-1] if line.endswith("\r") else line
        fields = _fields(line)
        if not fields:
            continue
        if fields[0][1] == SIZE_LINE:
            parse_size_line(fields, path, number)  # checked here, read by parse_robot_size
            continue
        if len(fields) != len(COLUMNS):
            column = fields[len(COLUMNS)][0] if len(fields) > len(COLUMNS) else None
            raise RobotDefinitionsError(
                "expected {} fields ({}), found {}".format(
                    len(COLUMNS), " ".join(COLUMNS), len(fields)),
                path, number, column)
        for name, (column, token) in zip(COLUMNS, fields):
            expected = _check_field(name, token)
            if expected is not None:
                raise RobotDefinitionsError(
                    "bad {} {}: expected {}".format(name, excerpt(token), expected), path, number,
                    column)
        values = [token for _, token in fields]
        robot = RobotDefinition(
            int(values[0]), values[1], int(values[2]), values[3], values[4], values[5], number)
        unique = (
            ("robot id", str(robot.id), 0),
            ("address", robot.address.lower(), 1),
            ("Vicon name", robot.vicon_name, 4),
        )
        for what, key, index in unique:
            earlier = first.setdefault((what, key), robot)
            if earlier is not robot:
                raise RobotDefinitionsError(
                    "{} {} is already used by robot {} on line {}".format(
                        what, key, earlier.id, earlier.line),
                    path, number, fields[index][0])
        robots.append(robot)
    if not robots:
        raise RobotDefinitionsError(
            "no robot defined: expected lines of '{}'".format(" ".join(COLUMNS)), path)
    return robots


def parse_robot_size(text: str, path: Optional[str] = None, cell: Optional[float] = None) -> RobotSize:
    """The robots' size from `text`'s size line (a TurtleBot 2 without one); `cell` in metres
    (default: the lab's)."""
    size = RobotSize()
    seen = 0
    for number, line in enumerate(text.split("\n"), 1):
        fields = _fields(line[:-1] if line.endswith("\r") else line)
        if fields and fields[0][1] == SIZE_LINE:
            seen += 1
            if seen > 1:
                raise RobotDefinitionsError("a second size line: the fleet has one size", path, number)
            size = parse_size_line(fields, path, number)
    return size if cell is None else size.with_cell(cell)


def read_robot_size(path: Union[str, Path, None] = None, cell: Optional[float] = None) -> RobotSize:
    """The robots' size in a definitions file (default: `default_definitions_path()`)."""
    from .formats.lines import read_text

    path = Path(path) if path is not None else default_definitions_path()
    text = read_text(str(path), RobotDefinitionsError, MAX_DEFINITIONS_BYTES, strict=True)
    return parse_robot_size(text, str(path), cell)


def read_robot_definitions(path: Union[str, Path, None] = None) -> List[RobotDefinition]:
    """Read and check a definitions file (default: `default_definitions_path()`)."""
    from .formats.lines import read_text

    path = Path(path) if path is not None else default_definitions_path()
    text = read_text(str(path), RobotDefinitionsError, MAX_DEFINITIONS_BYTES, strict=True)
    return parse_robot_definitions(text, str(path))


def format_robot_definitions(robots: Iterable[RobotDefinition]) -> str:
    """The file text for `robots`: a header naming the columns, then aligned lines."""
    rows = [list(COLUMNS)]
    rows[0][0] = "# " + rows[0][0]
    for r in robots:
        rows.append([str(r.id), r.host, str(r.command_port), r.ssh_user, r.vicon_name, r.colour])
    widths = [max(len(row[i]) for row in rows) for i in range(len(COLUMNS))]
    lines = ["  ".join(cell.ljust(w) for cell, w in zip(row, widths)).rstrip() for row in rows]
    return "\n".join(lines) + "\n"


def default_definitions_path() -> Path:
    """$FLEETCONTROL_ROBOTS if set, else the repository's robot_definitions.txt.

    The repository is found by walking up from this module (source tree, catkin
    devel space); failing that, the file in the current directory.
    """
    env = os.environ.get(ENV_VAR)
    if env:
        return Path(env)
    for folder in Path(__file__).resolve().parents:
        if (folder / FILE_NAME).is_file():
            return folder / FILE_NAME
    return Path.cwd() / FILE_NAME
