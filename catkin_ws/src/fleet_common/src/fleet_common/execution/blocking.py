"""Which robots are stuck because of a robot that is out, directly or transitively.

`Wait` reports form a wait-for graph: a robot waits for the robots in its
`on` (all of them must move on before it can). A robot is blocked by an out
robot d when d is in its `on`, or when some robot in its `on` is blocked by d.
Under the discrete time step one blocked robot holds the barrier, so every
robot waiting at the barrier is blocked too; under the ADG only the chain of
robots that need d's cells is. The manager offers replanning for these.

Linear in the size of the reports: a group of robots shared by many waiters
(the barrier's) becomes one node instead of one edge per pair.
"""
from __future__ import annotations

from collections import deque
from typing import Deque, Dict, Iterable, List, Sequence, Set, Tuple

from .events import Wait


def blocked_by(waits: Sequence[Wait], out: Iterable[int]) -> Dict[int, List[int]]:
    """For each out robot, the sorted robots blocked by it (possibly none)."""
    # nodes: ("r", robot) and ("g", group id); edges point from a robot to those waiting on it
    waiters: Dict[Tuple[str, int], List[Tuple[str, int]]] = {}
    groups: Dict[int, int] = {}  # id(on tuple) -> group number
    for w in waits:
        me = ("r", w.agent)
        if len(w.on) == 1:
            waiters.setdefault(("r", w.on[0]), []).append(me)
            continue
        key = id(w.on)
        g = groups.get(key)
        if g is None:
            g = groups[key] = len(groups)
            for q in w.on:
                waiters.setdefault(("r", q), []).append(("g", g))
        waiters.setdefault(("g", g), []).append(me)
    result: Dict[int, List[int]] = {}
    for d in out:
        seen: Set[Tuple[str, int]] = {("r", d)}
        todo: Deque[Tuple[str, int]] = deque([("r", d)])
        while todo:
            for nxt in waiters.get(todo.popleft(), ()):
                if nxt not in seen:
                    seen.add(nxt)
                    todo.append(nxt)
        result[d] = sorted(r for kind, r in seen if kind == "r" and r != d)
    return result
