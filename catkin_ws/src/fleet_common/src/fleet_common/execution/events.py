"""What goes into the engine (events) and what comes out (decisions).

Every input is an event carrying `time`, a number the caller chooses (seconds
of a wall clock, simulated time, plan steps): the engine never reads a clock,
it only passes times on to the metrics. Robots report progress (`ActionStarted`,
`ActionCompleted`, `RobotFailed`); the operator or the manager controls the run
(`Resume`, `Pause`, `StepRound`, `SwitchStrategy`, `Disabled`, `Enabled`,
`Freeze`, `Thaw`), and time passes (`Tick`, for strategies that read the plan's
clock).
A run starts paused: the first `Resume` starts it.

`Engine.handle(event)` answers with `Dispatch` decisions: agent r may start
its action `index` now (move from `src` to `dst`, plan step `step`). The
caller sends each one to its robot exactly once. An action that `RobotFailed` or
`Disabled` took back (sent, not started) is dispatched again when the robot
is enabled: that is a new decision, to be sent again. `Wait` reports who is
waiting for whom and where, for the console's red highlight.

Names: the wire protocol's replies are `fleet_common.wire.Completed` and
`Failed` (one command on one robot); the engine's events say what they are
about (`ActionCompleted`: a plan action; `RobotFailed`: the robot is out), so
the manager, which translates one into the other, never confuses them.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple, Optional, Tuple

from ..grid import Coord
from .strategy import Strategy


@dataclass(frozen=True)
class ActionStarted:
    """Agent `agent` began its action `index` (optional: completion implies it)."""

    agent: int
    index: int
    time: float


@dataclass(frozen=True)
class ActionCompleted:
    """Agent `agent` finished its action `index`: it is wholly in the action's `dst`."""

    agent: int
    index: int
    time: float


@dataclass(frozen=True)
class RobotFailed:
    """The robot of agent `agent` stopped with a fault; it is out until `Enabled`, then retries."""

    agent: int
    time: float


@dataclass(frozen=True)
class Disabled:
    """The operator took agent `agent` out (a dead battery): it is sent nothing new."""

    agent: int
    time: float


@dataclass(frozen=True)
class Enabled:
    """Agent `agent` takes part again and continues where it stopped."""

    agent: int
    time: float


@dataclass(frozen=True)
class Resume:
    """Start the run, or continue it after `Pause` or `StepRound`."""

    time: float


@dataclass(frozen=True)
class Tick:
    """Time passes. A strategy that decides by the plan's clock (`Strategy.tick_every`, in plan
    steps) looks again at the robots waiting; the caller sends one that often while the run runs."""

    time: float


@dataclass(frozen=True)
class Pause:
    """Send no new actions (robots finish the ones they have)."""

    time: float


@dataclass(frozen=True)
class Freeze:
    """Send no new actions until `Thaw`, the run going on (its clock runs, robots finish what they
    were sent): a new plan is being made from this moment (a reroute's look in a worker thread),
    and a robot sent a new move meanwhile would leave the plan's start behind."""

    time: float


@dataclass(frozen=True)
class Thaw:
    """Send new actions again after `Freeze` (nothing if not frozen)."""

    time: float


@dataclass(frozen=True)
class StepRound:
    """Release one round (strategy's unit: one plan step, or one action per robot), then hold."""

    time: float


@dataclass(frozen=True)
class SwitchStrategy:
    """Continue the run under `strategy` (from `make_strategy`), keeping all progress."""

    strategy: Strategy
    time: float


class Dispatch(NamedTuple):
    """Decision: agent `agent` may start its action `index` (plan step `step`).

    `follows` names the leader (agent, action index) whose move out of `dst` is not
    complete yet: keep the safe distance from it until it is (see `following`)."""

    agent: int
    index: int
    step: int
    src: Coord
    dst: Coord
    follows: Optional[Tuple[int, int]] = None


#: Wait reasons (stable strings): the cell to enter is not free yet, the strategy
#: holds the robot (e.g. the step barrier), the run is paused, or it follows a leader
#: into a cell at the safe distance (`Engine.following`).
CELL = "cell"
PAUSED = "paused"
FOLLOW = "follow"


class Wait(NamedTuple):
    """Agent `agent` is ready for its next action but waits for agents `on`.

    `cell` is the cell it waits to enter (reason CELL) or None.
    """

    agent: int
    on: Tuple[int, ...]
    cell: Optional[Coord]
    reason: str
