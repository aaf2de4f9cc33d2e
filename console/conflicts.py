"""Validator findings as the player lists and marks them.

Each finding with a time step becomes an entry: a short line for the list,
in the view's coordinates, the time to jump to, and the time window in which
its marker is shown on the canvas. A vertex conflict is marked around the
step where the agents meet; a swap conflict during the move in which the
agents pass through each other (from step t-1 to t), and the jump goes to the
middle of that move, where the two discs overlap.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import List, Optional, Sequence, Tuple

from fleet_common.grid import Coord
from fleet_common.validate import SWAP, Finding

from .orientation import shown_cell

#: Short names for the list.
KIND_LABELS = {
    "vertex-conflict": "vertex", "swap-conflict": "swap", "following-move": "following",
    "off-map": "off map", "blocked": "blocked", "non-adjacent-move": "jump",
    "start-mismatch": "start", "goal-mismatch": "goal",
    "soc-mismatch": "soc", "makespan-mismatch": "makespan", "agent-count": "agents",
}


_EPS = 1e-3


@dataclass(frozen=True)
class ConflictEntry:
    finding: Finding
    #: where the player goes when the entry is picked (None: the finding has no time)
    jump_time: Optional[float]
    #: the marker shows while window[0] <= t <= window[1]
    window: Tuple[float, float]

    @property
    def cell(self) -> Optional[Coord]:
        return self.finding.cell

    @property
    def agents(self) -> Tuple[int, ...]:
        return self.finding.agents

    def label(self, height: int, view: str, file_orientation: str) -> str:
        f = self.finding
        kind = KIND_LABELS.get(f.kind, f.kind)
        if f.timestep is None:
            return "{}: {}".format(kind, f.message)
        where = ""
        if f.cell is not None:
            where = " at ({}, {})".format(*shown_cell(f.cell, height, view, file_orientation))
        who = ", ".join(str(a) for a in f.agents)
        return "t={:<4d} {:<7s} {}{}".format(f.timestep, kind, who, where)


def conflict_entries(findings: Sequence[Finding]) -> List[ConflictEntry]:
    """Entries in the order of time (findings without a time last)."""
    out = []
    for f in findings:
        if f.timestep is None:
            out.append(ConflictEntry(f, None, (-1.0, -1.0)))
        elif f.kind == SWAP:  # while passing each other, not at either end of the move
            out.append(ConflictEntry(f, f.timestep - 0.5, (f.timestep - 1 + _EPS, f.timestep - _EPS)))
        else:
            out.append(ConflictEntry(f, float(f.timestep), (f.timestep - 0.5 + _EPS, f.timestep + 0.5 - _EPS)))
    out.sort(key=lambda e: (e.jump_time is None, e.jump_time or 0.0))
    return out


def next_entry(entries: Sequence[ConflictEntry], time: float, delta: int) -> Optional[int]:
    """Index of the first timed entry after (delta 1) or before (-1) `time`, wrapping."""
    timed = [i for i, e in enumerate(entries) if e.jump_time is not None]
    if not timed:
        return None
    if delta > 0:
        later = [i for i in timed if entries[i].jump_time > time + 1e-6]
        return later[0] if later else timed[0]
    earlier = [i for i in timed if entries[i].jump_time < time - 1e-6]
    return earlier[-1] if earlier else timed[-1]
