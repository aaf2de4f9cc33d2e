"""Angles in the base frame: radians, counter-clockwise from +x."""
from __future__ import annotations

import math
from typing import Sequence

__all__ = ["wrap_angle", "heading"]


def wrap_angle(angle: float) -> float:
    """`angle` in [-pi, pi]."""
    return math.atan2(math.sin(angle), math.cos(angle))


def heading(src: Sequence[float], dst: Sequence[float]) -> float:
    """The heading from point `src` to point `dst`."""
    return math.atan2(dst[1] - src[1], dst[0] - src[0])
