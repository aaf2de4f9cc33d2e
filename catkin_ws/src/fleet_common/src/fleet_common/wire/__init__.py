"""The manager <-> robot wire protocol, sans-I/O (thesis 3.6, 5.2, 6.4).

The robot binds its command port (from robot_definitions.txt) and the manager
connects: robots are servers, so the manager can run anywhere (thesis 6.4).
Over that connection go typed, versioned records (`messages`), one compact
JSON object per ZeroMQ frame (`codec`):

    manager                                 robot
    Hello(robot_id, epoch, version)   ->
                                      <-    Welcome(robot_id, session, feedback_port, version)
    DriveToPosition(id, x, y, time)   ->                        (base-grid cells, seconds)
                                      <-    Accepted(id)
                                      <-    Completed(id) | Failed(id, reason)
    Turn(id, angle) / Stop(id)        ->    (same replies)      (radians, absolute heading)
    GetStatus(id)                     ->
                                      <-    Status(id, pose, current, faults)
    Heartbeat()                      <->    Heartbeat()         (after 1 s of silence)
    Bye(reason, code)                <->    Bye(reason, code)   (ends the connection)

and, outside the connection, the robot publishes `PoseFeedback` 10 times a
second on its feedback port (9980, or one per robot when they share a host:
`ports`).

Every module here is pure (stdlib only, Python 3.8): `messages`, `codec`,
`states` (the transition tables), `connection` (`Connection`: bytes in,
messages out; an illegal message raises `LocalProtocolError` or
`RemoteProtocolError` and changes nothing), `executor` (`CommandExecutor`: a
command id seen before is acknowledged again, never executed twice; one
command at a time; stop preempts), `command_check` (what the robot's world
forbids: off the map, into obstacles, more than a step, too long), `navigator`
(the `PollingNavigator` interface it drives), `liveness` (heartbeat timing), `ports`.
Decoding is total (`fleet_common.limits`, and the message schemas of
`fleet_common.schema`, as in the console protocol): any bytes are a message or a
`MalformedFrameError`. The sockets, robot side and manager side, live in
`fleet_common.transport`.
"""
from __future__ import annotations

from .connection import Connection
from .errors import (LocalProtocolError, MalformedFrameError, ProtocolError, RemoteProtocolError,
                     VersionMismatchError)
from .executor import CommandExecutor
from .liveness import HEARTBEAT_INTERVAL, PEER_TIMEOUT, Liveness
from .messages import (COMMAND_TYPES, MESSAGE_TYPES, PROTOCOL_VERSION, Accepted, Bye, Command,
                       Completed, DriveToPosition, Failed, GetStatus, Heartbeat, Hello, Message,
                       Pose, PoseFeedback, Release, Reply, Status, Stop, Turn, Welcome)
from .navigator import MotionOutcome, MotionRefused, PollingNavigator
from .ports import FEEDBACK_PORT, feedback_ports, on_localhost
from .states import Phase, Role, State

__all__ = [
    "Connection", "LocalProtocolError", "MalformedFrameError", "ProtocolError", "RemoteProtocolError",
    "VersionMismatchError", "CommandExecutor", "HEARTBEAT_INTERVAL", "PEER_TIMEOUT", "Liveness",
    "COMMAND_TYPES", "MESSAGE_TYPES", "PROTOCOL_VERSION", "Accepted", "Bye", "Command",
    "Completed", "DriveToPosition", "Failed", "GetStatus", "Heartbeat", "Hello", "Message", "Pose",
    "PoseFeedback", "Release", "Reply", "Status", "Stop", "Turn", "Welcome", "MotionOutcome",
    "MotionRefused", "PollingNavigator", "FEEDBACK_PORT", "feedback_ports", "on_localhost", "Phase",
    "Role", "State",
]
