"""The manager <-> console messages: what a console sees and what it may ask.

    console                                   manager
    Hello(name)                         ->
                                        <-    Welcome(session, version)
                                        <-    RunSetup(map, robots, plan)   (and on every plan change)
                                        <-    State(...)                    10+ times a second
                                        <-    Notice(...)                   faults, links, operators, ...
    Request(id, action, args, based_on) ->
                                        <-    Answer(id, ok, reason, version)
                                        <-    Proposal(...)                 a replan to accept or reject
    Heartbeat()                        <->    Heartbeat()                   (after 1 s of silence)
    Bye(reason)                        <->    Bye(reason)

Versions (thesis 5.1.1): the manager keeps a Lamport clock, `version`, that
moves on every change an operator's decision may rest on (run state,
strategy, plan, a robot enabled, disabled, failed or losing its link, a
position source). Every State and Answer carries it; a Request carries the
version its sender last saw (`based_on`), and the manager refuses a request
based on an older version when something it acts on changed since (the run,
or the robot it names; see `desk.py`), saying what changed, so nobody acts on
a picture that is no longer true. Telemetry (poses, progress, waits) does not
move it: it changes ten times a second and no decision depends on it.

Coordinates are base-grid cells (origin bottom-left, y up), angles radians.
Robots are named by their robot_definitions.txt id.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, ClassVar, Dict, Optional, Tuple

import numpy as np

from ..limits import MAX_MESSAGE_CHARS

PROTOCOL_VERSION = 1

#: Where a manager listens by default, and where a console looks for it.
DEFAULT_ENDPOINT = "tcp://127.0.0.1:7100"

#: How a refusal to a console the manager does not know begins: the console says hello again.
HELLO_FIRST = "say hello first"

RUN_STATES = ("waiting", "running", "paused", "stopped", "done", "failed")
PURPOSES = ("plan", "to-starts")
ORIENTATIONS = ("mapf-ir", "base")
LINK_STATES = ("connecting", "up", "down", "failed")
SOURCES = ("robot", "vicon")
#: Longest reason a State gives for a run action the manager would refuse (`RunInfo.why_not`):
#: one line as the command line prints it, cut in the middle (`limits.one_line`) so that what
#: to do, said last, stays (300 robots not connected make a long list).
WHY_NOT_CHARS = MAX_MESSAGE_CHARS


# ---- console -> manager ---------------------------------------------------------------

@dataclass(frozen=True)
class Hello:
    TYPE: ClassVar[str] = "hello"
    name: str


@dataclass(frozen=True)
class Request:
    """Do `action` with `args`; `based_on` is the newest version the console has seen."""

    TYPE: ClassVar[str] = "request"
    id: int
    action: str
    args: Dict[str, Any]
    based_on: int


@dataclass(frozen=True)
class Heartbeat:
    TYPE: ClassVar[str] = "heartbeat"


@dataclass(frozen=True)
class Bye:
    TYPE: ClassVar[str] = "bye"
    reason: str


# ---- manager -> console ---------------------------------------------------------------

@dataclass(frozen=True)
class Welcome:
    TYPE: ClassVar[str] = "welcome"
    session: str
    version: int


@dataclass(frozen=True)
class RobotInfo:
    """What does not change during a run: a robot's id, colour and its agent in the plan."""

    id: int
    colour: str
    vicon_name: str


@dataclass(frozen=True, eq=False)
class PlanData:
    """A plan as the console draws it: `positions[t, i]` is agent i's cell [x, y] at step t
    (an int32 array of shape (steps, agents, 2), the layout of `fleet_common.plan.Plan`)."""

    id: int
    robots: Tuple[int, ...]  # robot id of each agent
    positions: "np.ndarray"
    name: str = ""

    def __eq__(self, other: object) -> bool:
        return (isinstance(other, PlanData) and (self.id, self.robots, self.name) == (
            other.id, other.robots, other.name) and np.array_equal(self.positions, other.positions))

    __hash__ = None  # type: ignore[assignment]


@dataclass(frozen=True)
class RunSetup:
    """The run's setup: the map, the fleet and the plan; sent after Welcome and whenever the plan
    changes. (The console draws it as its `console.scene.Scene`; the tag stays "scene".)"""

    TYPE: ClassVar[str] = "scene"
    map_name: str
    rows: Tuple[str, ...]  # top row first, '.' free, '@' blocked (like a .map file)
    robots: Tuple[RobotInfo, ...]
    plan: PlanData
    strategies: Tuple[str, ...]
    step_time: float  # seconds a plan step is expected to take, for the planned-position ghost
    #: the robots' diameter, safety margin and the cell, metres (a manager of old: as large as a cell)
    robot_size: Tuple[float, float, float] = (0.7, 0.0, 0.7)
    #: how the plan's file counts rows: "mapf-ir" (from the top) or "base" (from the bottom); a
    #: console shows cells and positions as the file writes them (a manager of old: "base")
    orientation: str = "base"


@dataclass(frozen=True)
class Waiting:
    """The robot is ready to move but waits: for robots `on`, to enter `cell`, because `reason`
    ("cell": the cell is not free yet; "follow": it follows a robot into a cell and stands at
    the safe distance behind it; "barrier": the time step; "paused"; "link": its own link is
    down; "fault")."""

    on: Tuple[int, ...]
    cell: Optional[Tuple[int, int]]
    reason: str


@dataclass(frozen=True)
class Activity:
    """The command a robot is carrying out: a turn or a drive of plan action `index`."""

    kind: str  # "turn" | "drive" | "stop"
    index: Optional[int]
    x: Optional[float] = None
    y: Optional[float] = None
    angle: Optional[float] = None


@dataclass(frozen=True)
class RobotState:
    id: int
    link: str
    link_reason: str
    x: Optional[float]
    y: Optional[float]
    theta: Optional[float]
    source: str           # where the pose comes from: "robot" or "vicon"
    age: Optional[float]  # seconds since that source last saw it (None: never)
    stale: bool
    faults: Tuple[str, ...]
    out: Optional[str]    # None, "disabled" or "failed"
    activity: Optional[Activity]
    done: int             # plan actions completed
    total: int            # plan actions in all
    step: int             # plan step of its next action (the plan's makespan once done)
    waiting: Optional[Waiting]
    behind: float         # plan steps behind the plan's clock (0 if on time or ahead)
    vicon_age: Optional[float] = None  # None: Vicon does not see it (or there is no Vicon)
    disagree: bool = False  # its own pose and Vicon's differ by more than the threshold
    follows: Optional[int] = None  # the robot it follows into a cell, at the safe distance


@dataclass(frozen=True)
class RunInfo:
    state: str
    reason: str
    strategy: str
    lookahead: int
    clock: float          # seconds since the run started (0 before); it stops when the run is done
    plan_time: float      # steps since the current plan's step 0 (a replan's too), at most its makespan
    plan_id: int
    arrived: int
    robots: int
    min_distance: Optional[float]  # the smallest distance between two robots so far, cells
    collisions: int
    proposal: Optional[int]        # id of the replan proposal awaiting an answer
    replanning: bool = False       # a replan is being computed (or waits for a safe point)
    #: what the run is for: "plan" (the plan loaded) or "to-starts" (the robots driving to the
    #: plan's starts, a run of its own before it)
    purpose: str = "plan"
    #: the run actions (requests.RUN_ACTIONS) the manager would carry out now; None: a manager
    #: of old that does not say
    allowed: Optional[Tuple[str, ...]] = None
    #: rerouting robots a late robot holds up: "off", "propose" (a proposal for the operator) or
    #: "auto" (at once)
    reroute: str = "off"
    #: the run's plan steps before the current plan's step 0: what its earlier plans took (a
    #: reroute's plan starts at its cut, an accepted replan's at the accept); 0 for the run's first
    #: plan. Sent only when not 0: a console older than it refuses a field it does not know.
    plan_start: float = 0.0
    #: whom a reroute may give new paths: "held" (the robots a late one holds up) or "all" (every
    #: robot, replanned from the cut). Sent only when "all": a console older than it refuses it.
    reroute_scope: str = "held"
    #: plans are trimmed of moves that do not bring a robot in sooner (`planning.trim`): the held
    #: scope's reroutes' plans before their hand-over (scope all's always are), plans loaded.
    #: Sent only when true: a console older than it refuses it.
    trim: bool = False
    #: why the manager would refuse each run action it does not allow now, by action: one line
    #: each, of at most WHY_NOT_CHARS; None: a manager of old that does not say (left out of the
    #: frame). A manager that has it always sends it, and a console older than it refuses a field
    #: it does not know: such consoles are updated with the manager.
    why_not: Optional[Dict[str, str]] = None

    @property
    def run_steps(self) -> float:
        """The run's plan clock, in plan steps: it goes on across a change of plan (`plan_time`
        starts again at the new plan's step 0) and stops at the current plan's makespan."""
        return self.plan_start + self.plan_time


@dataclass(frozen=True)
class State:
    TYPE: ClassVar[str] = "state"
    seq: int
    version: int
    run: RunInfo
    robots: Tuple[RobotState, ...]


@dataclass(frozen=True)
class Answer:
    """The answer to Request `id`: done (`ok`) or refused with a `reason` a person can read."""

    TYPE: ClassVar[str] = "answer"
    id: int
    ok: bool
    reason: str
    version: int


@dataclass(frozen=True)
class Notice:
    """Something an operator should see: a line of the console's event list (seq counts from 1
    per manager). Not an engine event, not a run-log record; the tag stays "event"."""

    TYPE: ClassVar[str] = "event"
    seq: int
    time: float
    kind: str             # "fault", "link", "operator", "strategy", "run", "plan", "vicon", "pass", ...
    robot: Optional[int]
    text: str


#: What may propose a new plan (`Proposal.kind`).
PROPOSAL_KINDS = ("replan", "reroute")


@dataclass(frozen=True)
class Proposal:
    """A new plan waiting for an operator (a replan, or a reroute): accept or reject it by `id`."""

    TYPE: ClassVar[str] = "proposal"
    id: int
    plan: PlanData
    message: str
    soc: int
    makespan: int
    unreachable: Tuple[int, ...] = field(default=())
    #: what proposes it: "replan" (the operator's replan) or "reroute" (robots a late one holds
    #: up, `--reroute propose`; the run goes on meanwhile)
    kind: str = "replan"


CONSOLE_MESSAGES = (Hello, Request, Heartbeat, Bye)
MANAGER_MESSAGES = (Welcome, RunSetup, State, Answer, Notice, Proposal, Heartbeat, Bye)
