"""PIBT for robots that turn in place: a quarter turn takes a step, as a move does.

Why. The other solvers plan cells only, so a robot that must turn in place before
each change of direction cannot run their plans as planned: on the arena, the robot
that sets PIBT's makespan drives 80 cells and turns 40 quarters with no step to wait
in, so no executor brings it in under 1.25 of the plan (`slowest_need`; virtual
robots: 2 s a cell, 1.05 s a quarter turn). Here every agent faces one of four ways,
and a step either drives it one cell straight ahead, turns it a quarter in place, or
waits; the plan counts its turns, and has fewer, since a turn costs a step.

How (the scheme of PIBT entries to the League of Robot Runners, 2023). Each step
PIBT picks every agent's next cell as usual, breaking ties between cells equally
nearer the goal by the fewest quarter turns from the agent's heading. Ties among
cells no nearer stay random: an agent pushed out of the way that kept straight on
would be pushed along a line by the agent behind it instead of stepping aside (one
agent made 100 moves for a distance of 18 so). Then an agent whose next cell is not
straight ahead turns a quarter towards it instead, and stays. An agent whose next
cell is the cell of an agent that stays stays too, and so on down the chain. Only
moves are taken back, so no swap or rotation appears, and the only cell that could
be entered twice is a stayer's, which the chain keeps its mover out of: the step
stays valid. Incomplete like PIBT, stopped at `max_timestep`.

The plan is an ordinary mapf-IR plan: a turn is a step in which the agent stays in
its cell, so every executor runs it; the ADG, which keeps no waits, lets a robot whose
turn is quicker than a move run ahead of it. Headings are quarters counter-clockwise
from +x in the base frame (`headings`, radians, as robots report them; default +x,
where the virtual fleet starts its robots). The Python step only, since the C step
does not know headings: about 0.1 s for the arena's 300 agents, 9 s for
brc202d's 1,500.
"""
from __future__ import annotations

import math
from typing import Dict, List, Optional, Sequence, Tuple

from ..formats.instance import DEFAULT_MAX_TIMESTEP
from ..grid import Coord, Grid
from ..plan import Plan
from .cells import NIL
from .deadline import Deadline
from .pibt import run_steps
from .pibt_step import PIBTStep
from .result import SolveResult, solved

NAME = "pibt-turns"

#: A cell step's quarter: 0 +x, 1 +y, 2 -x, 3 -y (counter-clockwise, as headings).
_QUARTER: Dict[Tuple[int, int], int] = {(1, 0): 0, (0, 1): 1, (-1, 0): 2, (0, -1): 3}


def quarter(heading: float) -> int:
    """The nearest of the four ways to a heading in radians."""
    return int(round(heading / (math.pi / 2))) % 4


def quarters_between(a: int, b: int) -> int:
    """Quarter turns from way a to way b (0, 1 or 2)."""
    d = (b - a) % 4
    return min(d, 4 - d)


class TurningStep(PIBTStep):
    """PIBT steps for agents with headings (`heading[i]`, a quarter) that turn a quarter a step."""

    def __init__(self, grid: Grid, goals: Sequence[Coord], headings: Sequence[int],
                 rotations: bool = False) -> None:
        super().__init__(grid, goals, rotations=rotations, native=False)
        width = grid.width
        self.xy = [(int(c) % width, int(c) // width) for c in self.free.ids]
        self.heading = list(headings)
        self.quarter_turns = 0

    def way(self, a: int, b: int) -> int:
        """The quarter of the step from free cell a to its neighbour b."""
        (x0, y0), (x1, y1) = self.xy[a], self.xy[b]
        return _QUARTER[(x1 - x0, y1 - y0)]

    def _open(self, i: int, q_from: Sequence[int], q_to: List[int], salt: int) -> Tuple[List[int], int]:
        here, h, dist = q_from[i], self.heading[i], self.dist[i]
        moves = self.turns[here]
        ties = moves[(salt + i) % len(moves)]
        nearer = dist[here]

        def turns(v: int) -> int:  # only moves towards the goal prefer straight ahead (see above)
            return quarters_between(h, self.way(here, v)) if dist[v] < nearer else 0
        cands = sorted(ties, key=lambda v: (dist[v], turns(v)))
        partner = self._swap_partner(i, cands[0], q_from, q_to) if self.swap else NIL
        if partner != NIL:
            # leading a swap: farthest first, and still the fewest turns among equals (the reversed
            # list would put the most turns first: two agents, each on the other's goal, then
            # turned back and forth for ever)
            cands = sorted(ties, key=lambda v: (-dist[v], turns(v)))
        return cands, partner

    def turn(self, q_from: Sequence[int], q_to: List[int]) -> None:
        """Make the step one of robots: an agent not facing its next cell turns a quarter towards it
        and stays; an agent entering the cell of one that stays stays too."""
        staying = []
        for i, (a, b) in enumerate(zip(q_from, q_to)):
            if a == b:
                continue
            w, h = self.way(a, b), self.heading[i]
            if w != h:
                self.heading[i] = (h + (3 if (w - h) % 4 == 3 else 1)) % 4
                self.quarter_turns += 1
                q_to[i] = a
                staying.append(i)
        entering = {b: i for i, (a, b) in enumerate(zip(q_from, q_to)) if a != b}
        while staying:
            j = entering.pop(q_from[staying.pop()], NIL)
            if j != NIL:
                q_to[j] = q_from[j]
                staying.append(j)
        for i, (a, b) in enumerate(zip(q_from, q_to)):
            if a != b:
                self.heading[i] = self.way(a, b)


def path_moves_and_turns(cells: Sequence[Coord], facing: Optional[int] = None) -> Tuple[int, int]:
    """Moves and quarter turns along a path of neighbouring cells (waits allowed): 1 at a corner, 2
    back the way it came; the first move turns from way `facing` (a quarter), or is free (None)."""
    moves = turns = 0
    for (x0, y0), (x1, y1) in zip(cells, cells[1:]):
        if (x0, y0) != (x1, y1):
            way = _QUARTER[(x1 - x0, y1 - y0)]
            moves += 1
            turns += 0 if facing is None else quarters_between(facing, way)
            facing = way
    return moves, turns


def moves_and_turns(plan: Plan, headings: Optional[Sequence[float]] = None) -> List[Tuple[int, int]]:
    """Per agent, the moves and quarter turns its path asks of a robot starting at its heading
    (radians; default +x): what it needs at least, whatever the executor."""
    pos = plan.positions
    return [path_moves_and_turns([tuple(c) for c in pos[:, a].tolist()],
                                 quarter(headings[a]) if headings is not None else 0)
            for a in range(plan.num_agents)]


def slowest_need(counts: Sequence[Tuple[int, int]], quarter_of_a_move: float) -> float:
    """The most time one robot needs for its own moves and turns (`moves_and_turns`), in moves (a
    quarter turn taking `quarter_of_a_move`): no executor brings the plan in sooner."""
    return max((m + q * quarter_of_a_move for m, q in counts), default=0.0)


def pibt_turns(grid: Grid, starts: Sequence[Coord], goals: Sequence[Coord], deadline: Deadline,
               seed: int = 0, max_timestep: int = DEFAULT_MAX_TIMESTEP, rotations: bool = False,
               headings: Optional[Sequence[float]] = None) -> SolveResult:
    """PIBT whose agents face a way and turn a quarter a step (`headings`: radians, default +x)."""
    if [tuple(c) for c in starts] == [tuple(c) for c in goals]:
        return solved(Plan.from_paths([[c] for c in starts]), NAME, timesteps=0)
    ways = [quarter(h) for h in headings] if headings is not None else [0] * len(starts)
    if len(ways) != len(starts):
        raise ValueError("{} headings for {} agents".format(len(ways), len(starts)))
    stepper = TurningStep(grid, goals, ways, rotations=rotations)
    result = run_steps(stepper, starts, deadline, seed, max_timestep, NAME, after=stepper.turn)
    result.stats["quarter_turns"] = stepper.quarter_turns
    return result
