"""Planned stalls: robot R halts for S seconds halfway through its K-th drive.

Written `R:K:S` on the command line (`fleetctl virtual-fleet --stall 2:7:8`).
Unlike the delay model's random stalls, a planned stall is deterministic: a
demo or a test makes one chosen robot late at one chosen moment and shows the
robots that depend on it waiting. Drives are counted from 1 per robot
(`drive_to_position` commands; turns do not count), and seconds are the
fleet's own, like the delay model's.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Dict, Iterable

from fleet_common.errors import FleetError

__all__ = ["Stall", "parse_stall", "stalls_by_robot"]

_FORM = "ROBOT:MOVE:SECONDS, e.g. 2:7:8 (robot 2 halts 8 s halfway through its 7th drive)"


@dataclass(frozen=True)
class Stall:
    robot: int
    move: int       # the robot's K-th drive, from 1
    seconds: float  # fleet seconds

    def describe(self) -> str:
        return "robot {} stalls {:g} s in its drive {}".format(self.robot, self.seconds, self.move)


def parse_stall(text: str) -> Stall:
    """The stall `text` describes; FleetError saying what was expected otherwise."""
    parts = text.strip().split(":")
    try:
        robot, move, seconds = int(parts[0]), int(parts[1]), float(parts[2])
    except (ValueError, IndexError):
        raise FleetError("stall {!r}: expected {}".format(text, _FORM)) from None
    if len(parts) != 3 or robot < 0 or move < 1 or not 0 < seconds < 1e6:
        raise FleetError("stall {!r}: expected {}, with MOVE >= 1 and SECONDS > 0".format(text, _FORM))
    return Stall(robot, move, seconds)


def stalls_by_robot(stalls: Iterable[Stall]) -> Dict[int, Dict[int, float]]:
    """robot id -> {drive number: seconds}."""
    out: Dict[int, Dict[int, float]] = {}
    for s in stalls:
        out.setdefault(s.robot, {})[s.move] = s.seconds
    return out
