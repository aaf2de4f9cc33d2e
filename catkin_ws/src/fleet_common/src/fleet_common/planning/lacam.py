"""LaCAM: Lazy Constraints Addition search for MAPF (Okumura, AAAI 2023).

Theory of operation. A depth-first search over configurations (every agent's
cell at one step). Successors are not enumerated (5^N of them): a high-level
node asks PIBT for one successor at a time, each time under a different set of
constraints ("agent i goes to cell v"), taken from a low-level search tree that
grows breadth-first, one agent per level, only as successors are requested.
PIBT's greedy move usually heads straight for the goal; when it revisits a
configuration, the search goes back to that node and tries its next
constraint. Every configuration is visited once, and every successor of it can
be forced by some constraint set, so the search is complete: it finds a plan
whenever one exists, and reports "no-solution" when every reachable
configuration has been tried. Plans are feasible, not optimal.

Unless `rotations` is set, successors have no rotation (robots cannot
perform one): PIBT avoids them and undoes any that a constraint set closes
(`pibt_step`). Completeness carries over to rotation-free plans: a
constraint set that fixes every agent to a rotation-free successor leaves
PIBT nothing to plan and nothing to undo, so that successor is generated, and
the fully grown constraint tree holds one such set per successor; an undone
cycle only yields another valid successor, explored like any other.
"""
from __future__ import annotations

import random
from collections import deque
from typing import Deque, Dict, List, Optional, Sequence, Tuple

from ..grid import Coord, Grid
from .cells import NIL, plan_from_configs, to_ids
from .deadline import Deadline
from .pibt import initial_ties
from .pibt_step import PIBTStep
from .result import NO_SOLUTION, TIMEOUT, SolveResult, failed, solved

NAME = "lacam"
Config = Tuple[int, ...]


class _Constraint:
    """Low-level node: the agents `who` are sent to cells `where` (parallel tuples)."""

    __slots__ = ("who", "where")

    def __init__(self, who: Tuple[int, ...] = (), where: Tuple[int, ...] = ()) -> None:
        self.who = who
        self.where = where


class _Node:
    """High-level node: a configuration, how the search reached it, and its constraint tree."""

    __slots__ = ("config", "parent", "prio", "order", "tree")

    def __init__(self, config: Config, parent: "Optional[_Node]", prio: List[float]) -> None:
        self.config = config
        self.parent = parent
        self.prio = prio
        self.order = sorted(range(len(config)), key=prio.__getitem__, reverse=True)
        self.tree: Deque[_Constraint] = deque([_Constraint()])


def lacam(grid: Grid, starts: Sequence[Coord], goals: Sequence[Coord], deadline: Deadline,
          seed: int = 0, rotations: bool = False) -> SolveResult:
    """Search until a plan is found, every configuration is exhausted, or the deadline."""
    rng = random.Random(seed)
    n = len(starts)
    goal_cfg: Config = tuple(to_ids(grid, goals))
    start_cfg: Config = tuple(to_ids(grid, starts))
    stepper = PIBTStep(grid, goals, rotations=rotations)
    tie = initial_ties(stepper, start_cfg, rng)
    root = _Node(start_cfg, None, list(tie))
    open_: List[_Node] = [root]
    explored: Dict[Config, _Node] = {start_cfg: root}
    moves = stepper.moves
    loops = 0
    while open_:
        loops += 1
        if loops & 63 == 0 and deadline.expired():
            return failed(NAME, TIMEOUT, "time limit reached after {} configurations".format(
                len(explored)), explored=len(explored), loops=loops)
        node = open_[-1]
        if node.config == goal_cfg:
            return solved(plan_from_configs(grid, _backtrack(node), n), NAME,
                          explored=len(explored), loops=loops, undone_rotations=stepper.reverted)
        if not node.tree:
            open_.pop()
            continue
        con = node.tree.popleft()
        depth = len(con.who)
        if depth < n:  # grow the constraint tree one agent deeper, lazily
            i = node.order[depth]
            cells = list(moves[node.config[i]])
            rng.shuffle(cells)
            for v in cells:
                node.tree.append(_Constraint(con.who + (i,), con.where + (v,)))
        nxt = [NIL] * n
        for i, v in zip(con.who, con.where):
            nxt[i] = v
        if not stepper.step(node.config, nxt, node.order, rng.randrange(1 << 20)):
            continue
        cfg = tuple(nxt)
        known = explored.get(cfg)
        if known is not None:
            open_.append(known)  # go back to it: its next constraint may lead elsewhere
            continue
        child = _Node(cfg, node, _next_priorities(node.prio, cfg, goal_cfg, tie))
        explored[cfg] = child
        open_.append(child)
    return failed(NAME, NO_SOLUTION, "every reachable configuration was explored: no plan exists",
                  explored=len(explored), loops=loops)


def _next_priorities(prio: List[float], cfg: Config, goal: Config, tie: List[float]) -> List[float]:
    return [p + 1.0 if c != g else t for p, c, g, t in zip(prio, cfg, goal, tie)]


def _backtrack(node: _Node) -> List[Config]:
    configs: List[Config] = []
    cur: Optional[_Node] = node
    while cur is not None:
        configs.append(cur.config)
        cur = cur.parent
    configs.reverse()
    return configs
