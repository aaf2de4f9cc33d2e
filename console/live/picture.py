"""What the map shows of the live fleet at one moment, as arrays by plan agent.

Built from the model's newest State and scene, pure, for `ui.robot_layer`:
reported poses and headings, the planned position (the plan at the run's
plan clock: the faint ghost), which robots are greyed and why, which are
behind the plan, where each one's remaining plan starts, and the waits to
draw (a red frame on the cell a robot waits to enter, arrows to the robots it
waits for), and who follows whom into a cell at the safe distance.

Waits flicker: under ADG a robot often waits a few milliseconds for a cell
that is being left. `WaitMarks` shows a wait only once it has lasted
`after` seconds, so the red frame means a real hold-up, as in the thesis's
fig. 5.11.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Dict, List, Optional, Tuple

import numpy as np

from ..fleet_state import state_at
from .describe import BEHIND_MARK, greyed
from .model import LiveModel

__all__ = ["Picture", "WaitMark", "WaitMarks", "picture"]

Cell = Tuple[int, int]


@dataclass(frozen=True)
class WaitMark:
    agent: int
    cell: Cell
    on: Tuple[int, ...]  # agents it waits for


@dataclass
class Picture:
    pose: np.ndarray          # (N, 2) cells; the plan start where no pose came yet
    theta: np.ndarray         # (N,) radians, NaN unknown
    ghost: Optional[np.ndarray]  # (N, 2) planned positions now; None before the run starts
    grey: np.ndarray          # (N,) bool
    labels: List[str]         # why each is greyed ("" if not)
    behind: np.ndarray        # (N,) bool
    steps: np.ndarray         # (N,) plan step of each robot's next action
    waits: List[WaitMark] = field(default_factory=list)
    #: (follower agent, leader agent): it drives into a cell its leader is leaving, at the safe
    #: distance (drawn as a thin line; a follower standing at its hold point waits, in red)
    follows: List[Tuple[int, int]] = field(default_factory=list)

    @property
    def num_agents(self) -> int:
        return int(self.pose.shape[0])


def picture(model: LiveModel) -> Picture:
    scene = model.scene
    n = 0 if scene is None else scene.num_agents
    fleet = model.fleet_state()
    theta = np.radians(fleet.headings) if fleet.headings is not None else np.full(n, np.nan)
    grey = np.zeros(n, dtype=bool)
    behind = np.zeros(n, dtype=bool)
    steps = np.zeros(n, dtype=np.int64)
    labels = [""] * n
    waits: List[WaitMark] = []
    follows: List[Tuple[int, int]] = []
    for agent, r in enumerate(model.robots_by_agent()):
        why = greyed(r, model.connected)
        if why is not None:
            grey[agent], labels[agent] = True, why
        if r is None:
            continue
        behind[agent] = r.behind >= BEHIND_MARK and why is None
        steps[agent] = r.step
        w = r.waiting
        if w is not None and w.cell is not None and model.connected:
            on = tuple(model.agent_of[o] for o in w.on if o in model.agent_of)
            waits.append(WaitMark(agent, (int(w.cell[0]), int(w.cell[1])), on))
        elif r.follows is not None and r.follows in model.agent_of and model.connected:
            follows.append((agent, model.agent_of[r.follows]))
    ghost = None
    run = None if model.state is None else model.state.run
    if scene is not None and scene.plan is not None and run is not None and run.clock > 0:
        # a run done is where its plan ends, also when the robots got there before the plan's clock
        # did (a plan that gives its turns whole steps): no ghost left standing in an empty cell
        at = float(scene.plan.makespan) if run.state == "done" else run.plan_time
        ghost = state_at(scene.plan, at).positions
    return Picture(fleet.positions, theta, ghost, grey, labels, behind, steps, waits, follows)


class WaitMarks:
    """Keeps the waits that have lasted `after` seconds (by the caller's clock)."""

    def __init__(self, after: float = 0.3) -> None:
        self.after = after
        self._since: Dict[WaitMark, float] = {}

    def lasting(self, waits: List[WaitMark], now: float) -> List[WaitMark]:
        since = {w: self._since.get(w, now) for w in waits}
        self._since = since
        return [w for w in waits if now - since[w] >= self.after]
