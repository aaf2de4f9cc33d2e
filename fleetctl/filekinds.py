"""Which supported format a file is, decided from its content (not its name alone).

The sniffing looks at the first meaningful lines, the way a person would:
`version 1` starts a MovingAI scenario, `<` an XML file of the original
system, `height`/`width`/`map` a grid map, a `solution=` line a solver output,
`map_file=` an instance, and six whitespace-separated fields (and a `size`
line) a robot definitions file.
"""
from __future__ import annotations

import re
from pathlib import Path

from fleet_common.errors import FormatError

MAP = "map"
INSTANCE = "instance"
SOLUTION = "solution"
SCEN = "scen"
LEGACY_MAP = "legacy-node-map"
LEGACY_PLAN = "legacy-plan"
ROBOTS = "robot-definitions"

KINDS = (MAP, INSTANCE, SOLUTION, SCEN, LEGACY_MAP, LEGACY_PLAN, ROBOTS)

_ROBOT_LINE = re.compile(r"^\s*(\d+\s+\S+\s+\d+\s+\S+\s+\S+\s+\S+|size(\s+\S+)+)\s*(#.*)?$")


def sniff(path: Path) -> str:
    """The kind of file at `path`, or FormatError naming what was expected."""
    with open(path, "rb") as f:
        head = f.read(1 << 16)
    text = head.decode("utf-8", errors="replace")
    stripped = text.lstrip("\ufeff \t\r\n")
    if stripped.startswith("<"):
        if re.search(r"<\s*agent[\s>]", text):
            return LEGACY_PLAN
        return LEGACY_MAP
    lines = [ln.strip() for ln in text.splitlines()]
    meaningful = [ln for ln in lines if ln and not ln.startswith("#")]
    if meaningful and re.match(r"^version\s+\d", meaningful[0]):
        return SCEN
    if any(ln == "map" for ln in meaningful[:8]) or any(
        re.match(r"^(height|width)\s+\d+$", ln) for ln in meaningful[:4]
    ):
        return MAP
    if any(ln.startswith("solution=") or ln.startswith("starts=") for ln in lines) or (
        meaningful and re.match(r"^instance\s*=", meaningful[0])
    ):
        return SOLUTION
    if any(re.match(r"^map_file\s*=", ln) for ln in meaningful):
        return INSTANCE
    if meaningful and all(_ROBOT_LINE.match(ln) for ln in meaningful[:20]):
        return ROBOTS
    raise FormatError(
        "cannot tell what this file is; expected a .map grid, a mapf-IR instance or solution, "
        "a MovingAI .scen, a legacy FleetControl XML file or robot definitions",
        path=str(path), line=1,
    )
