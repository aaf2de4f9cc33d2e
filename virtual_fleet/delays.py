"""The virtual fleet's delay and fault model: what can go wrong with a move, and how often.

Written on the command line as comma-separated `name=value` terms:

    delay=D          each move starts after a random wait of 0..D seconds
    slow=P:F         with probability P a move runs F times slower
    stall=P:S        with probability P a move halts for S seconds partway, then goes on
    dropout=P:S      with probability P the robot drops out partway through a move (its
                     sockets close, as at a power cut) and comes back S seconds later as
                     a restarted robot (new session, command memory lost), where it stopped

e.g. `--delay-model "delay=0.5,slow=0.1:2,stall=0.05:3,dropout=0.01:10"`. Times are in
the fleet's own (scaled) seconds. `none` (the default) is a perfect fleet.
Draws come from a per-robot `random.Random`, so a `--seed` makes a run repeatable.
"""
from __future__ import annotations

import random
from dataclasses import dataclass
from typing import Dict, Optional

from fleet_common.errors import FleetError

__all__ = ["DelayModel", "MoveFate", "parse_delay_model"]

_TERMS = {"delay": 1, "slow": 2, "stall": 2, "dropout": 2}
_HELP = "delay=D, slow=P:F, stall=P:S, dropout=P:S (comma-separated) or none"


@dataclass(frozen=True)
class MoveFate:
    """What happens to one move: extra wait, speed factor, a stall, a dropout."""

    start_delay: float = 0.0
    slowdown: float = 1.0
    stall: float = 0.0              # seconds of stall, 0: none
    stall_at: float = 0.5           # where, as a fraction of the move
    dropout_at: Optional[float] = None  # fraction of the move, None: no dropout


@dataclass(frozen=True)
class DelayModel:
    delay: float = 0.0
    slow_p: float = 0.0
    slow_factor: float = 1.0
    stall_p: float = 0.0
    stall_s: float = 0.0
    dropout_p: float = 0.0
    dropout_s: float = 0.0

    def draw(self, rng: random.Random) -> MoveFate:
        """The fate of the next move. Every term draws, so fates do not shift when one
        term's probability changes."""
        start = rng.uniform(0.0, self.delay)
        slow = self.slow_factor if rng.random() < self.slow_p else 1.0
        stall = self.stall_s if rng.random() < self.stall_p else 0.0
        stall_at = rng.random()
        drop = rng.random() < self.dropout_p
        dropout_at = rng.random()
        return MoveFate(start, slow, stall, stall_at, dropout_at if drop else None)


def parse_delay_model(text: str) -> DelayModel:
    """The model `text` describes; FleetError naming the bad term otherwise."""
    text = text.strip()
    if text in ("", "none"):
        return DelayModel()
    values: Dict[str, list] = {}
    for term in text.split(","):
        name, eq, rest = term.strip().partition("=")
        if name not in _TERMS or not eq:
            raise FleetError("delay model term {!r}: expected {}".format(term.strip(), _HELP))
        if name in values:
            raise FleetError("delay model names {} twice".format(name))
        parts = rest.split(":")
        try:
            numbers = [float(p) for p in parts]
        except ValueError:
            numbers = []
        if len(numbers) != _TERMS[name] or any(n < 0 for n in numbers):
            raise FleetError("delay model term {!r}: expected {} with non-negative numbers".format(
                term.strip(), {"delay": "delay=D", "slow": "slow=P:F", "stall": "stall=P:S",
                               "dropout": "dropout=P:S"}[name]))
        if name != "delay" and numbers[0] > 1:
            raise FleetError("delay model term {!r}: the probability P must be 0..1".format(
                term.strip()))
        values[name] = numbers
    if "slow" in values and values["slow"][1] < 1:
        raise FleetError("delay model: slow=P:F needs F >= 1 (F times slower)")
    slow = values.get("slow", [0.0, 1.0])
    stall = values.get("stall", [0.0, 0.0])
    dropout = values.get("dropout", [0.0, 0.0])
    return DelayModel(values.get("delay", [0.0])[0], slow[0], slow[1], stall[0], stall[1],
                      dropout[0], dropout[1])
