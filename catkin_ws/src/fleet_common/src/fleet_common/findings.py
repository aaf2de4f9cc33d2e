"""What the validator says about a plan: findings, each with a severity and a stable kind.

A `Report` lists the findings of one `validate.validate_plan` run, errors and
information (legal in mapf-IR, but worth knowing, such as following moves) in
the order checked, and counts every finding of each kind, also those past the
listing cap. Kinds are stable strings that tests and tools may match on.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Dict, List, Optional, Tuple

from .grid import Coord

ERROR = "error"
INFO = "info"

#: Finding kinds, stable strings that tests and tools may match on.
OFF_MAP = "off-map"
BLOCKED = "blocked"
JUMP = "non-adjacent-move"
VERTEX = "vertex-conflict"
SWAP = "swap-conflict"
FOLLOWING = "following-move"
ROTATION = "rotation"
START = "start-mismatch"
GOAL = "goal-mismatch"
AGENTS = "agent-count"
SOC = "soc-mismatch"
MAKESPAN = "makespan-mismatch"


@dataclass(frozen=True)
class Finding:
    """One problem (or remark) about a plan; `str()` is a line for people."""

    severity: str
    kind: str
    message: str
    timestep: Optional[int] = None
    agents: Tuple[int, ...] = ()
    cell: Optional[Coord] = None

    def __str__(self) -> str:
        return self.message


@dataclass
class Report:
    """The findings about one plan, errors first in the order checked."""

    findings: List[Finding] = field(default_factory=list)
    #: findings per kind, including those not listed (past `max_findings_per_kind`)
    counts: Dict[str, int] = field(default_factory=dict)

    @property
    def errors(self) -> List[Finding]:
        return [f for f in self.findings if f.severity == ERROR]

    @property
    def infos(self) -> List[Finding]:
        return [f for f in self.findings if f.severity == INFO]

    @property
    def ok(self) -> bool:
        return not self.errors

    def of_kind(self, kind: str) -> List[Finding]:
        return [f for f in self.findings if f.kind == kind]

    def count(self, kind: str) -> int:
        """How many findings of `kind` there are, listed or not."""
        return self.counts.get(kind, 0)
