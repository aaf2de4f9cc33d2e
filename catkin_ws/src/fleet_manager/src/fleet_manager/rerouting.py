"""Rerouting in a live run (issue 28): robots a late robot holds up get new paths, the run goes on.

Theory of operation. `fleet_common.execution.reroute` says when a reroute pays
and makes one (`decide`), `handover` gives a running engine over to it; this
module is the manager's side, a state machine that starts no thread and reads
no clock:

1. in `propose` or `auto` mode, while the run runs and some robot is held up
   (`held_up`, cheap), at most once every `rule.every` plan steps and never
   while a look is in flight, a reroute proposal awaits an answer or the
   operator's replan is open, the core asks for a look: a `RerouteJob` with a
   *snapshot* of the engine (a deep copy: the loop goes on mutating the live
   one), which the manager's loop runs in a worker thread (`look`, the one
   function tests call in place);
2. the result comes back as an input (`RunCore.reroute_ready`); a result for
   a plan that is no longer run, or that comes after the mode went off, the
   run paused or a replan was opened, is dropped without a word;
3. `auto`: while the look is in flight the engine sends no new move
   (`Freeze`, for `FREEZE` plan steps at most: `freezes`; the run goes on,
   robots finish the moves they were sent, the clock runs), then the core
   hands the run over at once against the LIVE engine (`Run.reroute`) and
   thaws the engine if it is still the run's (`Thaw`); the hand-over
   re-checks the cut and refuses a plan the robots have moved away from
   since (`HandoverError`, `Cut.moved`: sent a move or given one back, gone
   out or come back; finishing a move sent at the cut is not moving away):
   the reroute is dropped with one operator line and a record, nothing
   changes.
   `propose`: the reroute is the consoles' proposal (the run does not pause);
   accept hands over as in auto, reject clears it (and no look is made for
   `REJECTED_PAUSE` plan steps), and it is dropped by itself as soon as a
   robot it reroutes moves on (`moved_since`).

A plan a replan made with cells walled off (the cell an out robot stopped
halfway into, the cells round a robot a manager restart found between cells:
`replanning`) is rerouted on that walled map (`keep_to`, until the next
replan): the engine's record puts such a robot in its cell, so a reroute on
the whole map could send a robot into, or past, where it really stands.

Scope all (`RerouteRule(scope="all")`, `--reroute-scope all`): a look is due
when some robot is late (not only held up), and the reroute gives new paths to
every robot whose remaining path changes, often most of the fleet. With 300
robots on the move some robot completes a move every few milliseconds and a
look takes about 200 ms from snapshot to hand-over through the manager, so
without the freeze some rerouted robot was always sent a move meanwhile: 0
of 34 handed over (bench/manager.py, 300 virtual robots); with it every one
(13-22 a run), and the arena's run 24 % sooner than the ADG's (bench/README.md
"Scope all through the manager"). The freeze costs a robot that completes
during a look the rest of the look before its next move; in the simulator a
look 0.26 steps long left the arena's makespan where it was. Why it is
safe: it only withholds dispatches (rule 3 of the engine, as a pause does),
never sends one, and ends when the look comes back, is given up, or at
`FREEZE` steps; a robot frozen waits in its cell, which it holds, and a
robot in the middle of a move finishes it under the same rules as ever (a
follower's hold point still moves only on its leader's poses, so a stale or
lost pose stops it short as before). A look that comes back later than
that is mostly dropped (bench/reroute_drops.py: on the lab plan a reroute
of one robot is handed over with looks answering within 1 s of fleet time
and dropped at 2 s). A dropped reroute changes nothing and the next look
starts from the run as it is then.

A snapshot costs a deep copy of the engine (its immutable action table
shared): see bench/README.md for the figure at 300 robots.
"""
from __future__ import annotations

import copy
import dataclasses
from typing import Any, Dict, Iterator, List, NamedTuple, Optional, Sequence, Tuple

from fleet_common.execution import Engine
from fleet_common.execution.cut import moved_on
from fleet_common.execution.reroute import (EVERY, FREEZE, MODES, Reroute, RerouteRule, decide, expected_steps,
                                            worth_a_look)
from fleet_common.execution.reroute_plan import Maps
from fleet_common.grid import Coord, Grid
from fleet_common.planning.deadline import Deadline

#: Plan steps without a look after the operator rejected a reroute.
REJECTED_PAUSE = 8.0

__all__ = ["Rerouting", "RerouteJob", "look", "snapshot", "moved_since", "moved_words", "held_cell", "MODES"]


class RerouteJob(NamedTuple):
    """A look for a reroute at `now` on `engine` (a snapshot, the worker's own) on `maps`."""

    id: int
    engine: Engine
    maps: Maps
    now: float
    rule: RerouteRule
    expected: List[int]
    timed: bool


def look(job: RerouteJob) -> Optional[Reroute]:
    """What the worker thread runs: a reroute that pays, or None."""
    deadline = Deadline(job.rule.budget if job.timed else None)
    return decide(job.engine, job.maps, job.now, job.rule, deadline, job.expected)


def snapshot(engine: Engine) -> Engine:
    """A copy of `engine` a worker may read while the loop goes on with the original: everything
    deep-copied but the action table and the run's lists taken from it (never changed: shared)
    and the driver's take-back (left out). The long lists of numbers are copied flat (a number is
    immutable: a shallow copy is a deep one, and ten times quicker than deepcopy's walk): 8 ms
    instead of 24 for the arena's 300 robots (bench/reroute_look.py)."""
    run = engine.run
    memo: Dict[int, Any] = {id(engine._give_back): None, id(engine.table): engine.table,
                            id(engine.show): engine.show}
    for shared in (run.first, run.step, run.agent, run.src, run.dst):
        memo[id(shared)] = shared
    for flat in (run.dep, run.succ, engine._sent_at, engine._freed_at):  # re-ordering changes dep, succ
        memo[id(flat)] = list(flat)
    return copy.deepcopy(engine, memo)


class Rerouting:
    """The mode, the look in flight and the proposal awaiting an answer, for one manager."""

    def __init__(self, grid: Grid, mode: str, ids: Iterator[int], timed: bool = True,
                 rule: Optional[RerouteRule] = None) -> None:
        if mode not in MODES:
            raise ValueError("reroute mode {!r}; modes: {}".format(mode, ", ".join(MODES)))
        self.mode = mode
        self.rule = rule or RerouteRule()
        self.timed = timed
        self.maps = Maps(grid)
        self._ids = ids  # shared with the replans' jobs: a proposal's id is never a replan's
        self.job: Optional[RerouteJob] = None
        self._for: Optional[Engine] = None  # the live engine the look in flight was taken of
        #: a reroute proposed to the operator (propose mode), by id
        self.pending: Optional[Tuple[int, Reroute]] = None
        self._next: Tuple[object, float] = (None, 0.0)  # (run, plan step from which to look again)
        self._expected: Tuple[object, List[int]] = (None, [])
        #: looks asked for, reroutes found, handed over, dropped (stale)
        self.looks = self.found = self.done = self.dropped = 0

    @property
    def proposal_id(self) -> Optional[int]:
        return None if self.pending is None else self.pending[0]

    def set_mode(self, mode: str) -> None:
        """A mode from MODES (checked by the caller): off or auto forget a proposal; off also
        forgets the look in flight (its result is dropped)."""
        self.mode = mode
        if mode != "propose":
            self.pending = None
        if mode == "off":
            self.job = self._for = None

    def keep_to(self, grid: Grid) -> None:
        """Plan reroutes on `grid` from now on: the map a new plan was made on, with the cells it
        was walled off from (`replanning`), so that no reroute of it sends a robot there."""
        if grid is not self.maps.grid:
            self.maps = Maps(grid)

    def set_scope(self, scope: str) -> None:
        """A scope from SCOPES (checked by the caller): the rule's other settings stay, its pace
        becomes the new scope's own unless it was set apart from the old scope's. A look in flight
        or a proposal of the old scope stays: its plan is handed over as any other."""
        rule = self.rule
        every = None if rule.every == EVERY[rule.scope] else rule.every
        self.rule = dataclasses.replace(rule, scope=scope, every=every)

    def set_trim(self, trim: bool) -> None:
        """Whether a held-scope reroute's plan is trimmed before its hand-over (`RerouteRule.trim`;
        scope all's always is); a look in flight or a proposal made before stays as it was made."""
        self.rule = dataclasses.replace(self.rule, trim=trim)

    def due(self, engine: Engine, now: float) -> bool:
        """Time for a look (paced by `rule.every` plan steps of this plan) and some robot held up
        (scope all: some robot late)."""
        if self.mode == "off" or self.job is not None or self.pending is not None or engine.paused:
            return False
        run = engine.run
        steps = run.clock.steps(now)
        if self._next[0] is not run:
            self._next = (run, self.rule.pace)  # a new plan: look a while after its start
        if steps < self._next[1] or self.on_walls(engine):  # (then looked for once it has moved off)
            return False
        self._next = (run, steps + self.rule.pace)
        return worth_a_look(engine, now, self.rule, self.expected(engine))

    def on_walls(self, engine: Engine) -> bool:
        """Whether a robot still stands on a cell this plan's map walls off: a replan has a robot
        finish its move out of a cell first and walls that cell off for one leaning into it
        (`replanning.walled`); a reroute from now would have it start on a wall, and be refused as
        invalid (narrow session 1779). Its first move is made at once."""
        grid = self.maps.grid
        return any(not grid.is_free(tuple(held_cell(engine, r))) for r in range(engine.run.num_agents))

    def expected(self, engine: Engine) -> List[int]:
        """The engine's `expected_steps`, computed once per plan."""
        if self._expected[0] is not engine.run:
            self._expected = (engine.run, expected_steps(engine))
        return self._expected[1]

    def ask(self, engine: Engine, now: float) -> RerouteJob:
        """The look to run now, on a snapshot of `engine`."""
        self.job = RerouteJob(next(self._ids), snapshot(engine), self.maps, now, self.rule,
                              self.expected(engine), self.timed)
        self._for = engine
        self.looks += 1
        return self.job

    def freezes(self, engine: Engine, now: float) -> bool:
        """Whether the look in flight keeps new moves back on `engine` now: in auto mode, for at
        most `FREEZE` plan steps from its start (a look that takes longer is not waited for)."""
        job = self.job
        return (job is not None and self._for is engine and self.mode == "auto"
                and now - job.now < FREEZE * engine.run.clock.step_time)

    def finished(self, job_id: int, engine: Engine) -> bool:
        """The look `job_id` came back: True if it is the one in flight, taken of `engine` (the
        live engine now); False (forget it) for a look given up or of a plan no longer run."""
        if self.job is None or self.job.id != job_id:
            return False
        mine = self._for is engine
        self.job = self._for = None
        return mine

    def propose(self, found: Reroute) -> int:
        """`found` awaits the operator (propose mode); its proposal id."""
        pid = next(self._ids)
        self.pending = (pid, found)
        return pid

    def resolved(self) -> None:
        self.pending = None

    def rejected(self, engine: Engine, now: float) -> None:
        """The operator said no: no new proposal for `REJECTED_PAUSE` plan steps (the same robots
        would most likely be proposed again at once)."""
        self.pending = None
        self._next = (engine.run, engine.run.clock.steps(now) + REJECTED_PAUSE)


def moved_since(engine: Engine, found: Reroute) -> List[int]:
    """Robots of `found` that moved away from its cut (`moved_on`: sent a move since, or gave one
    back), and robots that went out or came back: the hand-over would refuse it (a cheap look at
    the robots rerouted, for every tick)."""
    run, cut = engine.run, found.cut
    moved = [r for r in found.agents
             if moved_on(cut, r, run.completed[r], run.dispatched[r] - run.completed[r],
                         run.started[r] > run.completed[r])]
    return moved + [r for r in range(cut.num_agents) if run.out[r] != cut.out[r] and r not in moved]


def moved_words(moved: Sequence[int], ids: Sequence[int]) -> str:
    """"robots 3, 7 moved", by robot id."""
    return "robot{} {} moved".format("s" if len(moved) > 1 else "", ", ".join(str(ids[a]) for a in moved))

def held_cell(engine: Engine, agent: int) -> Coord:
    """The cell `agent` holds on `engine`: its last completed action's target (its start before)."""
    run = engine.run
    done = run.completed[agent]
    if done == 0:
        return engine.table.start(agent)
    return engine.table.coord(run.dst[run.first[agent] + done - 1])
