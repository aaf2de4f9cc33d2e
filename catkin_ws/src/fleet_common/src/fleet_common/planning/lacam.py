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

Anytime (LaCAM*, Okumura IJCAI 2023), with `anytime=True`: the search goes on
after the first plan until the deadline. Every configuration remembers the
configurations it has led to and its cost from the start (the sum of loss:
per step, the agents that are not resting on their goals); when a known
configuration is reached again more cheaply, the cheaper parents spread
through those links (a Dijkstra relaxation), a node whose cost plus its
sum of distances cannot beat the best plan is not expanded, and now and then
the search dives again from the start. The best plan
only improves; when nothing is left to expand it is optimal for the sum of
loss. `stats["anytime"]` lists (milliseconds, soc) at each improvement.

Memory. Every configuration reached is kept (packed, see `Config`), so the
search stops at a memory limit as at its deadline (`memory_limit`), keeping
its best plan.
"""
from __future__ import annotations

import heapq
import random
import time
from array import array
from typing import Dict, List, Optional, Sequence, Tuple

import numpy as np

from ..grid import Coord, Grid
from .cells import NIL
from .deadline import Deadline
from .memory_limit import MemoryLimit
from .pibt import tie_ranks
from .pibt_step import PIBTStep
from .result import NO_SOLUTION, TIMEOUT, SolveResult, failed, solved

NAME = "lacam"
#: After the first plan, the chance per iteration of diving again from the start (as LaCAM*'s code).
RESTART_RATE = 0.001
#: A configuration, packed: per agent its free-cell id as uint16 (uint32 on maps of more cells), as
#: bytes. The search keeps every configuration it reaches, so their size is LaCAM*'s memory; bytes
#: also hash once, where a tuple hashes every entry at each lookup.
Config = bytes


class _Constraint:
    """Low-level node: agent `who` is sent to cell `where`, and so are those of `up` (its parent).

    Linked to the parent rather than copying its lists: a constraint at depth d then costs
    one object, not two tuples of d entries."""

    __slots__ = ("up", "who", "where", "depth")

    def __init__(self, up: "Optional[_Constraint]" = None, who: int = -1, where: int = -1) -> None:
        self.up = up
        self.who = who
        self.where = where
        self.depth = 0 if up is None else up.depth + 1

    def apply(self, nxt: List[int]) -> None:
        """Fix in `nxt` the cells of this constraint and of its ancestors (the root fixes none)."""
        con: Optional[_Constraint] = self
        while con is not None and con.up is not None:
            nxt[con.who] = con.where
            con = con.up


#: The empty constraint every node's tree starts from (constraints are never changed).
_ROOT = _Constraint()


class _Node:
    """High-level node: a configuration, its cheapest known parent and cost, its constraint tree."""

    __slots__ = ("config", "parent", "steps", "order", "tree", "next", "g", "h", "links")

    def __init__(self, config: Config, parent: "Optional[_Node]", steps: np.ndarray, order: np.ndarray,
                 g: int, h: int) -> None:
        self.config = config
        self.parent = parent
        #: per agent, steps since it was last at its goal: its priority (ties by rank, see `lacam`)
        self.steps = steps
        #: the agents by priority, highest first (the depth order of the constraint tree)
        self.order = order
        #: the constraints in breadth-first order, `tree[next]` the next to try: a list and an
        #: index, not a deque (whose first block alone is 624 bytes; the tried ones are kept alive
        #: by their children's `up` anyway)
        self.tree: List[_Constraint] = [_ROOT]
        self.next = 0
        self.g = g
        self.h = h
        #: configurations reached from this one, with the cost of that step (anytime only)
        self.links: Dict["_Node", int] = {}


def lacam(grid: Grid, starts: Sequence[Coord], goals: Sequence[Coord], deadline: Deadline,
          seed: int = 0, rotations: bool = False, anytime: bool = False,
          memory_limit_mb: Optional[float] = None) -> SolveResult:
    """Search until a plan is found (or, `anytime`, the deadline), every configuration is exhausted.

    The search also stops, as at its deadline, when the process's resident memory reaches
    `memory_limit_mb` (default: half the memory it may use, see `memory_limit`); the best
    plan so far is returned, and `stats["stopped"]` says "memory"."""
    began = time.perf_counter()
    memory = MemoryLimit(memory_limit_mb)
    rng = random.Random(seed)
    n = len(starts)
    stepper = PIBTStep(grid, goals, rotations=rotations)
    packing = _Packing(stepper.free.count, n, stepper.goals)
    goal_cfg = packing.pack(stepper.goals)
    start_ids = stepper.to_ids(starts)
    start_cfg = packing.pack(start_ids)
    # priorities as PIBT's (`pibt`): steps since the goal x n + a rank, all distinct
    rank = np.asarray(tie_ranks(stepper, start_ids, rng), dtype=np.int64)
    dist = stepper.dist

    def h_of(cfg: Config) -> int:  # sum of distances: no plan from cfg has a smaller loss
        return sum(dist[i][v] for i, v in enumerate(packing.ids(cfg))) if anytime else 0

    def loss(a: Config, b: Config) -> int:  # agents not resting on their goals during the step
        return int(np.count_nonzero(packing.away(a) | packing.away(b))) if anytime else 0

    def make_node(cfg: Config, parent: Optional[_Node], steps: np.ndarray, g: int) -> _Node:
        order = np.argsort(-(steps.astype(np.int64) * n + rank)).astype(packing.agent_type)
        return _Node(cfg, parent, steps, order, g, h_of(cfg))

    root = make_node(start_cfg, None, np.zeros(n, dtype=np.uint32), 0)
    open_: List[_Node] = [root]
    explored: Dict[Config, _Node] = {start_cfg: root}
    moves = stepper.moves
    loops = 0
    best: Optional[_Node] = None
    best_g = 0
    history: List[Tuple[float, int]] = []

    def improved() -> None:
        nonlocal best_g
        best_g = best.g  # type: ignore[union-attr]
        history.append((round((time.perf_counter() - began) * 1000.0, 1), _soc(packing, _backtrack(best))))

    stopped = ""
    while open_:
        loops += 1
        if loops & 63 == 0:
            if deadline.expired():
                stopped = "time"
                break
            if memory.reached():  # every configuration is kept: the OOM killer would lose the plan
                stopped = "memory"
                break
        node = open_[-1]
        if best is None and node.config == goal_cfg:
            best = node
            improved()
            if not anytime:
                break
        if best is not None and best.g < best_g:
            improved()
        if best is not None and rng.random() < RESTART_RATE:
            open_.append(root)  # LaCAM*'s random restart: dive again from the start
        if best is not None and node.g + node.h >= best.g:
            open_.pop()  # cannot lead to a cheaper plan
            continue
        if node.next == len(node.tree):
            open_.pop()
            continue
        con = node.tree[node.next]
        node.next += 1
        here = packing.ids(node.config)
        if con.depth < n:  # grow the constraint tree one agent deeper, lazily
            i = int(node.order[con.depth])
            cells = list(moves[here[i]])
            rng.shuffle(cells)
            for v in cells:
                node.tree.append(_Constraint(con, i, v))
        nxt = [NIL] * n
        con.apply(nxt)
        if not stepper.step(here, nxt, node.order, rng.randrange(1 << 20)):
            continue
        cfg = packing.pack(nxt)
        known = explored.get(cfg)
        if known is not None:
            if anytime and known not in node.links:
                node.links[known] = loss(node.config, cfg)
                _relax(node)
            open_.append(known)  # go back to it: its next constraint may lead elsewhere
            continue
        steps = np.where(packing.away(cfg), node.steps + 1, 0).astype(np.uint32)
        child = make_node(cfg, node, steps, node.g + loss(node.config, cfg))
        if anytime:
            node.links[child] = child.g - node.g
        explored[cfg] = child
        open_.append(child)
    stats: Dict[str, object] = dict(explored=len(explored), loops=loops, undone_rotations=stepper.reverted)
    if stopped == "memory":
        stats.update(stopped="memory", memory_limit_mb=memory.limit_mb)
    if best is not None:
        if best.g < best_g:
            improved()
        if anytime:
            stats["anytime"] = history
            stats["optimal_loss"] = not open_
        return solved(stepper.plan(packing.unpack(_backtrack(best))), NAME, **stats)
    if stopped == "memory":
        return failed(NAME, TIMEOUT, "memory limit of {:.0f} MB reached after {} configurations".format(
            memory.limit_mb, len(explored)), **stats)
    if open_:
        return failed(NAME, TIMEOUT, "time limit reached after {} configurations".format(len(explored)), **stats)
    return failed(NAME, NO_SOLUTION, "every reachable configuration was explored: no plan exists", **stats)


class _Packing:
    """How configurations are packed (`Config`), for `cells` free cells and `n` agents."""

    def __init__(self, cells: int, n: int, goals: Sequence[int]) -> None:
        self.cell_type = np.dtype(np.uint16 if cells <= 0xFFFF else np.uint32)
        self.code = self.cell_type.char  # the same width for array and memoryview: "H" or "I"
        #: the agents' numbers in a node's `order` (the C step reads it in place)
        self.agent_type = np.uint16 if n <= 0xFFFF else np.uint32
        self.n = n
        self.goals = np.asarray(goals, dtype=self.cell_type)

    def pack(self, ids: Sequence[int]) -> Config:
        return array(self.code, ids).tobytes()

    def ids(self, cfg: Config) -> memoryview:
        """The free-cell ids of `cfg`, in place (indexable, iterable; the C step reads it as a buffer)."""
        return memoryview(cfg).cast(self.code)

    def away(self, cfg: Config) -> np.ndarray:
        """Per agent, whether it is off its goal in `cfg`."""
        return np.frombuffer(cfg, dtype=self.cell_type) != self.goals

    def unpack(self, configs: List[Config]) -> np.ndarray:
        """Configurations as rows of free-cell ids."""
        return np.frombuffer(b"".join(configs), dtype=self.cell_type).reshape(len(configs), self.n)


def _relax(start: _Node) -> None:
    """Spread a cheaper cost from `start` through the links (Dijkstra)."""
    heap: List[Tuple[int, int, _Node]] = []
    count = 0
    for b, cost in start.links.items():
        if start.g + cost < b.g:
            b.g, b.parent = start.g + cost, start
            count += 1
            heapq.heappush(heap, (b.g, count, b))
    while heap:
        g, _, a = heapq.heappop(heap)
        if g > a.g:
            continue  # improved again since it was queued
        for b, cost in a.links.items():
            if g + cost < b.g:
                b.g, b.parent = g + cost, a
                count += 1
                heapq.heappush(heap, (b.g, count, b))


def _backtrack(node: _Node) -> List[Config]:
    configs: List[Config] = []
    cur: Optional[_Node] = node
    while cur is not None:
        configs.append(cur.config)
        cur = cur.parent
    configs.reverse()
    return configs


def _soc(packing: _Packing, configs: List[Config]) -> int:
    """mapf-IR's sum of costs: per agent, the step from which it stays at its goal."""
    away = packing.unpack(configs) != packing.goals
    steps = away.shape[0]
    last = steps - np.argmax(away[::-1], axis=0)  # one past the last step away from the goal
    return int(np.where(away.any(axis=0), last, 0).sum())
