"""What a robot link reports to the manager: link up and down, the robot's replies.

Pose feedback arrives as fleet_common.wire's `PoseFeedback` itself.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Union

from ..wire import PoseFeedback, Reply

__all__ = ["LinkUp", "LinkDown", "RobotReply", "LinkEvent"]


@dataclass(frozen=True)
class LinkUp:
    robot_id: int
    session: str
    restarted: bool  # a different robot process than last time


@dataclass(frozen=True)
class LinkDown:
    robot_id: int
    reason: str
    fatal: bool = False  # the link gave up (version or robot id mismatch)


@dataclass(frozen=True)
class RobotReply:
    robot_id: int
    reply: Reply  # Accepted, Completed, Failed or Status


LinkEvent = Union[LinkUp, LinkDown, RobotReply, PoseFeedback]
