"""What a robot link reports to the manager: link up and down, the robot's replies.

Values only (the link itself, with its sockets, is `fleet_common.transport.robot_link`), so
that the manager's core reads them without pyzmq. Pose feedback arrives as `PoseFeedback`
itself.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Union

from .messages import PoseFeedback, Reply

__all__ = ["LinkUp", "LinkDown", "RobotReply", "LinkEvent", "OUTCOME_UNKNOWN"]

#: The end of the reason of a command failed by the link because its robot restarted under it.
OUTCOME_UNKNOWN = "its outcome is unknown"


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
