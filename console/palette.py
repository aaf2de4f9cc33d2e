"""Agent colours: the lab robots' own, or a set of distinct ones.

When the agents are the lab's robots, each is drawn in the colour
`robot_definitions.txt` gives it, so the operator sees the same red robot on
the screen and on the floor. Otherwise the first colours come from a short
hand-picked list of well-separated hues; beyond it, hues step by the golden
angle with three levels of saturation and brightness, so neighbouring agent
ids never look alike. Every colour is bright enough to stand out from the
dark obstacles and saturated enough to stand out from the pale free cells.
"""
from __future__ import annotations

import colorsys
from typing import List, Optional, Sequence

from fleet_common.robots import RobotDefinition, colour_to_rgb

_FIRST = (
    "#e6194b", "#3cb44b", "#4363d8", "#f58231", "#911eb4", "#42d4f4",
    "#f032e6", "#9a6324", "#469990", "#a9c934", "#ff6f91", "#2b4c9b",
)
_GOLDEN = 0.381966  # 1 - 1/phi of a turn: successive hues land far apart
_LEVELS = ((0.85, 0.90), (0.65, 0.70), (1.00, 0.55))  # (saturation, value)


def hex_colour(rgb: Sequence[int]) -> str:
    return "#{:02x}{:02x}{:02x}".format(int(rgb[0]), int(rgb[1]), int(rgb[2]))


def distinct_colours(n: int) -> List[str]:
    """`n` colours as '#rrggbb', the first ones the most different."""
    out = list(_FIRST[:n])
    for i in range(len(out), n):
        k = i - len(_FIRST)
        sat, val = _LEVELS[k % len(_LEVELS)]
        r, g, b = colorsys.hsv_to_rgb((k * _GOLDEN) % 1.0, sat, val)
        out.append(hex_colour((round(r * 255), round(g * 255), round(b * 255))))
    return out


def robot_colours(robots: Sequence[RobotDefinition]) -> List[str]:
    """Each robot's colour from its definition, as '#rrggbb'."""
    return [hex_colour(colour_to_rgb(r.colour)) for r in robots]


def agent_colours(n: int, robots: Optional[Sequence[RobotDefinition]] = None) -> List[str]:
    """Robot colours when `robots` is given and covers the `n` agents, else distinct ones."""
    if robots is not None and n <= len(robots):
        return robot_colours(robots[:n])
    return distinct_colours(n)
