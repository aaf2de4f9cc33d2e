"""The ADG strategy: a robot goes as soon as its dependencies allow.

The engine already refuses to start an action before its predecessors in the
Action Dependency Graph have completed (see `adg`); this strategy adds no
other hold, so robots keep the plan's order of visits to each cell but not
its clock: a late robot delays only the robots that need a cell it has yet to
leave, directly or through others (thesis 5.6.2).

`lookahead` (Hönig et al.'s "send several actions ahead") is how many actions
a robot may have been sent and not completed: with 3, a robot whose next
three actions are free gets all three at once and drives them without
stopping for a reply; it is never sent past the first action whose
dependencies are incomplete. One round of a paused run is one action per robot.
"""
from __future__ import annotations

from .errors import UnknownStrategyError
from .strategy import Strategy, register


@register
class AdgStrategy(Strategy):
    """Dependencies only; up to `lookahead` actions sent ahead."""

    name = "adg"
    summary = "action dependency graph: keep each cell's order of robots, not the plan's clock"
    SETTINGS = ("lookahead",)

    def __init__(self, lookahead: int = 1) -> None:
        super().__init__()
        if isinstance(lookahead, bool) or not isinstance(lookahead, int) or lookahead < 1:
            raise UnknownStrategyError("adg lookahead must be a whole number >= 1, got {!r}".format(lookahead))
        self.lookahead = lookahead
        self.window = lookahead
