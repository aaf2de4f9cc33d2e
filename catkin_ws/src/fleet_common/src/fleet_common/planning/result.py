"""What every solver returns: a plan, or a clear reason why there is none.

`status` is "solved" (a plan that passed the validator), "timeout" (the time
or step budget ran out first) or "no-solution" (the search is exhausted, or an
incomplete solver gave up: `message` says which). `comp_time_ms` is wall time.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Dict, Optional

from ..errors import FleetError
from ..plan import Plan

SOLVED = "solved"
TIMEOUT = "timeout"
NO_SOLUTION = "no-solution"
STATUSES = (SOLVED, TIMEOUT, NO_SOLUTION)


class SolverError(FleetError):
    """A solver returned a plan that the validator rejects: a bug, never user input."""


@dataclass
class SolveResult:
    """A solver's answer; `plan` is None unless `status` is "solved"."""

    plan: Optional[Plan]
    solver: str
    status: str
    comp_time_ms: float = 0.0
    message: str = ""
    stats: Dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if self.status not in STATUSES:
            raise ValueError("status must be one of {}, got {!r}".format(", ".join(STATUSES), self.status))
        if (self.plan is not None) != (self.status == SOLVED):
            raise ValueError("a plan is given exactly when the status is 'solved'")

    @property
    def solved(self) -> bool:
        return self.status == SOLVED

    def summary(self) -> str:
        """One line for people: solver, status, soc/makespan or the reason."""
        head = "{}: {} in {:.1f} ms".format(self.solver, self.status, self.comp_time_ms)
        if self.plan is not None:
            return "{}, soc={} makespan={}".format(head, self.plan.soc, self.plan.makespan)
        return "{} ({})".format(head, self.message) if self.message else head


def solved(plan: Plan, solver: str, **stats: Any) -> SolveResult:
    return SolveResult(plan, solver, SOLVED, stats=dict(stats))


def failed(solver: str, status: str, message: str, **stats: Any) -> SolveResult:
    return SolveResult(None, solver, status, message=message, stats=dict(stats))
