"""Delay models for the simulator: how long each move really takes.

A move's duration is `nominal x factor`, plus a stall now and then:

    none                 every move takes exactly `nominal`
    random:LOW-HIGH      factor drawn uniformly from [LOW, HIGH] per move
    stall:P:LENGTH       with probability P a move also stalls LENGTH nominal moves
    slow:ROBOT:FACTOR    robot ROBOT (0-based agent index) is FACTOR times slower, always
    moderate             random:0.8-1.5 and stall:0.02:3 (the default)

Several specs combine (`random:0.9-1.2` with `slow:3:2`). Durations are drawn
per action, once, from a seeded generator: the same seed gives the same
duration to each action whatever the strategy, so strategies are compared on
the very same delays.
"""
from __future__ import annotations

import re
from typing import Dict, List, Sequence

import numpy as np

from ..errors import FleetError
from .actions import ActionTable

FORMS = "none, moderate, random:LOW-HIGH, stall:P:LENGTH, slow:ROBOT:FACTOR"
_NUM = r"(\d+(?:\.\d*)?|\.\d+)"
_RANDOM = re.compile(r"random:{0}-{0}$".format(_NUM))
_STALL = re.compile(r"stall:{0}:{0}$".format(_NUM))
_SLOW = re.compile(r"slow:(\d+):{0}$".format(_NUM))


class DelayModelError(FleetError, ValueError):
    """A delay model spec that is not one of the forms in `FORMS`."""


class DelayModel:
    """Per-move factor range, random stalls, and permanently slow robots."""

    def __init__(self, low: float = 1.0, high: float = 1.0, stall_p: float = 0.0,
                 stall_len: float = 0.0, slow: Dict[int, float] = None) -> None:
        self.low, self.high = low, high
        self.stall_p, self.stall_len = stall_p, stall_len
        self.slow: Dict[int, float] = dict(slow or {})

    def durations(self, table: ActionTable, seed: int, nominal: float = 1.0) -> np.ndarray:
        """One duration per action of `table` (flat action order)."""
        rng = np.random.default_rng(seed)
        count = table.num_actions
        factor = rng.uniform(self.low, self.high, count) if self.high > self.low else np.full(count, self.low)
        stalls = (rng.random(count) < self.stall_p) * self.stall_len
        self.check_robots(table.num_robots)
        for robot, slow in self.slow.items():
            factor[table.first[robot]:table.first[robot + 1]] *= slow
        return nominal * (factor + stalls)

    def check_robots(self, num_robots: int) -> None:
        for robot in self.slow:
            if robot >= num_robots:
                raise DelayModelError("slow:{}: the plan has robots 0..{} only".format(robot, num_robots - 1))

    def describe(self) -> str:
        parts: List[str] = []
        if self.high > self.low:
            parts.append("moves take {:g}-{:g} x nominal".format(self.low, self.high))
        elif self.low != 1.0:
            parts.append("moves take {:g} x nominal".format(self.low))
        if self.stall_p > 0 and self.stall_len > 0:
            parts.append("stalls of {:g} moves with p={:g}".format(self.stall_len, self.stall_p))
        for robot, slow in sorted(self.slow.items()):
            parts.append("robot {} {:g}x slower".format(robot, slow))
        return "; ".join(parts) or "none"


def parse_delay_model(specs: Sequence[str]) -> DelayModel:
    """The model the specs describe; no specs means `moderate`."""
    model = DelayModel()
    for spec in specs or ["moderate"]:
        spec = spec.strip()
        m_random, m_stall, m_slow = _RANDOM.match(spec), _STALL.match(spec), _SLOW.match(spec)
        if spec == "none":
            model = DelayModel(slow=model.slow)
        elif spec == "moderate":
            model.low, model.high, model.stall_p, model.stall_len = 0.8, 1.5, 0.02, 3.0
        elif m_random:
            low, high = float(m_random.group(1)), float(m_random.group(2))
            if not 0 < low <= high:
                raise DelayModelError("delay model '{}': need 0 < LOW <= HIGH".format(spec))
            model.low, model.high = low, high
        elif m_stall:
            p, length = float(m_stall.group(1)), float(m_stall.group(2))
            if p > 1:
                raise DelayModelError("delay model '{}': the probability P must be at most 1".format(spec))
            model.stall_p, model.stall_len = p, length
        elif m_slow:
            factor = float(m_slow.group(2))
            if factor <= 0:
                raise DelayModelError("delay model '{}': FACTOR must be positive".format(spec))
            model.slow[int(m_slow.group(1))] = factor
        else:
            raise DelayModelError("unknown delay model '{}'; use one of: {}".format(spec, FORMS))
    return model
