"""Replanning when it pays: new paths for robots a late robot holds up, while the others go on.

No re-ordering helps a robot that waits outside its goal for a late robot
that must still pass through it, nor one queued behind a late robot in a
corridor: one of them needs a new path. This module decides when one pays,
and makes it; `handover` gives the run over to the new plan without stopping
anyone. Pure: values in (an engine, its grid, the time), a plan out.

Who. A robot waits for the cell it enters (`Engine.waiting`, reason CELL) for
the robot that must leave it first; that one may wait for another, or follow
one. A robot is *held up* when that chain reaches a *late* robot: one that is
out, or that is both behind the plan's clock (`RunState.clock`) by `gap`
steps or more, measured against the step a run without delays would start
its next move (`expected_steps`), and delayed itself (its own moves took it
half a step or more longer than nominal, `Metrics.own_delay`). So a run
without delays never has a late robot and never reroutes, whatever the
strategy or the robots' size.

The rule ("it pays"), for each late robot L and the robots H it holds up
(the `tries` late robots holding up the most first), trying to reroute L
alone (the robot waiting outside its goal goes in, L goes round), those of H
that could arrive sooner by a shortest path, or both:

1. predict the rest of the run as it stands (`forecast`: every move as soon
   as the dependency graph allows, each cell's order kept, L standing still
   as long again as it has stood with its move sent);
2. plan the chosen robots anew around the others (`reroute_plan`), and
   predict the run on that plan the same way;
3. gain = predicted arrival steps saved, summed over all robots, less
   `per_move` (a move's expected delay) for each move the new paths add;
   it *pays* when gain - `cost` x (robots rerouted) >= `margin` steps and no
   robot is predicted to arrive later by more than `later` steps (extra
   moves counted, `per_move` each), except robots whose new predicted
   arrival (extra moves counted) is still `slack` steps or more before
   the predicted makespan of step 1: the run's makespan is the last robot's
   arrival, so a robot well before it may give way (a late robot stepping
   aside for those it holds up, on a longer path) when the sum gains. The
   variant with the largest net gain is taken. By default: late from 1
   step, a robot rerouted costs half a step, the net gain must reach 1
   step, and nobody predicted to arrive less than 5 steps before the
   makespan may be more than 1 step later (`slack=None`: nobody at all,
   the rule before the slack).

A look, once some robot is held up, also tries one more variant: the
robots predicted within `critical` steps (3) of the makespan that a
shortest way would bring in sooner, held up or not, while no robot is out
(`critical=None`: not tried, the rule before 2026-11-26). The makespan is
their arrival, and a plan may have them wind (LaCAM's random-32-32-20 plan has a robot make 35
moves where 13 would do); the same rule decides whether it pays.

Scope. `RerouteRule.scope` says whom a reroute may give new paths: "held"
(the default: the rule above) or "all": every robot replanned from the cut
by PIBT when the predicted makespan drops by `margin` steps
(`reroute_all`, its docstring says how and why it is safe); `decide`
dispatches on it and both return a `Reroute` for the same hand-over.

Trimmed. Scope all's plan always has its robots trimmed of the moves that do
not bring them in sooner (`trim_cut`, `planning.trim`: the fewest moves that
arrive no later, around everyone else), before it is judged, so the plan judged
is the plan handed over; the held scope's only with `RerouteRule.trim`. Each
robot keeps its moves sent, and the cell a move sent enters stays reserved until
its robot is in. A replan of every robot by PIBT winds as LaCAM's plans do, and
every move is a chance of delay: trimmed, scope all went from -15.4 % to -20.4 %
against the ADG on random-32-32-20 (seeds 0-29; -21.0 % over 90 seeds; -22.7 %
on the arena; bench/README.md, "Scope all trims its replans"). Scope all's
reroutes trimmed, the plan given need not be (`simulate(trim=)`, `--trim`): the
run at p = 0 stays the ADG's exactly. The held scope gains nothing from it
(its reroutes are quickest paths already).

The rule (`slack` included) only chooses which plan to hand over; the
hand-over's safety below does not depend on it: any plan from the cut that
`reroute_plan` builds and `Engine.adopt` accepts runs as safely.

Why a hand-over is safe (`handover`, `Engine.adopt`). A plan is only a
prediction: what keeps the run safe is the engine's one rule, unchanged
(nobody enters a cell before the previous visitor's move out of it is
released: completed, or for robots of real size dispatched, the follower
then held at the safe distance behind its leader).

- Moves in flight finish: nothing sent is taken back. Every robot's moves
  sent and not completed at the cut are exactly its first moves in the new
  plan (a follower that completed its move into a cell its leader has not
  finished leaving makes that move again in the new plan, done already:
  `cut.Cut.base`), so the new engine knows them as dispatched and their
  completions arrive as the new plan's moves.
- The new plan holds every cell a move in flight enters for that robot
  until it is in (`reroute_plan`: its target is reserved from the cut), so
  in the new plan's dependency graph no move sent waits for a move not sent;
  `Engine.adopt` checks exactly that and refuses the plan otherwise (as the
  plan's validation and the graph's own conflict checks refuse a plan with
  two robots in a cell).
- Followers keep their leader: a follower in flight keeps, in the new
  graph, its dependency on the leader's move out of the cell (the same move
  in both plans), so the driver goes on holding it behind that leader.
- A robot that failed in the middle of a move stands between two cells
  until that move, sent again when it is enabled, is made
  (`RunState.halfway`). Out or enabled again, it is never given a new path,
  and the cell that move enters stays reserved for it until it is in
  (`reroute_plan._hold_targets`). A new path from its cell would have it
  drive from where it stands, across a cell nobody reserved for it.
- No reroute is looked for while a robot waits, in a move made again from
  the cut, for a move its leader took back (`cut.behind_taken_back`): no
  plan from that cut fits, and the hand-over would refuse every one. A
  robot sent a move behind a move taken back keeps its path: when its move
  comes hangs on the robot out, which a plan from the cut cannot know.

With a live fleet (`fleet_manager.rerouting`: the look runs in the manager's
worker thread, on a snapshot of the engine, while the loop goes on; the
hand-over runs in the loop, against the live engine) poses are stale, and
the look's result may be too. The cut is taken from the engine's events,
never from poses: a robot only moves on moves it was sent, so wherever a late
pose shows it, it is between the cell of its last completed move and the
target of its last move sent, all of which the new plan keeps for it; a
rerouted robot would go from that target along its new path. If by the
hand-over the rerouted robots' progress differs from the cut, or a robot
went out or came back, the plan is dropped (`HandoverError`: the manager
says "reroute dropped: ..." and records it; a proposal awaiting the operator
is dropped as soon as a robot it reroutes moves on); a completion that
arrives after the hand-over is one of the moves in flight, counted in the
new plan (the manager renumbers what its robots were sent by the cut's base). A follower's hold point comes from its leader's last pose,
which is never ahead of the leader: a stale pose stops it earlier, never
later.

Cost: two predictions (a pass over the incomplete moves each) and one
space-time A* per robot rerouted, per variant tried, within `budget` seconds
(`Deadline`); the driver asks at most once every `every` plan steps (the
manager: only while some robot is held up, one look in flight at a time).
"""
from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass
from typing import Callable, Dict, List, Optional, Sequence, Tuple

from ..errors import FleetError
from ..grid import Grid
from ..planning.deadline import Deadline
from ..planning.st_astar import DeadlineReached
from ..validate import validate_plan
from .cut import behind_taken_back, cut_of
from .engine import Engine
from .errors import UnknownStrategyError
from .forecast import earliest_starts, ready_steps, unplaced
from .reroute_plan import Maps, Proposal, Reroute, new_start, plan_around
from .lateness import behind, delayed, expected_steps, held_up, late_robots
from .reroute_all import replan
from .trim_cut import trim_from_cut

__all__ = ["MODES", "SCOPES", "EVERY", "FREEZE", "RerouteError", "RerouteRule", "Reroute", "expected_steps", "behind",
           "delayed", "held_up", "worth_a_look", "later_by", "decide", "way_home", "Rerouter"]

#: What `--reroute` accepts: never, ask the operator (the manager), or reroute at once.
MODES = ("off", "propose", "auto")


class RerouteError(FleetError):
    """A reroute's plan that is not valid: a defect of this module, never the run's fault."""


#: What `--reroute-scope` accepts: whom a reroute may give new paths: the robots a late robot
#: holds up (or the late one; this module's rule, the default), or every robot (`reroute_all`).
SCOPES = ("held", "all")

#: Plan steps between looks when `RerouteRule.every` is not given, per scope (chosen on
#: bench/reroute.py's and bench/replan_all.py's tuning seeds).
EVERY = {"held": 1.0, "all": 2.0}

#: Plan steps at most that a look in flight keeps new moves back (`Freeze`, a live run in auto
#: mode: `fleet_manager.rerouting`, and `Rerouter.lag` in the simulator). A robot sent a move
#: during the look would leave the cut behind and drop the plan (`Cut.moved`); at 300 robots one
#: always is. A look takes about 70 ms there, 0.03 of a 2.5 s step; a longer one is not waited for.
FREEZE = 0.5


@dataclass(frozen=True)
class RerouteRule:
    """The rule's settings (steps are plan steps, one nominal move each). The defaults were
    chosen on bench/reroute.py's plans (random70 seeds 0-9, arena300 seeds 0-3) among eight
    settings, `slack` later among some twenty variants (random70 seeds 0-9, arena300 seeds
    0-9); the figures in bench/README.md are on other seeds. Scope "all" (`reroute_all`) uses
    `gap`, `margin` (on the predicted makespan), `every`, `budget` and `clear`; its settings
    were chosen on bench/replan_all.py's arena300 seeds 0-3."""

    gap: int = 1            # late: this many steps behind the plan's clock, or more
    margin: float = 1.0     # reroute when the gain, less the cost, reaches this many steps
    cost: float = 0.5       # charged per robot given a new path
    every: Optional[float] = None  # a driver looks at most once per this many steps (None: EVERY[scope])
    budget: float = 0.25    # seconds of search per look
    tries: int = 3          # late robots looked at per look, the most robots held up first
    later: float = 1.0      # no robot's predicted arrival may be later by more than this
    per_move: float = 0.3   # expected delay of a move (steps), charged for each move more
    #: steps a quarter turn takes (robots that turn in place before a drive: the manager's, half a
    #: move for a TurtleBot), charged for each quarter turn more; 0: the simulator's robots, which
    #: do not turn
    per_turn: float = 0.0
    slack: Optional[float] = 5.0  # `later` spares robots predicted this many steps or more before the makespan
    scope: str = "held"     # whom a reroute may give new paths (SCOPES)
    clear: Optional[float] = 20.0  # scope all: robots predicted this near the last arrival steered into free cells
    #: held scope: a look also tries new shortest paths for the robots predicted this near the
    #: makespan that one would bring in sooner, held up or not (None: only held-up robots; chosen
    #: on random70 seeds 0-29, bench/README.md "The robots predicted last")
    critical: Optional[float] = 3.0
    #: held scope: the plan found has the robots it reroutes trimmed of moves that do not bring
    #: them in sooner before it is handed over (`planning.trim`; off: the plan as the look made
    #: it); scope all trims its plan whatever this says
    trim: bool = False

    def __post_init__(self) -> None:
        if not isinstance(self.trim, bool):
            raise UnknownStrategyError("reroute trim must be true or false, got {!r}".format(self.trim))
        if self.scope not in SCOPES:
            raise UnknownStrategyError("reroute scope must be one of {}, got {!r}".format(", ".join(SCOPES),
                                                                                       self.scope))
        if self.every is None:  # frozen: set once, here
            object.__setattr__(self, "every", EVERY[self.scope])
        for key in ("gap", "tries"):
            value = getattr(self, key)
            if isinstance(value, bool) or not isinstance(value, int) or value < 1:
                raise UnknownStrategyError("reroute {} must be a whole number >= 1, got {!r}".format(key, value))
        for key in ("margin", "cost", "every", "budget", "later", "per_move", "per_turn", "slack", "clear",
                    "critical"):
            value = getattr(self, key)
            if key in ("slack", "clear", "critical") and value is None:  # None: see the field
                continue
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not value >= 0:
                raise UnknownStrategyError("reroute {} must be a number >= 0, got {!r}".format(key, value))

    @property
    def pace(self) -> float:
        """`every`, set (plan steps between looks)."""
        return EVERY[self.scope] if self.every is None else self.every


def worth_a_look(engine: Engine, now: float, rule: RerouteRule, expected: Sequence[int]) -> bool:
    """Whether `decide` could find anything now (cheap): some robot held up by a late one (scope
    held), or some robot late (scope all)."""
    if rule.scope == "all":
        return bool(late_robots(engine, now, rule.gap, expected))
    return bool(held_up(engine, now, rule.gap, expected))


def later_by(before: Sequence[int], proposal: Proposal, per_move: float, spared: Optional[float],
             per_turn: float = 0.0) -> float:
    """How many steps later than `before` the proposal has the latest robot arrive, a move more
    counted as `per_move` steps more, a quarter turn more as `per_turn`; robots whose new arrival
    is still at or before `spared` (None: none) are not counted (at most 0)."""
    worst = 0.0
    for r, (new, old) in enumerate(zip(proposal.arrival, before)):
        extra = per_move * proposal.more.get(r, 0) + per_turn * proposal.turns.get(r, 0)
        if spared is None or new + extra > spared:
            worst = max(worst, new - old + extra)
    return worst


def decide(engine: Engine, maps: Maps, now: float, rule: RerouteRule,
           deadline: Optional[Deadline] = None, expected: Optional[Sequence[int]] = None) -> Optional[Reroute]:
    """A reroute that pays now, by `rule`, or None (see the module docstring); `expected`: the
    engine's `expected_steps`, if known."""
    if expected is None:
        expected = expected_steps(engine)
    deadline = deadline or Deadline(rule.budget)
    # trimming has a budget of its own: the look's may be spent by then
    trim = Deadline(rule.budget if deadline.seconds is not None else None)
    if rule.scope == "all":  # always trimmed, before it is judged: the plan judged is the plan handed over
        return replan(engine, maps.grid, now, rule.gap, rule.margin, rule.clear, deadline, expected, trim=trim)
    found = _held(engine, maps, now, rule, deadline, expected)
    if found is None or not rule.trim:
        return found
    return trimmed(found, engine, maps.grid, trim)


def trimmed(found: Reroute, engine: Engine, grid: Grid, deadline: Optional[Deadline] = None) -> Reroute:
    """`found` with the robots it reroutes trimmed of moves that do not bring them in sooner (see
    the module docstring, "Trimmed", and `trim_cut`)."""
    plan = trim_from_cut(found.plan, found.cut, grid, found.agents, engine.run.out, engine.run.halfway, deadline)
    return found if plan is found.plan else dataclasses.replace(found, plan=plan)


def _held(engine: Engine, maps: Maps, now: float, rule: RerouteRule, deadline: Deadline,
          expected: Sequence[int]) -> Optional[Reroute]:
    """The held scope's reroute that pays now (the module docstring's rule), or None."""
    groups = held_up(engine, now, rule.gap, expected)
    if not groups:
        return None
    run, follow = engine.run, engine.follow
    cut = cut_of(engine, now)
    if behind_taken_back(engine, cut):
        return None  # no plan from this cut would fit: wait until that move is sent again
    base = cut.base
    ready = ready_steps(run, now)
    before = earliest_starts(run, ready, follow, base)
    if unplaced(run, before, base, range(run.num_agents)):
        return None  # a prediction that cannot be made (nothing to compare with): no change
    grid = maps.grid
    table = run.table

    def potential(h: int) -> int:
        goal = grid.index(table.goal(h))
        here = grid.index(table.coord(run.dst[run.first[h] + run.dispatched[h] - 1]
                                      if run.dispatched[h] > base[h] else run.src[run.first[h] + base[h]]))
        return before.arrival[h] - new_start(run, before, base, h) - maps.distances(goal)[here]

    kept = set(behind_taken_back(engine, cut, sent=True))  # never given a new path (`cut.behind_taken_back`)

    def may_move(h: int) -> bool:
        """Whether robot h may be given a new path at all: not halfway in a move it failed in
        (it keeps that move), not sent a move behind one taken back."""
        return not run.halfway[h] and h not in kept
    ranked = sorted(groups.items(), key=lambda g: (-sum(max(0, before.arrival[h] - before.arrival[g[0]])
                                                        for h in g[1]), g[0]))
    best: Optional[Tuple[float, Proposal, int, bool]] = None
    # the makespan is the last robot's arrival: a robot predicted well before it may arrive later
    spared = None if rule.slack is None else before.makespan - rule.slack
    # (the late robot, the robots given new paths, whether they are the robots predicted last)
    variants: List[Tuple[int, List[int], bool]] = []
    for late, held in ranked[:rule.tries]:
        gaining = [h for h in held if may_move(h) and potential(h) > rule.margin]
        alone = run.out[late] is None and may_move(late) and run.dispatched[late] < run.count(late)
        if alone:
            variants.append((late, [late], False))
        if gaining:
            variants.append((late, gaining, False))
            if alone:
                variants.append((late, gaining + [late], False))
    # the makespan is the last robots' arrival: a shorter way for them; not while a robot is out or
    # halfway (the variant plans robots anywhere, and round a robot out such a plan was found
    # invalid: a wider sweep of the operator-action runs, bench/README.md "The robots predicted last")
    if rule.critical is not None and all(o is None for o in run.out) and not any(run.halfway):
        last = [h for h in range(run.num_agents) if before.arrival[h] >= before.makespan - rule.critical
                and may_move(h) and run.dispatched[h] < run.count(h) and potential(h) > rule.margin]
        if last:
            variants.append((ranked[0][0], last, True))
    try:
        for late, chosen, for_last in variants:
            proposal = plan_around(run, grid, maps, before, ready, follow, base, chosen, deadline)
            if proposal is None:
                continue
            # a move more is a step more, and its expected delay; a quarter turn more, its time
            gain = (sum(before.arrival) - sum(proposal.arrival) - rule.per_move * sum(proposal.more.values())
                    - rule.per_turn * sum(proposal.turns.values()))
            net = gain - rule.cost * len(chosen)
            worse = later_by(before.arrival, proposal, rule.per_move, spared, rule.per_turn)
            if net >= rule.margin and worse <= rule.later and (best is None or net > best[0]):
                best = (net, proposal, late, for_last)
    except DeadlineReached:
        pass  # what was found so far
    if best is None:
        return None
    _, proposal, late, for_last = best
    report = validate_plan(proposal.plan, grid, strict_rotations=True, max_findings_per_kind=1)
    if not report.ok:  # never, by construction (reroute_plan); refused all the same
        raise RerouteError("a reroute's plan is not valid: {}".format(report.errors[0]))
    lag = behind(engine, late, now, expected)
    return Reroute(proposal.plan, cut, proposal.agents, late, lag,
                   sum(before.arrival) - sum(proposal.arrival), before.makespan, max(proposal.arrival),
                   tuple(groups[late]), last=for_last)


def way_home(engine: Engine, maps: Maps, now: float, goals: Dict[int, Tuple[int, int]],
             deadline: Optional[Deadline] = None) -> Optional[Reroute]:
    """A plan from now that takes the robots of `goals` (agent -> goal cell, planned in this order)
    from where they stand to their goals around the others, their paths and each cell's order kept,
    or None: one has no way there now, or may not be given a new path (out, halfway in a move it
    failed in, sent a move behind one taken back). For robots the plan leaves away from their goals
    (out when the plan was made) that take part again: the run goes on, nobody stops. The same
    plan, prediction and hand-over as a reroute's, so just as safe (see above); no rule: they have
    no other way home but a replan."""
    run = engine.run
    cut = cut_of(engine, now)
    agents = list(goals)
    kept = behind_taken_back(engine, cut, sent=True)
    if not agents or any(run.out[a] is not None or run.halfway[a] or a in kept for a in agents) \
            or behind_taken_back(engine, cut):
        return None
    ready = ready_steps(run, now)
    before = earliest_starts(run, ready, engine.follow, cut.base)
    if unplaced(run, before, cut.base, range(run.num_agents)):
        return None
    try:
        proposal = plan_around(run, maps.grid, maps, before, ready, engine.follow, cut.base, agents,
                               deadline or Deadline(None), goals=goals)
    except DeadlineReached:
        return None
    if proposal is None:
        return None
    report = validate_plan(proposal.plan, maps.grid, strict_rotations=True, max_findings_per_kind=1)
    if not report.ok:  # never, by construction (reroute_plan); refused all the same
        raise RerouteError("a way home's plan is not valid: {}".format(report.errors[0]))
    return Reroute(proposal.plan, cut, tuple(agents), agents[0], None, sum(before.arrival) - sum(proposal.arrival),
                   before.makespan, max(proposal.arrival), (), home=True)


class Rerouter:
    """The rule applied as a run goes on: looks at most once per `rule.every` plan steps (and
    only while some robot is held up), and keeps what it costs."""

    def __init__(self, grid: Grid, rule: Optional[RerouteRule] = None, timed: bool = True,
                 clock: Callable[[], float] = time.perf_counter, lag: float = 0.0) -> None:
        """`timed`: searches stop after `rule.budget` seconds of `clock` (a live run); without,
        they run to the end, so that a simulation gives the same run every time. `lag`: plan
        steps from a look to its hand-over in the simulator, the robots going on meanwhile, new
        moves frozen for `FREEZE` steps at most, as a live manager's worker thread makes it (0:
        at once)."""
        self.maps = Maps(grid)
        self.rule = rule or RerouteRule()
        self.timed = timed
        self.lag = lag
        self._clock = clock
        self._next = -1.0
        self._expected: Optional[Tuple[object, List[int]]] = None  # (run, its expected_steps)
        #: looks taken, their total seconds, reroutes found and the seconds of the looks that found one
        self.looks = 0
        self.seconds = 0.0
        self.found = 0
        self.found_seconds = 0.0

    def consider(self, engine: Engine, now: float) -> Optional[Reroute]:
        """A reroute that pays now, if it is time to look and one does."""
        steps = engine.run.clock.steps(now)
        if steps < self._next or engine.paused:
            return None
        self._next = steps + self.rule.pace
        began = self._clock()
        found = decide(engine, self.maps, now, self.rule,
                       Deadline(self.rule.budget if self.timed else None, self._clock), self._expected_of(engine))
        spent = self._clock() - began
        self.looks += 1
        self.seconds += spent
        if found is not None:
            self.found += 1
            self.found_seconds += spent
        return found

    def wanted(self, engine: Engine, now: float) -> bool:
        """Whether a live manager would have asked for the look `consider` just took
        (`worth_a_look`: it asks only while some robot is held up, scope all: late)."""
        return worth_a_look(engine, now, self.rule, self._expected_of(engine))

    def _expected_of(self, engine: Engine) -> List[int]:
        """The engine's `expected_steps`, computed once per plan."""
        if self._expected is None or self._expected[0] is not engine.run:
            self._expected = (engine.run, expected_steps(engine))
        return self._expected[1]

    def restart(self) -> None:
        """A new plan's clock starts at 0: look again a while after its start."""
        self._next = self.rule.pace

