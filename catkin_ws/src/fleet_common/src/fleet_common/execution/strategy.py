"""Synchronization strategies: how much of the plan's timing a run keeps.

Whatever the strategy, the engine never starts an action before its
predecessors in the Action Dependency Graph have completed: that rule alone
keeps robots out of each other's cells (see `adg`), so no strategy can make a
run unsafe. A strategy may only hold actions back further (the discrete time
step holds every robot at the slowest one's step) or let a robot be sent
several actions ahead (the ADG's lookahead). It answers the engine's
questions from the shared `RunState`:

- `window`: how many actions a robot may have been sent and not completed;
- `holds(a)`: is action `a` held back now (its dependencies aside), and
  `hold_reason(a)`: why, for the console;
- `on_completed`, `on_out`, `on_back`, `on_tick`: which robots may now start something
  besides those the dependency graph names (the robot itself, the waiter);
- `overtake(a)`: only for strategies that re-order (`reorders`): may action
  `a`'s robot go before the robot it waits for at a cell (`reorder`);
- `round()`: how far each robot may go in one "step" of a paused run;
- `finished()`: is the run over (by default: every robot that is not out
  has completed its actions).

Adding a strategy is one `Strategy` subclass decorated with `@register`, in a
module that `execution/__init__.py` imports. `attach` is called when the
strategy takes over a run (at the start or mid-run), so a strategy derives
its state from the run's progress and never from another strategy.
"""
from __future__ import annotations

from typing import ClassVar, Dict, List, Optional, Sequence, Tuple, Type

from .errors import UnknownStrategyError
from .run import RunState

#: Registered strategies by name, in registration order.
STRATEGIES: Dict[str, Type["Strategy"]] = {}

#: Hold reasons (stable strings for the console and tests).
BARRIER = "barrier"


class Strategy:
    """Base class: no holds, one action at a time (see the module docstring)."""

    name: ClassVar[str] = ""
    #: One line for `fleetctl simulate --help` and the console.
    summary: ClassVar[str] = ""
    #: Keyword settings `make_strategy` accepts for this strategy.
    SETTINGS: ClassVar[Tuple[str, ...]] = ()
    #: True when the strategy may change a cell's order of robots (the engine asks `overtake`).
    reorders: ClassVar[bool] = False
    #: How often (plan steps) the strategy wants a `Tick` while the run runs; 0: never.
    tick_every: ClassVar[float] = 0.0

    def __init__(self) -> None:
        self.run: Optional[RunState] = None
        #: Actions a robot may have been sent and not yet completed.
        self.window = 1

    def attach(self, run: RunState) -> None:
        """Take over `run` (at its start or mid-run): derive state from its progress."""
        self.run = run

    def holds(self, a: int) -> bool:
        """True while this strategy keeps action `a` back (dependencies aside)."""
        return False

    def overtake(self, a: int) -> bool:
        """Action `a`'s robot is ready and `a` waits for a move out of its cell that is not
        released: change the cell's order so that it need not (see `reorder`)? True when
        `a`'s dependency is met now."""
        return False

    def hold_reason(self, a: int) -> Tuple[str, Tuple[int, ...]]:
        """Why `holds(a)`: a reason and the robots it waits for."""
        return ("", ())

    def on_completed(self, a: int) -> Sequence[int]:
        """Action `a` completed: robots that may now start an action because of it."""
        return ()

    def on_out(self, agent: int) -> Sequence[int]:
        """`robot` was disabled or failed: robots that may now start an action."""
        return ()

    def on_tick(self) -> Sequence[int]:
        """Time passed (`Tick`): robots to look at again."""
        return ()

    def on_back(self, agent: int) -> Sequence[int]:
        """`robot` takes part again: robots that may now start an action."""
        return ()

    def finished(self) -> bool:
        """Is the run finished: every robot that is not out has completed its actions."""
        return self._attached().finished

    def round(self) -> List[int]:
        """Per robot, how many of its actions may have been sent after one round."""
        run = self._attached()
        return [run.dispatched[r] + 1 for r in range(run.num_agents)]

    def settings(self) -> Dict[str, object]:
        return {key: getattr(self, key) for key in self.SETTINGS}

    def describe(self) -> str:
        extra = ", ".join("{} {}".format(k, v) for k, v in self.settings().items())
        return "{} ({})".format(self.name, extra) if extra else self.name

    def _attached(self) -> RunState:
        if self.run is None:
            raise RuntimeError("strategy '{}' is not attached to a run".format(self.name))
        return self.run


def register(cls: Type[Strategy]) -> Type[Strategy]:
    """Class decorator: make `cls` available by its `name`."""
    if not cls.name:
        raise ValueError("strategy class {} has no name".format(cls.__name__))
    STRATEGIES[cls.name] = cls
    return cls


def make_strategy(name: str, **settings: object) -> Strategy:
    """A new strategy by registered name, with its settings (e.g. `lookahead=3`)."""
    cls = STRATEGIES.get(name)
    if cls is None:
        raise UnknownStrategyError("unknown strategy '{}'; available strategies are: {}".format(
            name, ", ".join(STRATEGIES)))
    for key in settings:
        if key not in cls.SETTINGS:
            raise UnknownStrategyError("strategy '{}' has no setting '{}'; its settings are: {}".format(
                name, key, ", ".join(cls.SETTINGS) or "none"))
    return cls(**settings)  # type: ignore[call-arg]
