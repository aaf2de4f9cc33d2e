"""Angles: the one way to bring a heading into (-pi, pi], and the heading of a move.

Headings are radians counter-clockwise from +x in every frame we use (base
grid, robot frame); a difference of two headings is wrapped before it is
compared, so that turning from 179 degrees to -179 degrees is 2 degrees, not 358.
"""
from __future__ import annotations

import math
from typing import Sequence

__all__ = ["wrap_angle", "heading"]


def wrap_angle(angle: float) -> float:
    """`angle` in (-pi, pi]."""
    wrapped = math.fmod(angle + math.pi, 2.0 * math.pi)
    if wrapped <= 0.0:
        wrapped += 2.0 * math.pi
    return wrapped - math.pi


def heading(src: Sequence[float], dst: Sequence[float]) -> float:
    """The heading from point `src` to point `dst`."""
    return math.atan2(dst[1] - src[1], dst[0] - src[0])
