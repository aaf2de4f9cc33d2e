"""LiveModel: everything the live console knows, built from the items of the feed.

Pure: `apply(item, at, wall)` takes one item (a manager message or one of the
link's own, see `console.live.feed`) with its arrival time, and records what
changed in `changes` (a set of "scene", "state", "events", "connection",
"proposal", "reply") for the views to pick up with `take_changes()`.
`LiveSource` drains the feed into a model once a frame and answers the
window's `poll(now)` with a `FleetState` when a new State arrived, so the
live console plugs into the player's frame loop like the plan clock does.

The event list holds the manager's notices, the console's own lines (the
manager's answers, refusals included, connection changes, bad frames) and
the run's story in words (`ticker`: "robot 2 stalled", "robot 3 waits for
robot 2"), each with the local time it arrived; the presentation view shows
the story's last lines (`story`).
"""
from __future__ import annotations

import math
import time
from collections import deque
from dataclasses import dataclass
from typing import Any, Callable, Deque, Dict, List, Optional, Set

import numpy as np

from fleet_common.control import Bye, Notice, Proposal, RobotState, RunSetup, State
from fleet_common.plan import Plan

from ..fleet_state import FleetState
from ..scene import Scene
from .feed import CONNECTED, CONNECTING, LOST, LinkStatus, LiveFeed, Reply, Trouble
from .scene import scene_from_manager
from .ticker import Ticker

__all__ = ["Line", "LiveModel", "LiveSource"]

INFO, WARN, ERROR = "info", "warn", "error"
#: The kind of the story's lines (the ticker's words) in the event list.
STORY = "story"
#: Kinds of the manager's notices shown as warnings (they need an operator's eye).
_WARN_KINDS = ("fault", "link", "vicon")


@dataclass(frozen=True)
class Line:
    """One entry of the event list."""

    clock: str            # local time it arrived, HH:MM:SS
    kind: str             # the manager's kind, or "console" for the console's own lines
    robot: Optional[int]
    text: str
    level: str = INFO     # info, warn, error


class LiveModel:
    def __init__(self, endpoint: str, events: int = 500) -> None:
        self.endpoint = endpoint
        self.connection = LinkStatus(CONNECTING, "connecting to the manager at {}".format(endpoint))
        self.setup: Optional[RunSetup] = None
        self.scene: Optional[Scene] = None
        self.agent_of: Dict[int, int] = {}  # robot id -> agent index in the plan
        self.state: Optional[State] = None
        self.state_at = 0.0                  # monotonic arrival time of `state`
        self.proposal: Optional[Proposal] = None
        self.proposal_plan: Optional[Plan] = None
        self.lines: Deque[Line] = deque(maxlen=events)
        self.story: Deque[Line] = deque(maxlen=8)
        self.told = 0  # sentences of the story so far
        self.ticker = Ticker()
        self.last_reply: Optional[Reply] = None
        self.changes: Set[str] = set()
        self._fleet: Optional[FleetState] = None  # fleet_state() of the current state and scene

    # ---- taking items in ------------------------------------------------------------------

    def apply(self, item: Any, at: float, wall: float) -> None:
        if isinstance(item, State):
            if self.state is None or item.seq > self.state.seq:
                self.state, self.state_at = item, at
                self.changes.add("state")
                for text in self.ticker.state(item, at):
                    self._told(wall, text)
                if self.proposal is not None and item.run.proposal is None:
                    self.proposal, self.proposal_plan = None, None  # answered (here or elsewhere)
                    self.changes.add("proposal")
        elif isinstance(item, RunSetup):
            self._scene(item)
        elif isinstance(item, Notice):
            level = WARN if item.kind in _WARN_KINDS else INFO
            self._line(wall, item.kind, item.robot, item.text, level)
            for text in self.ticker.notice(item):
                self._told(wall, text)
        elif isinstance(item, Reply):
            self.last_reply = item
            self.changes.add("reply")
            self._line(wall, "console", item.args.get("robot"), reply_text(item),
                       INFO if item.ok else ERROR)
        elif isinstance(item, Proposal):
            self.proposal = item
            self.proposal_plan = Plan(item.plan.positions)
            self.changes.add("proposal")
            if item.kind != "reroute":  # a reroute's proposal is told by the manager's own notice
                self._line(wall, "plan", None, "replan proposal {}: {} (soc {}, makespan {}); accept or "
                           "reject it".format(item.id, item.message, item.soc, item.makespan))
        elif isinstance(item, LinkStatus):
            if item.status == CONNECTED:
                self.state = None  # a manager counts its states from 1: maybe a restarted one
                self.ticker.reset()
                if self.last_reply is not None:  # an answer of another session: no longer true
                    self.last_reply = None
                    self.changes.add("reply")
            if item != self.connection:
                self.connection = item
                self.changes.add("connection")
                self._line(wall, "console", None, item.text, ERROR if item.status == LOST else INFO)
        elif isinstance(item, Trouble):
            self._line(wall, "console", None, item.text, ERROR)
        elif isinstance(item, Bye):
            self._line(wall, "console", None, "the manager said goodbye: {}".format(item.reason), WARN)

    def _scene(self, message: RunSetup) -> None:
        self.setup = message
        self.ticker.step_time = message.step_time
        self.scene = scene_from_manager(message, self.endpoint)
        self.agent_of = {rid: i for i, rid in enumerate(message.plan.robots)}
        self.proposal, self.proposal_plan = None, None
        self.changes.update(("scene", "proposal"))

    def say(self, text: str, level: str = INFO, robot: Optional[int] = None) -> None:
        """A line of the console's own (a file opened, a plan sent, a solve) in the event list."""
        self._line(time.time(), "console", robot, text, level)

    def _line(self, wall: float, kind: str, robot: Optional[int], text: str, level: str = INFO) -> None:
        self.lines.append(Line(time.strftime("%H:%M:%S", time.localtime(wall)), kind, robot, text, level))
        self.changes.add("events")

    def _told(self, wall: float, text: str) -> None:
        """A sentence of the run's story: the event list and the ticker."""
        robot = None
        words = text.split()
        if len(words) > 1 and words[0] == "robot" and words[1].isdigit():
            robot = int(words[1])
        line = Line(time.strftime("%H:%M:%S", time.localtime(wall)), STORY, robot, text, INFO)
        self.lines.append(line)
        self.story.append(line)
        self.told += 1
        self.changes.update(("events", "story"))

    def take_changes(self) -> Set[str]:
        changes, self.changes = self.changes, set()
        if changes & {"state", "scene", "connection"}:
            self._fleet = None
        return changes

    # ---- what the views read ----------------------------------------------------------------

    @property
    def connected(self) -> bool:
        return self.connection.status == CONNECTED

    def robot_ids(self) -> List[int]:
        return [] if self.setup is None else list(self.setup.plan.robots)

    def robot(self, robot_id: int) -> Optional[RobotState]:
        if self.state is None:
            return None
        for r in self.state.robots:
            if r.id == robot_id:
                return r
        return None

    def robots_by_agent(self) -> List[Optional[RobotState]]:
        """The newest State's robots in plan (agent) order; None where it says nothing."""
        out: List[Optional[RobotState]] = [None] * len(self.agent_of)
        if self.state is not None:
            for r in self.state.robots:
                agent = self.agent_of.get(r.id)
                if agent is not None:
                    out[agent] = r
        return out

    def fleet_state(self) -> FleetState:
        """Where the robots are, as the map layers take it: reported poses (plan starts where no
        pose came yet), headings in degrees, the plan's clock as the time."""
        if self._fleet is None or self.changes & {"state", "scene", "connection"}:
            self._fleet = self._fleet_state()
        return self._fleet

    def _fleet_state(self) -> FleetState:
        scene = self.scene
        n = 0 if scene is None else scene.num_agents
        positions = np.zeros((n, 2)) if scene is None else np.array(scene.starts, dtype=np.float64).reshape(n, 2)
        headings = np.full(n, np.nan)
        for agent, r in enumerate(self.robots_by_agent()):
            if r is not None and r.x is not None and r.y is not None:
                positions[agent] = (r.x, r.y)
                if r.theta is not None:
                    headings[agent] = math.degrees(r.theta) % 360.0
        run = None if self.state is None else self.state.run
        return FleetState(run.plan_time if run is not None and self._plan_is_current() else 0.0, positions,
                          headings, 0 if self.state is None else self.state.seq)

    def _plan_is_current(self) -> bool:
        """Whether the last State is of the plan drawn. A new plan (a reroute's, a replan's) comes
        just before the first State of it: until that State the plan's clock is its step 0, not the
        old plan's step (the rings of where it wants each robot would jump ahead for a moment)."""
        return self.state is None or self.setup is None or self.state.run.plan_id == self.setup.plan.id

    def plan_start(self) -> float:
        """The run's plan steps before the drawn plan's step 0 (the header adds the plan's own time
        to it): the State's `plan_start`, or, while a new plan's first State has not come, all the
        run's steps so far (the new plan starts now)."""
        if self.state is None:
            return 0.0
        run = self.state.run
        return run.plan_start if self._plan_is_current() else run.run_steps


def reply_text(reply: Reply) -> str:
    what = reply.action + "".join(" {}={}".format(k, v) for k, v in sorted(reply.args.items())
                                  if v is not None and k not in ("text",))
    if reply.ok:
        return "{}: done{}".format(what, ": " + reply.reason if reply.reason else "")
    if not reply.sent:
        return "{}: not sent: {}".format(what, reply.reason)
    return "{}: REFUSED: {}".format(what, reply.reason)


class LiveSource:
    """The live console's source for the frame loop: drains the feed into the model."""

    def __init__(self, feed: LiveFeed, model: LiveModel, batch: int = 500,
                 wall: Callable[[], float] = time.time) -> None:
        self.feed = feed
        self.model = model
        self.batch = batch
        self.wall = wall
        self.pending: Set[str] = set()  # changes not yet taken by the views

    def poll(self, now: float) -> Optional[FleetState]:
        """The new fleet state if a State arrived since the last poll (None otherwise); the
        model's other changes wait in `pending` for the window."""
        wall = self.wall()
        for item, at in self.feed.drain(self.batch):
            self.model.apply(item, at, wall)
        changes = self.model.take_changes()
        self.pending |= changes
        if "state" in changes or "scene" in changes:
            return self.model.fleet_state()
        return None

    def take(self) -> Set[str]:
        changes, self.pending = self.pending, set()
        return changes
