"""In-app replanning (thesis ch. 7): a new plan for the robots still in the run, proposed first.

When robots are out for good (a dead battery), the ones that wait for them
wait forever. `replan` gets the others to their goals around them:

1. the run is paused and the replanner waits for a *safe point*: no robot
   in the middle of a command, so every robot that takes part stands on a
   cell of the plan and nobody is mid-move across the switch;
2. it plans, in a worker thread (the manager keeps serving robots and
   consoles), every robot that takes part from the cell it holds to its
   goal, with the out robots as obstacles (`fleet_common.planning.replan`,
   time-limited), walling off the second cell of an out robot that stopped
   mid-move;
3. the plan is proposed to the consoles; `accept` switches the run to it
   (and resumes if the run was running), `reject` goes back to the old plan.

The old and the new plan both stay in the run folder (plan-1.txt, plan-2.txt).
"""
from __future__ import annotations

import math
import threading
from dataclasses import dataclass
from typing import TYPE_CHECKING, List, Optional, Set

from fleet_common.grid import Coord, Grid
from fleet_common.planning.replan import ReplanResult, replan

from .driver import AT_CELL

if TYPE_CHECKING:
    from .manager import Manager

__all__ = ["Replanner", "Pending"]

IDLE, SAFE_POINT, PLANNING, PROPOSED = "idle", "safe-point", "planning", "proposed"


@dataclass
class Pending:
    """A computed proposal awaiting the operator."""

    id: int
    result: ReplanResult
    current: List[Coord]
    out: Set[int]


class Replanner:
    def __init__(self, time_limit: float = 5.0) -> None:
        self.state = IDLE
        self.time_limit = time_limit
        self.method = "pp"
        self.was_running = False
        self.pending: Optional[Pending] = None
        self._thread: Optional[threading.Thread] = None
        self._result: Optional[Pending] = None
        self._error: Optional[str] = None
        self._next_id = 1

    @property
    def busy(self) -> bool:
        return self.state in (SAFE_POINT, PLANNING)

    @property
    def proposal_id(self) -> Optional[int]:
        return self.pending.id if self.state == PROPOSED and self.pending is not None else None

    def request(self, was_running: bool, time_limit: Optional[float], method: Optional[str]) -> None:
        self.state = SAFE_POINT
        self.was_running = was_running
        self.time_limit = time_limit or self.time_limit
        self.method = method or "pp"

    def poll(self, manager: "Manager") -> Optional[str]:
        """Move on if it can; a message for the operator when something happened."""
        if self.state == SAFE_POINT and not manager.driver.moving:
            self._start(manager)
            return None
        if self.state == PLANNING and self._thread is not None and not self._thread.is_alive():
            self._thread = None
            if self._error is not None:
                self.state = IDLE
                return "replanning failed: " + self._error
            pending = self._result
            assert pending is not None
            if pending.result.plan is None:
                self.state = IDLE
                return "replanning found no plan: {}".format(pending.result.message)
            self.pending = pending
            self.state = PROPOSED
            return "replan {} proposed: {}".format(pending.id, pending.result.message)
        return None

    def resolved(self) -> None:
        self.state = IDLE
        self.pending = None

    def _start(self, manager: "Manager") -> None:
        engine, driver = manager.engine, manager.driver
        run = engine.run
        current = [driver.position(s) for s in driver.slots]
        out = {s.agent for s in driver.slots if run.out[s.agent] is not None}
        grid = _walled(manager.grid, manager, out)
        goals = list(manager.goals)
        proposal_id = self._next_id
        self._next_id += 1
        self._error = None
        self._result = None

        def work() -> None:
            try:
                result = replan(grid, current, goals, out, deadline=self.time_limit,
                                method=self.method)
                self._result = Pending(proposal_id, result, current, out)
            except Exception as err:  # a planning failure must not kill the manager
                self._error = "{}: {}".format(type(err).__name__, err)

        self.state = PLANNING
        self._thread = threading.Thread(target=work, name="replan", daemon=True)
        self._thread.start()


def _walled(grid: Grid, manager: "Manager", out: Set[int]) -> Grid:
    """`grid` with the far cell of every out robot that stopped mid-move blocked."""
    run, table = manager.engine.run, manager.engine.table
    free = grid.free.copy()
    for slot in manager.driver.slots:
        if slot.agent not in out:
            continue
        a = run.next_incomplete(slot.agent)
        pose = manager.positions.pose(slot.robot_id)
        here = manager.driver.position(slot)
        if a < 0 or pose is None or math.hypot(pose.x - here[0], pose.y - here[1]) <= AT_CELL:
            continue
        x, y = table.coord(run.dst[a])
        free[y, x] = False
    return Grid(free, name=grid.name)
