"""Everything the manager knows of one robot, in one place.

A `Robot` is the manager's record of one robot of the fleet: its link, what
it last reported (its own pose, Vicon's, its faults), what the manager holds
it for, and the command it is carrying out. It is named by its id from
robot_definitions.txt (`id`); `agent` is its index in the plan (plan agent i
runs on the i-th robot of the fleet). Whether the engine counts it out
(disabled or failed) is the engine's to say (`engine.run.out[agent]`): the
engine decides with it, so it lives there and nowhere else.

Poses are only ever what a source reported, with when it arrived: the pose a
command should leave the robot in is `facing` (its heading after its last
completed turn or drive), kept apart so that nothing reported is made up.
`Fleet` holds the robots in plan order and chooses, per robot, which pose
source the run uses (thesis 5.4): the robot's own localization or Vicon.
"""
from __future__ import annotations

from collections import deque
from dataclasses import dataclass, field
from typing import Deque, Dict, Iterator, List, Optional, Sequence, Set, Tuple

from fleet_common.execution import Dispatch
from fleet_common.robots import RobotDefinition
from fleet_common.wire import Pose

from .settings import STALE_AFTER

__all__ = ["Robot", "Fleet", "Seen", "InFlight", "ROBOT", "VICON", "HOLDS"]

#: Pose sources.
ROBOT = "robot"
VICON = "vicon"

#: Why the manager holds a robot (sends it nothing new): it asked where a restarted robot is;
#: it reported a fault; an operator halted it; a resumed run has not checked it yet.
RECOVER, FAULT, HALTED, RESUMING = "recover", "fault", "halted", "resuming"
HOLDS = (RECOVER, FAULT, HALTED, RESUMING)

#: A Vicon pose that reached the manager this long after a robot's reply was taken after the
#: robot stopped: Tracker sends a frame a few milliseconds after the cameras take it, and UDP to
#: pose is about a millisecond (bench/README.md "Vicon"); 50 ms leaves room for a busy network.
VICON_LATENCY = 0.05


@dataclass(frozen=True)
class Seen:
    """A pose from one source, and when it arrived (the manager's clock, seconds)."""

    pose: Pose
    at: float


@dataclass
class InFlight:
    """The motion command a robot is carrying out (or was last sent)."""

    id: int
    kind: str                # "turn" | "drive" | "stop"
    index: Optional[int]     # plan action it serves (None: a stop)
    sent: float
    target: Tuple[float, ...]
    accepted: bool = False


@dataclass
class Robot:
    """One robot as the manager sees it (see the module docstring)."""

    id: int
    agent: int
    colour: str = ""
    vicon_name: str = ""
    # the link
    link: str = "connecting"          # connecting | up | down | failed
    link_reason: str = ""
    # what it reported
    own: Optional[Seen] = None        # its own pose feedback (or a status reply)
    own_current: Optional[int] = None  # the command it was running when it took that pose
    own_ended: Optional[int] = None   # the last motion that had ended when it took that pose
    says_ended: bool = False          # its poses name the last motion ended (robots since 2026-11-27)
    vicon: Optional[Seen] = None      # Vicon's view of it
    source: str = ROBOT               # the pose the run uses
    disagreeing: bool = False         # its own pose and Vicon's differ (is it lost?)
    vicon_lost: bool = False          # Vicon saw it before and does not now
    faults: Tuple[str, ...] = ()
    # what the manager does with it
    hold: Optional[str] = None        # None or one of HOLDS
    hold_reason: str = ""
    queue: Deque[Dispatch] = field(default_factory=deque)  # dispatched, not yet driven
    flight: Optional[InFlight] = None
    status_id: Optional[int] = None   # a GetStatus awaiting its answer
    clear_fault: bool = False         # a stop is on its way to clear the fault (enable)
    moving_since: Optional[float] = None  # when the drive it is making was sent
    facing: Optional[float] = None    # heading its last completed turn or drive left it at
    next_id: int = 1                  # its next command id (they increase per manager epoch)
    releases: Set[int] = field(default_factory=set)  # ids of releases not yet settled
    ended_at: Optional[float] = None  # when the reply that ended its last command arrived
    answered: Optional[int] = None    # the last motion it accepted

    @property
    def link_up(self) -> bool:
        return self.link == "up"

    def take_id(self) -> int:
        cid = self.next_id
        self.next_id += 1
        return cid

    def seen(self, source: Optional[str] = None) -> Optional[Seen]:
        """The last pose from `source` (default: the chosen one)."""
        return self.vicon if (source or self.source) == VICON else self.own

    @property
    def pose(self) -> Optional[Pose]:
        """Where the chosen source last saw it."""
        seen = self.seen()
        return None if seen is None else seen.pose

    def pose_settled(self) -> bool:
        """Whether the pose the run uses was taken since the robot's last command ended, as far as
        its replies tell: its own pose names the command it was running when taken, and one taken
        during a command that has ended since (it came after the reply: late, or queued while no
        manager listened) shows where the robot was, not where it is; one taken while idle names
        the last motion that had ended, and one taken before the motion it last answered began
        shows it where it was before (wide session 1994: a half-cell move made in 0.25 s, a pose
        from before it delivered 0.3 s late, and the robot was judged moved by hand). Vicon's name none: one
        counts if it arrived `VICON_LATENCY` after that reply. The last pose of a robot Vicon
        has lost (occluded) may be from moves ago, and the run must not plan from it."""
        if self.source == VICON:
            seen = self.vicon
            return seen is None or self.ended_at is None or seen.at >= self.ended_at + VICON_LATENCY
        return self.own_settled()

    def own_settled(self) -> bool:
        """`pose_settled` for its own pose, whatever the run uses."""
        if self.own is None:
            return True
        if self.own_current is not None:
            return self.flight is not None and self.own_current == self.flight.id
        # idle when taken: after the last motion it accepted, or before that motion began (a pose
        # delivered late shows it a move back); a robot too old to say is taken at its word. (A
        # refused motion never began: session 1541, drive 4 refused while drive 3 ran, which then
        # ended; counting the refusal, no pose ever counted again and a replan waited for ever.)
        return not self.says_ended or self.answered is None or self.own_ended == self.answered

    def age(self, now: float, source: Optional[str] = None) -> Optional[float]:
        seen = self.seen(source)
        return None if seen is None else max(0.0, now - seen.at)

    def heading(self) -> Optional[float]:
        """Where it faces: its last completed command's heading, else its own pose's."""
        if self.facing is not None:
            return self.facing
        return None if self.own is None else self.own.pose.theta


class Fleet:
    """The robots of a run, in plan order (agent i is `fleet[i]`), and their pose sources."""

    def __init__(self, definitions: Sequence[RobotDefinition], stale_after: float = STALE_AFTER) -> None:
        self.robots: List[Robot] = [Robot(d.id, i, d.colour, d.vicon_name)
                                    for i, d in enumerate(definitions)]
        self.by_id: Dict[int, Robot] = {r.id: r for r in self.robots}
        self.stale_after = stale_after
        self.vicon_enabled = False

    def __iter__(self) -> Iterator[Robot]:
        return iter(self.robots)

    def __len__(self) -> int:
        return len(self.robots)

    def __getitem__(self, agent: int) -> Robot:
        return self.robots[agent]

    @property
    def ids(self) -> List[int]:
        return [r.id for r in self.robots]

    def stale(self, robot: Robot, now: float) -> bool:
        age = robot.age(now)
        return age is None or age > self.stale_after

    def choose(self, source: str, robot_id: Optional[int] = None) -> List[int]:
        """Use `source` for one robot (None: every robot); the ids whose source changed."""
        chosen = self.robots if robot_id is None else [self.by_id[robot_id]]
        changed = [r.id for r in chosen if r.source != source]
        for r in chosen:
            r.source = source
        return changed

    def shown(self, robot: Robot) -> Tuple[Optional[Seen], str]:
        """The pose to show: the chosen source's, else the other's if only it saw the robot."""
        other = VICON if robot.source == ROBOT else ROBOT
        for source in (robot.source, other):
            seen = robot.seen(source)
            if seen is not None:
                return seen, source
        return None, robot.source
