"""What the robot-side executor drives: `PollingNavigator`, non-blocking, in base-grid cells.

The thesis's navigation API is two blocking calls, `driveToPosition(x, y,
time)` and `turn(angle)` (3.6.1). The executor must stay responsive while a
robot moves (to answer status, heartbeats and a preempting stop), so it uses
them split in two: `start_*` begins a motion and returns at once, `poll()`
says whether it has ended. The robot (agv_package's `WireNavigator`, over its
`BlockingNavigator` in metres) and the virtual robot (virtual_fleet) implement
this; neither needs to know about messages. Both kinds of navigator report how a
motion ended with the one `MotionOutcome`.

All coordinates are base-grid cells and radians; a navigator that works in
its own frame (metres, the robot frame) converts inside itself.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Optional, Sequence, Tuple

try:  # typing.Protocol is 3.8+; only annotations use it
    from typing import Protocol
except ImportError:  # pragma: no cover
    Protocol = object  # type: ignore

from .messages import Pose

__all__ = ["PollingNavigator", "MotionOutcome", "MotionRefused"]


@dataclass(frozen=True)
class MotionOutcome:
    """How a motion ended: `ok`, or not with a `reason` for people ("bumper pressed")."""

    ok: bool
    reason: str = ""


class MotionRefused(Exception):
    """Raised by `start_drive`/`start_turn` when the motion cannot begin (target off the
    grid, a fault); the message is the reason the manager is told."""


class PollingNavigator(Protocol):
    """Starts a motion and returns at once; `poll` says when and how it ended."""

    def start_drive(self, x: float, y: float, time: float,
                    hold: Optional[Tuple[float, float]] = None) -> None:
        """Begin: turn to face (x, y), then drive there, arriving `time` s from now
        (0: at the configured speed), but not past the point `hold` on the way until
        `release` lets it on. Returns at once; MotionRefused if it cannot."""

    def release(self, x: float, y: float) -> None:
        """The drive under way may go as far as (x, y) now (its target: no hold left); a
        hold point never moves back. Nothing happens when no drive is under way."""

    def start_turn(self, angle: float) -> None:
        """Begin turning in place to heading `angle` (radians, base frame)."""

    def halt(self) -> None:
        """Stop moving now (zero velocity); the motion under way is abandoned."""

    def poll(self) -> Optional[MotionOutcome]:
        """None while a motion started by start_* is under way, then its outcome once
        (and None again after that, until the next start)."""

    def pose(self) -> Pose:
        """The current pose estimate."""

    def faults(self) -> Sequence[str]:
        """Faults now present ("bumper"); while any is, new motions are refused."""
