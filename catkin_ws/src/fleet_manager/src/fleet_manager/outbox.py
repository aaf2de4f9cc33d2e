"""What the run core gives back: every effect as a value, in the order it happened.

The core (`core.py`) never sends, writes or prints; each input leaves effects
in its `Outbox`, and the manager's loop takes them (`take`) and carries them
out in order:

- `Send`: a wire command for one robot (its id already chosen);
- `Record`: a line for the run folder's events.jsonl (also fed, as it is
  made, to the run's `SummaryBuilder`, so the figures the manager prints and
  those the folder gives later are one computation);
- `ToConsole`: an encoded frame for one console (States, answers, notices);
- `Say`: a line for the manager's terminal;
- `PlanJob`: planning to run off the loop (its result comes back as an input);
- `RerouteJob`: a look for a reroute to run off the loop (`rerouting`; likewise);
- `LoadJob`: an instance a console asked to load, solved off the loop (`plan_requests`;
  its plan comes back as a PlanJob's does);
- `NewRunFolder`: close the run folder (if one is open) and open a new one
  with the plan in it (the run began, or a new plan was loaded); the records
  after it go there. Its first record, `run`, leaves `started` (the wall
  clock) and `definitions` (the file copied in) for the writer to fill in;
- `ResumeRunFolder`: go on writing the run folder of a run resumed after its
  manager died (its torn last line cut off); its next record is `resume`,
  whose `started` and `dropped` the writer fills in;
- `WriteFile`: a file for the run folder (a replan's plan-2.txt ...).
"""
from __future__ import annotations

from pathlib import Path
from typing import Any, Dict, List, NamedTuple, Optional, Sequence, Set, Union

from fleet_common.control import Notice
from fleet_common.control.desk import ControlDesk
from fleet_common.grid import Coord, Grid
from fleet_common.runlog.summary import SummaryBuilder
from fleet_common.wire import Command

from .plan_requests import Requested
from .rerouting import RerouteJob

__all__ = ["Outbox", "Send", "Record", "ToConsole", "Say", "PlanJob", "LoadJob", "RerouteJob", "NewRunFolder",
           "ResumeRunFolder", "WriteFile", "Effect"]

#: Console notice kinds also printed on the manager's terminal.
SAID = ("fault", "link", "run", "plan", "strategy", "operator", "vicon", "reroute")
#: The notice kind of rerouting: the mode switched, a reroute made, proposed or dropped.
REROUTE = "reroute"
#: Notice kinds that change what a decision about the robot rests on (the desk's version).
BUMPED = ("link", "fault", "run", "plan")


class Send(NamedTuple):
    robot: int          # robot id
    command: Command


class Record(NamedTuple):
    kind: str
    t: float
    fields: Dict[str, Any]


class ToConsole(NamedTuple):
    peer: bytes
    data: bytes


class Say(NamedTuple):
    text: str


class PlanJob(NamedTuple):
    """Replan `current` -> `goals` on `grid` around the agents `out` (see `replanning`)."""

    id: int
    grid: Grid
    current: List[Coord]
    goals: List[Coord]
    out: Set[int]
    time_limit: float
    method: str


class LoadJob(NamedTuple):
    """Solve `requested`, an instance a console asked to load (see `plan_requests`)."""

    id: int
    requested: Requested


class NewRunFolder(NamedTuple):
    plan_text: str      # written as plan-1.txt


class ResumeRunFolder(NamedTuple):
    folder: Path


class WriteFile(NamedTuple):
    name: str
    text: str


Effect = Union[Send, Record, ToConsole, Say, PlanJob, LoadJob, RerouteJob, NewRunFolder, ResumeRunFolder, WriteFile]


class Outbox:
    """Collects the core's effects; `now` is the time of the input being handled."""

    def __init__(self, desk: ControlDesk) -> None:
        self.desk = desk
        self.summary = SummaryBuilder()
        self.effects: List[Effect] = []
        self.now = 0.0
        self._notices = 0

    def take(self) -> List[Effect]:
        effects, self.effects = self.effects, []
        return effects

    def send(self, robot: int, command: Command) -> None:
        self.effects.append(Send(robot, command))

    def record(self, kind: str, **fields: Any) -> None:
        """A run log record, stamped with the time of the input being handled."""
        t = round(self.now, 4)
        self.summary.feed(dict(fields, k=kind, t=t))
        self.effects.append(Record(kind, t, fields))

    def tell(self, kind: str, robot: Optional[int], text: str) -> None:
        """A notice for the consoles' event lists (and the terminal, for the kinds in SAID)."""
        self._notices += 1
        self.broadcast(Notice(self._notices, round(self.now, 3), kind, robot, text))
        if kind in SAID:
            self.say("[{:7.1f} s] {}".format(self.now, text))
        if kind in BUMPED and robot is not None:
            self.desk.bump(text, robot)

    def say(self, text: str) -> None:
        self.effects.append(Say(text))

    def broadcast(self, message: Any) -> None:
        self.frames(self.desk.broadcast(message, self.now))

    def frames(self, frames: Sequence) -> None:
        self.effects.extend(ToConsole(peer, data) for peer, data in frames)

    def add(self, effect: Effect) -> None:
        self.effects.append(effect)

    @property
    def notices(self) -> int:
        """Notices told so far (the next one's seq is this plus one)."""
        return self._notices
