"""The manager's end of a robot's pose feedback stream, and CURVE for its client sockets.

A robot publishes `PoseFeedback` on the port its Welcome names; the manager
subscribes to everything (SUB, empty prefix) and keeps only a short queue,
since only the latest poses matter. `read_pose` is the one reader of a feedback
frame (the manager's links and `deploy`'s net check use it): a frame that does
not decode, or names another robot, is refused with the reason. The manager
logs it (once a minute per robot, then a count) and drops it: feedback is
advisory, never fatal.
"""
from __future__ import annotations

import logging
from typing import List, Optional

import zmq

from ..limits import MAX_FRAME_BYTES, excerpt
from ..ratelimit import RateLimitedLog
from ..wire import PoseFeedback, RemoteProtocolError
from ..wire.errors import MalformedFrameError
from ..wire.codec import decode
from .curve_keys import ManagerKeys

__all__ = ["secure_client", "subscribe_feedback", "read_pose", "NotThisRobotsPose", "poses_in"]


def secure_client(sock: zmq.Socket, keys: Optional[ManagerKeys]) -> None:
    """Make `sock` a CURVE client with the manager's key pair (no-op without keys), and
    one that refuses frames beyond the limit (libzmq drops the peer that sends one)."""
    sock.setsockopt(zmq.MAXMSGSIZE, MAX_FRAME_BYTES)
    if keys is not None:
        sock.curve_secretkey = keys.secret
        sock.curve_publickey = keys.public
        sock.curve_serverkey = keys.robot_public


def subscribe_feedback(context: zmq.Context, host: str, port: int,
                       keys: Optional[ManagerKeys]) -> zmq.Socket:
    sock = context.socket(zmq.SUB)
    sock.linger = 0
    secure_client(sock, keys)
    sock.setsockopt(zmq.SUBSCRIBE, b"")
    sock.setsockopt(zmq.RCVHWM, 20)  # only recent poses matter
    sock.connect("tcp://{}:{}".format(host, port))
    return sock


class NotThisRobotsPose(MalformedFrameError):
    """A feedback frame that decodes, but to another message or to another robot's pose;
    `sender` is that other robot's id (None: not a pose at all)."""

    def __init__(self, message: str, sender: Optional[int]) -> None:
        super().__init__(message)
        self.sender = sender


def read_pose(data: bytes, robot_id: int) -> PoseFeedback:
    """The pose in one frame from robot `robot_id`'s feedback port; RemoteProtocolError
    saying why not (NotThisRobotsPose when it decodes to something else)."""
    message = decode(data)
    if not isinstance(message, PoseFeedback) or message.robot_id != robot_id:
        sender = message.robot_id if isinstance(message, PoseFeedback) else None
        raise NotThisRobotsPose("feedback port sent {}".format(excerpt(message, 120)), sender)
    return message


def poses_in(data: bytes, robot_id: int, refusals: RateLimitedLog) -> List[PoseFeedback]:
    """The pose in one feedback frame of robot `robot_id` ([] if the frame is not one,
    whatever it holds)."""
    where = "robot {}'s feedback port".format(robot_id)
    try:
        return [read_pose(data, robot_id)]
    except NotThisRobotsPose as err:
        refusals.event(logging.WARNING, where, "bad feedback frames", "robot %s: %s", robot_id, err)
    except RemoteProtocolError as err:
        refusals.event(logging.WARNING, where, "bad feedback frames",
                       "robot %s: bad pose feedback frame: %s", robot_id, err)
    except Exception:  # decode is total; this is a bug of ours, not the robot's
        refusals.event(logging.ERROR, where, "failures", "robot %s: pose feedback frame %s "
                       "failed to decode", robot_id, excerpt(data), exc_info=True)
    return []
