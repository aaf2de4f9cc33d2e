"""Angles: the one way to bring a heading into (-pi, pi].

Headings are radians counter-clockwise from +x in every frame we use (base
grid, robot frame); a difference of two headings is wrapped before it is
compared, so that turning from 179 degrees to -179 degrees is 2 degrees, not 358.
"""
from __future__ import annotations

import math

__all__ = ["wrap_angle"]


def wrap_angle(angle: float) -> float:
    """`angle` in (-pi, pi]."""
    wrapped = math.fmod(angle + math.pi, 2.0 * math.pi)
    if wrapped <= 0.0:
        wrapped += 2.0 * math.pi
    return wrapped - math.pi
