"""The terms of a delay model, in nominal moves and probabilities per move.

Every move of every robot is affected by the terms that apply to it:

    factor     the move takes LOW..HIGH (uniform) times its nominal time
    delay      it starts after a wait of 0..D moves (uniform)
    slow       with probability P it runs F times slower
    stall      with probability P it halts S moves partway, then goes on
    dropout    with probability P the robot drops out partway and is back
               S moves later, restarted (the simulator, which has no
               connection to lose, holds it there for S, like a stall)
    robots     robot R (0-based agent index) is always F times slower
    events     League of Robot Runners delay events: before a move, with
               probability P (bernoulli) or Poisson(P) times (poisson), the
               robot stands still for a duration drawn from MIN..MAX whole
               moves, uniform or gaussian (mean and spread as fractions of
               the range)
    prone      BTPG's model: a FRACTION of the robots is delay-prone; before
               each of their moves, with probability P, they stand still S moves
    seed       the seed used when the command gives none

A wait before a move (delay, events, prone) keeps the robot in its cell; a
slow or stalled move keeps it in both cells of the move.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import List, Optional, Tuple

from ..errors import FormatError

EVENT_MODELS = ("bernoulli", "poisson")
DURATION_MODELS = ("uniform", "gaussian")


class DelayModelError(FormatError):
    """A delay model spec or file that says something this language does not."""

    def __str__(self) -> str:
        return FormatError.__str__(self) if self.path else "delay model: " + self.message


@dataclass(frozen=True)
class EventDelays:
    """League of Robot Runners `delayConfig` events (durations in whole moves)."""

    model: str = "bernoulli"
    p: float = 0.0
    min: int = 1
    max: int = 1
    duration: str = "uniform"
    mean: float = 0.5   # gaussian: mean at min + mean x (max - min)
    std: float = 0.25   # gaussian: standard deviation std x (max - min)


@dataclass(frozen=True)
class ProneDelays:
    """BTPG's model: `fraction` of the robots delay-prone, each move delayed `moves` with `p`."""

    fraction: float = 0.1
    p: float = 0.3
    moves: float = 5.0


@dataclass(frozen=True)
class DelayModel:
    """What can make moves late; see the module docstring. The default is a perfect fleet."""

    factor: Tuple[float, float] = (1.0, 1.0)
    delay: float = 0.0
    slow_p: float = 0.0
    slow_factor: float = 1.0
    stall_p: float = 0.0
    stall_moves: float = 0.0
    dropout_p: float = 0.0
    dropout_moves: float = 0.0
    robots: Tuple[Tuple[int, float], ...] = ()
    events: Optional[EventDelays] = None
    prone: Optional[ProneDelays] = None
    seed: Optional[int] = field(default=None, compare=True)

    @property
    def perfect(self) -> bool:
        return self.describe() == "none"

    def check_robots(self, num_robots: int) -> None:
        for robot, _ in self.robots:
            if robot >= num_robots:
                raise DelayModelError("robot={}:...: the plan has robots 0..{} only".format(
                    robot, num_robots - 1))

    def describe(self) -> str:
        """One line a person reads (the summary of `fleetctl simulate`)."""
        parts: List[str] = []
        low, high = self.factor
        if high > low:
            parts.append("moves take {:g}-{:g} x nominal".format(low, high))
        elif low != 1.0:
            parts.append("moves take {:g} x nominal".format(low))
        if self.delay > 0:
            parts.append("start after 0-{:g} moves".format(self.delay))
        if self.slow_p > 0 and self.slow_factor != 1.0:
            parts.append("{:g}x slower with p={:g}".format(self.slow_factor, self.slow_p))
        if self.stall_p > 0 and self.stall_moves > 0:
            parts.append("stalls of {:g} moves with p={:g}".format(self.stall_moves, self.stall_p))
        if self.dropout_p > 0:
            parts.append("dropouts of {:g} moves with p={:g}".format(self.dropout_moves, self.dropout_p))
        for robot, slow in self.robots:
            parts.append("robot {} {:g}x slower".format(robot, slow))
        e = self.events
        if e is not None and e.p > 0:
            parts.append("{} delay events p={:g} of {}-{} moves ({})".format(
                e.model, e.p, e.min, e.max, e.duration))
        q = self.prone
        if q is not None and q.fraction > 0 and q.p > 0:
            parts.append("{:g}% of robots delay-prone: p={:g} per move, {:g} moves".format(
                100 * q.fraction, q.p, q.moves))
        return "; ".join(parts) or "none"

    def spec(self) -> str:
        """The model in the command-line spec language (parses back to an equal model)."""
        terms: List[str] = []
        if self.factor != (1.0, 1.0):
            terms.append("factor={}-{}".format(*map(_num, self.factor)))
        if self.delay:
            terms.append("delay={}".format(_num(self.delay)))
        if self.slow_p:
            terms.append("slow={}:{}".format(_num(self.slow_p), _num(self.slow_factor)))
        if self.stall_p:
            terms.append("stall={}:{}".format(_num(self.stall_p), _num(self.stall_moves)))
        if self.dropout_p:
            terms.append("dropout={}:{}".format(_num(self.dropout_p), _num(self.dropout_moves)))
        terms += ["robot={}:{}".format(r, _num(f)) for r, f in self.robots]
        e = self.events
        if e is not None:
            terms.append("events={}:{}:{}-{}:{}:{}:{}".format(
                e.model, _num(e.p), e.min, e.max, e.duration, _num(e.mean), _num(e.std)))
        q = self.prone
        if q is not None:
            terms.append("prone={}:{}:{}".format(_num(q.fraction), _num(q.p), _num(q.moves)))
        if self.seed is not None:
            terms.append("seed={}".format(self.seed))
        return ",".join(terms) or "none"


def _num(x: float) -> str:
    """`x` exactly (it parses back to the same float), without a needless `.0`."""
    text = repr(float(x))
    return text[:-2] if text.endswith(".0") else text
