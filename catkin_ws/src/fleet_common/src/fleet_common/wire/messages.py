"""The manager <-> robot messages: typed, versioned records.

Every message is a frozen dataclass; `TYPE` is its tag on the wire. Coordinates
are in the base grid (cells, origin bottom-left, y up; see fleet_common.grid),
angles in radians counter-clockwise from +x. Commands carry an `id` chosen by
the manager: ids strictly increase within one manager `epoch` (the random
string the manager sends in `Hello` and keeps across reconnects), so the robot
recognises a command sent again and never executes it twice.

Replies: a drive, turn or stop is answered by `Accepted` then `Completed` or
`Failed`, or refused at once by `Failed`; `GetStatus` is answered by `Status`.
`Hello`, `Welcome` and `Bye` keep their fields in every protocol version, so
that a peer of another version still gets a clear refusal.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar, Dict, Optional, Tuple, Type, Union

#: The version this code speaks; bump it on any incompatible change (2: hold points, `Release`:
#: a robot that ignored them could drive into the robot it follows).
PROTOCOL_VERSION = 2


@dataclass(frozen=True)
class Pose:
    """Where a robot is: base-grid cells (fractions between markers) and heading."""

    x: float
    y: float
    theta: float


# ---- handshake and connection --------------------------------------------------------

@dataclass(frozen=True)
class Hello:
    """Manager -> robot, first message: who it expects and its epoch for command ids."""

    TYPE: ClassVar[str] = "hello"
    robot_id: int
    epoch: str
    version: int = PROTOCOL_VERSION


@dataclass(frozen=True)
class Welcome:
    """Robot -> manager: the handshake succeeded. `session` changes when the robot restarts."""

    TYPE: ClassVar[str] = "welcome"
    robot_id: int
    session: str
    feedback_port: int
    version: int = PROTOCOL_VERSION


@dataclass(frozen=True)
class Bye:
    """Either side, any time: the connection ends. `code` says why in one word
    (version, robot-id, no-session, superseded, shutdown, timeout, protocol)."""

    TYPE: ClassVar[str] = "bye"
    reason: str
    code: str = "shutdown"


@dataclass(frozen=True)
class Heartbeat:
    """Either side, when it has sent nothing for a while: "I am still here"."""

    TYPE: ClassVar[str] = "heartbeat"


# ---- commands (manager -> robot) -----------------------------------------------------

@dataclass(frozen=True)
class DriveToPosition:
    """driveToPosition(x, y, time): turn to face (x, y), then drive there, arriving
    `time` seconds after the robot received the command (0: as fast as allowed).

    `hold`: a point on the way the robot must not drive past (it stops there, short of
    the robot it follows) until a `Release` lets it on; None: no hold point."""

    TYPE: ClassVar[str] = "drive"
    id: int
    x: float
    y: float
    time: float
    hold: Optional[Tuple[float, float]] = None


@dataclass(frozen=True)
class Turn:
    """turn(angle): turn in place to the absolute heading `angle` (radians, base frame)."""

    TYPE: ClassVar[str] = "turn"
    id: int
    angle: float


@dataclass(frozen=True)
class Stop:
    """Stop now; the running command, if any, fails with "stopped"."""

    TYPE: ClassVar[str] = "stop"
    id: int


@dataclass(frozen=True)
class Release:
    """The drive `drive` may go on as far as (x, y) (its target: no hold point left). A
    hold point only ever moves on along the drive; for a drive that is not running it
    does nothing. Accepted and completed at once."""

    TYPE: ClassVar[str] = "release"
    id: int
    drive: int
    x: float
    y: float


@dataclass(frozen=True)
class GetStatus:
    """Ask for a `Status` reply."""

    TYPE: ClassVar[str] = "get_status"
    id: int


# ---- replies (robot -> manager) ------------------------------------------------------

@dataclass(frozen=True)
class Accepted:
    """The command `id` runs (or ran: `duplicate` when the id was seen before)."""

    TYPE: ClassVar[str] = "accepted"
    id: int
    duplicate: bool = False


@dataclass(frozen=True)
class Completed:
    """The command `id` finished as asked."""

    TYPE: ClassVar[str] = "completed"
    id: int


@dataclass(frozen=True)
class Failed:
    """The command `id` was refused or did not finish; `reason` is for people."""

    TYPE: ClassVar[str] = "failed"
    id: int
    reason: str


@dataclass(frozen=True)
class Status:
    """Answer to GetStatus `id`: pose, the running command's id (None: idle), faults."""

    TYPE: ClassVar[str] = "status"
    id: int
    pose: Pose
    current: Optional[int]
    faults: Tuple[str, ...] = ()


# ---- pose feedback stream (robot PUB -> manager SUB, outside the connection) ---------

@dataclass(frozen=True)
class PoseFeedback:
    """Published 10 times a second or more; `seq` counts up from 0 per robot process.
    `current`: the motion running when the pose was taken (None: idle); `ended`: the last
    motion (drive or turn) it accepted that had ended by then, completed, failed or stopped
    (None: none since the robot started, or a robot too old to say). With `ended` a manager
    tells an idle robot's pose taken before its last motion began (and delivered late) from
    one taken after it ended: both name no motion running."""

    TYPE: ClassVar[str] = "pose"
    robot_id: int
    seq: int
    pose: Pose
    current: Optional[int]
    faults: Tuple[str, ...] = ()
    ended: Optional[int] = None


Command = Union[DriveToPosition, Turn, Stop, Release, GetStatus]
Reply = Union[Accepted, Completed, Failed, Status]
Message = Union[Hello, Welcome, Bye, Heartbeat, DriveToPosition, Turn, Stop, Release, GetStatus,
                Accepted, Completed, Failed, Status, PoseFeedback]

MESSAGE_TYPES: Dict[str, Type] = {
    cls.TYPE: cls
    for cls in (Hello, Welcome, Bye, Heartbeat, DriveToPosition, Turn, Stop, Release, GetStatus,
                Accepted, Completed, Failed, Status, PoseFeedback)
}
COMMAND_TYPES = ("drive", "turn", "stop", "release", "get_status")
#: Messages whose layout never changes, so a peer of another version can read them.
VERSIONLESS_TYPES = ("hello", "welcome", "bye")

__all__ = [
    "PROTOCOL_VERSION", "Pose", "Hello", "Welcome", "Bye", "Heartbeat", "DriveToPosition",
    "Turn", "Stop", "Release", "GetStatus", "Accepted", "Completed", "Failed", "Status", "PoseFeedback",
    "Command", "Reply", "Message", "MESSAGE_TYPES", "COMMAND_TYPES", "VERSIONLESS_TYPES",
]
