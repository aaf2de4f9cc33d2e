"""The execution engine: events in, decisions out, for one run of one plan.

Theory of operation. The plan becomes per-robot actions (`actions`) and an
Action Dependency Graph (`adg`); progress lives in a `RunState` (`run`).
Each event updates the progress, then the engine looks again at only the
robots the event can have freed: the robot itself, the robot waiting for the
completed action (its ADG successor), and whichever robots the strategy
names (the next step's robots when a barrier moves). A robot's next action is
dispatched when

1. the robot takes part (not disabled, not failed),
2. fewer than `strategy.window` of its actions are sent and incomplete,
3. the run is not paused (or the current round allows it) nor frozen (`Freeze`:
   a new plan is being made from this moment; the clock runs on),
4. its ADG predecessor (the other robot's move out of the cell it enters)
   has completed, or, for robots smaller than a cell (`follow`), has been
   dispatched: the safety rule, the same for every strategy,
5. the strategy does not hold it (the discrete time step's barrier).

A strategy that re-orders (`reorder`) may, when rule 4 stops a ready robot,
change the cell's order so that the robot goes first (`Strategy.overtake`);
the move it passes, if dispatched and not begun, is first taken back from the
caller (`take_back`). Rule 4 itself never changes.

So a completion costs O(1) plus the dispatches it causes, whatever the
fleet's size. No sockets, threads or clocks: time is a number in each event,
used only for the metrics. An event that contradicts the progress raises
`EventError` and changes nothing.

Following (`follow=True`). Robots of their real size may follow one another:
a robot may start into a cell that another is leaving as soon as the
leaver's move is dispatched, not completed, so that a train of robots moves
as one instead of one robot at a time. Such a `Dispatch` names its leader
(`follows`): until the leader's move completes, the follower may only go as
far as keeps it at the safe distance from where the leader is known to be
(`following.hold_fraction`, applied by whoever drives the robot: the
simulator, the manager's driver). Why that is safe, whatever the delays: the
leader only ever moves on along its path, so a position it reported is
never ahead of the truth; the follower stops short of the hold point
computed from it, and a late or lost report only stops it earlier. Why no
new deadlock: a follower waits only for its leader's move, as before, and
every chain of leaders ends at a robot whose move depends on nobody
unfinished (the ADG has no cycles). `following()` lists who follows whom.

A run may be handed over to a new plan from where its robots are (`adopt`, for `reroute`):
the new engine takes the old one's progress, translated to the new plan, and checks the one
thing that keeps the hand-over safe: no move already sent waits in the new plan for a move
that is not.

Switching strategies keeps the progress and attaches the new strategy to it;
actions already sent stay sent. Because rule 4 holds under every strategy,
any mix of strategies, pauses, disabled and failed robots is collision-free:
a robot that stops (even mid-move) still holds both cells of its move, since
nobody may enter a cell before its previous occupant's move out is complete
(for followers: nobody comes closer than the safe distance to it).
"""
from __future__ import annotations

import math
from collections import deque
from typing import Callable, Dict, List, Mapping, Optional, Sequence, Tuple, Union

from ..grid import Coord
from ..plan import Plan
from .actions import ActionTable
from .adg import build_adg
from .blocking import blocked_by
from .errors import EventError, UnknownStrategyError
from .events import (
    CELL, FOLLOW, PAUSED, ActionCompleted, ActionStarted, Disabled, Dispatch, Enabled, Freeze, Pause, Resume,
    RobotFailed, StepRound, SwitchStrategy, Thaw, Tick, Wait,
)
from .metrics import Metrics
from .run import DISABLED, FAILED, PlanClock, RunState
from .strategy import Strategy, make_strategy

Recheck = Tuple[Sequence[int], Optional[int]]  # robots to look at, robot whose event freed them


def _identity(c: Coord) -> Coord:
    return c


class Engine:
    """One run of `plan` under a switchable strategy; see the module docstring."""

    def __init__(self, plan: Plan, strategy: Union[str, Strategy] = "adg",
                 show: Callable[[Coord], Coord] = _identity, follow: bool = False,
                 take_back: Optional[Callable[[int, int], bool]] = None, step_time: float = 1.0,
                 **settings: object) -> None:
        """Build actions and ADG (raising `PlanError` for plans robots cannot run).

        `strategy` is a registered name (with its `settings`, e.g. `lookahead=2`)
        or a `Strategy`; `show` turns base cells into the frame messages use;
        `follow`: robots smaller than a cell, which may follow one another; `take_back(r, k)`:
        the caller takes back robot r's dispatched actions from index k on, which it has not
        handed over or the robot has not begun, and answers True (they will never start), or
        answers False (a re-ordering strategy then leaves that robot's order alone);
        `step_time`: one plan step in the unit of the events' times (a strategy that compares
        robots with the plan's clock reads it).
        """
        self.follow = follow
        self.show = show  # the frame messages use (a plan handed over to keeps it)
        #: follower action -> leader action, for actions dispatched before their leader completed
        self.early: Dict[int, int] = {}
        table = ActionTable.from_plan(plan, show)
        self.run = RunState(build_adg(table, show))
        self.run.follow = follow
        self.run.clock = PlanClock(step_time)
        self._give_back: Optional[Callable[[int, int], bool]] = None
        self._out: List[Dispatch] = []  # the decisions being made (take-backs remove from it)
        self.allow_take_back(take_back)
        self.table = table
        if not isinstance(strategy, str) and settings:
            raise UnknownStrategyError("settings ({}) go with a strategy name, not a Strategy object".format(
                ", ".join(settings)))
        self.strategy = make_strategy(strategy, **settings) if isinstance(strategy, str) else strategy
        self.strategy.attach(self.run)
        self.metrics = Metrics([self.run.count(r) for r in range(self.run.num_agents)])
        # per action, when it was last dispatched, and when the cell it leaves was freed for the
        # next visitor (completed, or dispatched when robots follow): what makes a wait forced
        self._sent_at = [math.inf] * table.num_actions
        self._freed_at = [math.inf] * table.num_actions
        self._cap: Optional[List[int]] = list(self.run.dispatched)  # a run starts paused
        self._frozen: Optional[List[int]] = None  # dispatched per robot at `Freeze`, until `Thaw`
        self._handlers: Dict[type, Callable[..., Recheck]] = {
            ActionCompleted: self._completed, ActionStarted: self._started, RobotFailed: self._failed,
            Disabled: self._disabled, Enabled: self._enabled, Resume: self._resume,
            Pause: self._pause, StepRound: self._step_round, SwitchStrategy: self._switch,
            Tick: self._tick, Freeze: self._freeze, Thaw: self._thaw,
        }

    def handle(self, event: object) -> List[Dispatch]:
        """Apply `event`; the actions that may start now, each to be sent once."""
        handler = self._handlers.get(type(event))
        if handler is None:
            raise EventError("not an engine event: {!r}".format(event))
        self.run.now = event.time  # type: ignore[attr-defined]
        agents, released_by = handler(event)
        self.run.version += 1
        self.metrics.record(event)
        # a thaw ends waits the rerouting made, not the operator (the metrics' "held")
        return self._dispatch(agents, released_by, event.time,  # type: ignore[attr-defined]
                              operator=not isinstance(event, Thaw))

    @property
    def paused(self) -> bool:
        return self._cap is not None

    @property
    def frozen(self) -> bool:
        return self._frozen is not None

    @property
    def finished(self) -> bool:
        """The strategy's verdict: by default, every robot not out has completed its actions."""
        return self.strategy.finished()

    @property
    def stuck(self) -> bool:
        """Running, not finished, and nothing moving: only an out robot can cause this."""
        return not self.paused and not self.frozen and not self.finished and not self.run.moving

    def out_agents(self) -> List[int]:
        return [r for r, why in enumerate(self.run.out) if why is not None]

    def waiting(self) -> List[Wait]:
        """Robots ready for their next action that may not start it, and why."""
        run, cap, out = self.run, self._cap, []
        for r in range(run.num_agents):
            if run.out[r] is not None or run.dispatched[r] > run.completed[r]:
                continue
            a = run.next_undispatched(r)
            if a < 0:
                continue
            d = run.dep[a]
            if cap is not None and run.dispatched[r] >= cap[r]:
                out.append(Wait(r, (), None, PAUSED))
            elif d >= 0 and not run.done[d] and run.agent[d] != r:
                out.append(Wait(r, (run.agent[d],), self.table.coord(run.dst[a]), CELL))
            elif self.strategy.holds(a):
                reason, on = self.strategy.hold_reason(a)
                out.append(Wait(r, on, None, reason))
        return out

    def following(self) -> List[Wait]:
        """Followers whose leader's move is not complete yet: they may not come closer to it
        than the safe distance (reason FOLLOW, `on` the leader, `cell` the cell they enter)."""
        run = self.run
        return [Wait(run.agent[a], (run.agent[d],), self.table.coord(run.dst[a]), FOLLOW)
                for a, d in sorted(self.early.items())]

    def blocked_by(self) -> Dict[int, List[int]]:
        """For each out robot, the robots now waiting for it, directly or transitively."""
        return blocked_by(self.waiting() + self.following(), self.out_agents())

    def restore(self, completed: Sequence[int], started: Sequence[int], dispatched: Sequence[int],
                time: float, taken_back: Optional[Sequence[bool]] = None) -> List[Dispatch]:
        """Progress known from elsewhere, before any event: a manager started again on a run
        folder reads it from the run log. Agent r completed its first `completed[r]` actions,
        began those up to `started[r]` and was sent those up to `dispatched[r]`; `taken_back[r]`:
        it began its next one and a fault or a halt took it back (it stands between two cells,
        `RunState.halfway`). Followers sent before their leader completed need the leader's move
        dispatched: it is counted so. A follower that completed its move into the cell such a
        leader was leaving needs nothing more: the leader's move was dispatched when it followed,
        as the live engine had it (big operator session 293: a manager could not take over).
        The progress must be one the dependency rule allows (EventError otherwise, changing
        nothing). The run stays paused; the actions dispatched and not completed are returned
        (their robots are carrying them out, or are to)."""
        run = self.run
        n = run.num_agents
        if run.version or not (len(completed) == len(started) == len(dispatched) == n):
            raise EventError("restore needs the progress of all {} agents before any event".format(n))
        done = [int(c) for c in completed]
        disp = [max(int(c), int(s), int(d)) for c, s, d in zip(completed, started, dispatched)]
        for r in range(n):
            if not 0 <= done[r] <= disp[r] <= run.count(r):
                raise EventError("agent {} has {} actions; cannot restore {} completed, {} sent".format(
                    r, run.count(r), done[r], disp[r]), r)
        first, dep, agent = run.first, run.dep, run.agent

        def index(a: int) -> int:
            return a - first[agent[a]]

        grown = True
        while grown:  # a follower sent early needs its leader's move sent (and that one's leader)
            grown = False
            for r in range(n):
                for a in range(first[r] + done[r], first[r] + disp[r]):
                    d = dep[a]
                    if d < 0 or agent[d] == r or index(d) < done[agent[d]]:
                        continue
                    if not self.follow:
                        raise EventError("agent {} was sent action {} before agent {} completed "
                                         "action {}".format(r, a - first[r], agent[d], index(d)), r)
                    if index(d) >= disp[agent[d]]:
                        disp[agent[d]] = index(d) + 1
                        grown = True
        back = list(taken_back) if taken_back is not None else [False] * n
        for r in range(n):
            for a in range(first[r], first[r] + done[r]):
                d = dep[a]
                if self.follow and d >= 0 and back[agent[d]] and index(d) == done[agent[d]]:
                    continue  # behind a leader's move taken back: sent when it followed
                if d >= 0 and agent[d] != r and index(d) >= (disp if self.follow else done)[agent[d]]:
                    raise EventError("agent {} completed action {} before agent {} began action {}".format(
                        r, a - first[r], agent[d], index(d)), r)
        for r in range(n):
            for a in range(first[r], first[r] + done[r]):
                run.done[a] = 1
            run.completed[r] = done[r]
            run.started[r] = min(max(done[r], int(started[r])), disp[r])
            run.started_at[r] = time
            run.dispatched[r] = run.sent[r] = disp[r]
        out = []
        for r in range(n):
            for a in range(first[r] + done[r], first[r] + disp[r]):
                d = dep[a]
                leader = None
                if d >= 0 and not run.done[d] and agent[d] != r:
                    self.early[a] = d
                    leader = (agent[d], index(d))
                out.append(Dispatch(r, a - first[r], run.step[a], self.table.coord(run.src[a]),
                                    self.table.coord(run.dst[a]), leader))
        self.strategy.attach(run)  # strategies derive their state from the progress
        self.metrics.restored(done, time)
        self._cap = list(run.dispatched)
        run.version += 1
        return out

    # ---- events -------------------------------------------------------------------------
    def _agent(self, r: object, event: object) -> int:
        if isinstance(r, bool) or not isinstance(r, int) or not 0 <= r < self.run.num_agents:
            raise EventError("{!r}: no agent {!r} in this plan of {} agents".format(
                event, r, self.run.num_agents))
        return r

    def _started(self, e: ActionStarted) -> Recheck:
        run, r = self.run, self._agent(e.agent, e)
        if not run.completed[r] <= e.index < run.sent[r]:
            raise EventError("agent {} reports starting action {}, but it was sent actions up to {} "
                             "and completed {}".format(r, e.index, run.sent[r] - 1, run.completed[r]), r)
        if e.index + 1 > run.started[r]:
            run.started[r] = e.index + 1
            run.started_at[r] = e.time
        run.dispatched[r] = max(run.dispatched[r], e.index + 1)  # a withdrawn action it began anyway
        return (), None

    def _completed(self, e: ActionCompleted) -> Recheck:
        run, r = self.run, self._agent(e.agent, e)
        k = e.index
        if k != run.completed[r] or k >= run.sent[r]:
            raise EventError("agent {} reports completing action {}, but its next action to complete "
                             "is {} and it was sent {}".format(r, k, run.completed[r], run.sent[r]), r)
        a = run.first[r] + k
        run.done[a] = 1
        if self._freed_at[a] > e.time:
            self._freed_at[a] = e.time
        run.completed[r] = k + 1
        run.halfway[r] = False
        run.started[r] = max(run.started[r], k + 1)
        run.dispatched[r] = max(run.dispatched[r], k + 1)
        if self.early:
            self.early.pop(a, None)
            self.early.pop(run.succ[a], None)
        extra = self.strategy.on_completed(a)
        s = run.succ[a]
        agents = [r] if s < 0 else [r, run.agent[s]]
        if extra:
            agents.extend(extra)
        return agents, r

    def _failed(self, e: RobotFailed) -> Recheck:
        run, r = self.run, self._agent(e.agent, e)
        was_active = run.out[r] is None
        if run.out[r] != DISABLED:  # the operator's choice stands; the move begun is taken back all the same
            run.out[r] = FAILED
        run.halfway[r] = run.halfway[r] or run.started[r] > run.completed[r]
        # nothing it was sent counts as done; on Enabled it is sent its next action again
        run.dispatched[r] = run.started[r] = run.completed[r]
        self._forget_early(r)
        return (self.strategy.on_out(r) if was_active else ()), r

    def _disabled(self, e: Disabled) -> Recheck:
        run, r = self.run, self._agent(e.agent, e)
        was_active = run.out[r] is None
        # the operator's choice wins over a fault: out of the run, no longer waiting to be cleared
        # (a robot failed halfway keeps that move and its cell: `halfway`)
        run.out[r] = DISABLED
        run.dispatched[r] = max(run.started[r], run.completed[r])  # keeps only what it began
        self._forget_early(r)
        return (self.strategy.on_out(r) if was_active else ()), r

    def _forget_early(self, r: int) -> None:
        """Robot r's actions taken back are no longer following anyone."""
        if self.early:
            run = self.run
            for a in range(run.first[r] + run.dispatched[r], run.first[r + 1]):
                self.early.pop(a, None)

    def allow_take_back(self, take_back: Optional[Callable[[int, int], bool]]) -> None:
        """Set (or, with None, clear) the caller's `take_back` (see `__init__`)."""
        self._give_back = take_back
        self.run.take_back = self._take_back

    def _take_back(self, r: int, k: int) -> bool:
        """Robot r's unstarted actions from index k on no longer count as sent, if the caller
        takes them back (for a strategy that re-orders: `reorder`)."""
        run = self.run
        if self._give_back is None or not run.started[r] <= k < run.dispatched[r] or run.out[r] is not None:
            return False
        first, succ, agent, dispatched = run.first, run.succ, run.agent, run.dispatched
        for a in range(first[r] + k, first[r] + dispatched[r]):
            s = succ[a]
            if s >= 0 and agent[s] != r and dispatched[agent[s]] > s - first[agent[s]]:
                return False  # a robot already follows it out of its cell: it must go
        if not self._give_back(r, k):
            return False
        for a in range(first[r] + k, first[r] + dispatched[r]):
            self._sent_at[a] = self._freed_at[a] = math.inf
        run.dispatched[r] = run.sent[r] = k
        self.metrics.taken_back(r, k, run.now)
        self._forget_early(r)
        self._out[:] = [d for d in self._out if d.agent != r or d.index < k]  # decided a moment ago
        return True

    def _enabled(self, e: Enabled) -> Recheck:
        run, r = self.run, self._agent(e.agent, e)
        if run.out[r] is None:
            return (), None
        run.out[r] = None
        return [r] + list(self.strategy.on_back(r)), r

    def _resume(self, e: Resume) -> Recheck:
        self._cap = None
        self.run.clock.run(e.time)
        return range(self.run.num_agents), None

    def _pause(self, e: Pause) -> Recheck:
        self._cap = list(self.run.dispatched)
        self.run.clock.stop(e.time)
        return (), None

    def _freeze(self, e: Freeze) -> Recheck:
        self._frozen = list(self.run.dispatched)
        return (), None

    def _thaw(self, e: Thaw) -> Recheck:
        if self._frozen is None:
            return (), None
        self._frozen = None
        return range(self.run.num_agents), None

    def _step_round(self, e: StepRound) -> Recheck:
        self.run.clock.stop(e.time)
        limits = self.strategy.round()
        self._cap = [max(c, d) for c, d in zip(limits, self.run.dispatched)]
        return range(self.run.num_agents), None

    def _tick(self, e: Tick) -> Recheck:
        return self.strategy.on_tick(), None

    @property
    def tick_every(self) -> float:
        """How often (plan steps) the strategy wants a `Tick` while the run runs (0: never)."""
        return 0.0 if self.paused else self.strategy.tick_every

    def _switch(self, e: SwitchStrategy) -> Recheck:
        new = e.strategy
        if not isinstance(new, Strategy) or (new.run is not None and new.run is not self.run):
            raise EventError("SwitchStrategy needs a new strategy from make_strategy(), got {!r}".format(new))
        new.attach(self.run)
        self.strategy = new
        return range(self.run.num_agents), None

    # ---- a run handed over to a new plan -------------------------------------------------
    def adopt(self, old: "Engine", progress: Sequence[Tuple[int, int, bool]], time: float,
              released_by: Optional[Mapping[int, int]] = None) -> List[Dispatch]:
        """Go on with `old`'s run on this engine's plan, a plan from where its robots are (see
        `handover`). `progress[r]`: robot r's moves of this plan completed, its moves sent and not
        completed, and whether it began the first of those. The robots out, the pause, the caller's
        `take_back` and the metrics (one object for the whole run) carry over; the plan's clock
        starts at `time`. The decisions now; a wait one ends is charged to `released_by[robot]`.

        Raises `EventError`, changing neither engine, when a move made or sent is not, cell for
        cell, the one `old`'s robot made or was sent, or would wait in this plan for a move that is
        not (the plan does not fit the run: the rule's one condition), unless `old`
        sent it following that very move (its leader went out since and took the move back): the
        pair keeps its order and the follower its hold behind the leader's real pose."""
        run = self.run
        n = run.num_agents
        if n != old.run.num_agents or len(progress) != n or run.passes or self.metrics.begin is not None:
            raise EventError("adopt: a fresh engine for the same {} robots is needed".format(old.run.num_agents))
        first, agent, dep = run.first, run.agent, run.dep
        for r, (done, sent, _) in enumerate(progress):
            if done < 0 or sent < 0 or done + sent > run.count(r):
                raise EventError("adopt: robot {} has {} moves in the new plan, not {} done and {} sent".format(
                    r, run.count(r), done, sent), r)
        misfit = self._misfit(progress, old)
        if misfit is not None:
            raise EventError(misfit)
        for r, (done, sent, began) in enumerate(progress):
            for a in range(first[r], first[r] + done):
                run.done[a] = 1
                self._freed_at[a] = time
            for a in range(first[r] + done, first[r] + done + sent):
                self._sent_at[a] = time
                if self.follow:
                    self._freed_at[a] = time
            run.completed[r] = done
            run.dispatched[r] = run.sent[r] = done + sent
            run.started[r] = done + (1 if began and sent else 0)
            run.dispatched_at[r] = old.run.dispatched_at[r]
            run.started_at[r] = old.run.started_at[r]
            run.out[r] = old.run.out[r]
            run.halfway[r] = old.run.halfway[r]  # a plan from the cut keeps its next move (`reroute`)
            for a in range(first[r] + done, first[r] + done + sent):
                d = dep[a]
                if d >= 0 and agent[d] != r and not run.done[d]:
                    self.early[a] = d
        run.version = old.run.version + 1
        run.clock = PlanClock(old.run.clock.step_time)
        if not old.paused:
            run.clock.run(time)
            self._cap = None
        else:
            self._cap = list(run.dispatched)
        self._give_back = old._give_back
        old.metrics.rebase([old.metrics.offset[r] + old.run.completed[r] - progress[r][0] for r in range(n)],
                           [run.count(r) for r in range(n)])
        self.metrics = old.metrics
        self.strategy.attach(run)
        out: List[Dispatch] = []
        charged = released_by or {}
        for r in range(n):
            out += self._dispatch([r], charged.get(r), time, operator=False)
        return out

    def _misfit(self, progress: Sequence[Tuple[int, int, bool]], old: "Engine") -> Optional[str]:
        """Why this plan does not fit `old`'s run with `progress` (see `adopt`), or None: a move
        done or sent that is not the same move (cells) in `old`'s run, or that waits in this plan
        for a move not completed (robots of real size: not sent), and that `old` did not send
        following the same move. (A move done behind one not made: the plan puts another robot
        into a cell before a robot that is in it already.)"""
        run = self.run
        first, agent, dep = run.first, run.agent, run.dep
        # robot r's move k here is its move k + base[r] in `old`'s plan
        base = [old.run.completed[r] - done for r, (done, _, _) in enumerate(progress)]
        otherwise = self._moved_otherwise(progress, old)
        if otherwise is not None:
            return otherwise
        for r, (done, sent, _) in enumerate(progress):
            for a in range(first[r], first[r] + done + sent):
                d = dep[a]
                if d < 0 or agent[d] == r:
                    continue
                q = agent[d]
                k = d - first[q]
                if k < progress[q][0] or (self.follow and k < progress[q][0] + progress[q][1]):
                    continue
                was = old.early.get(old.run.first[r] + base[r] + a - first[r])
                if self.follow and was is not None and was == old.run.first[q] + base[q] + k:
                    continue  # it follows the move it followed: its leader took it back (out)
                return ("adopt: robot {}'s move {} was {}, but in the new plan it waits for robot {}'s "
                        "move {}, which was not".format(r, a - first[r], "made" if a < first[r] + done else "sent",
                                                        q, k))
        return None

    def _moved_otherwise(self, progress: Sequence[Tuple[int, int, bool]], old: "Engine") -> Optional[str]:
        """Why this plan's moves done or sent are not the moves `old`'s robots made or were sent (the
        same cells: a robot drives the move it was sent, whatever plan it now belongs to), or None."""
        run, was = self.run, old.run
        for r, (done, sent, _) in enumerate(progress):
            base = was.completed[r] - done  # robot r's move k here is its move k + base in `old`'s plan
            for k in range(done + sent):
                a, b = run.first[r] + k, was.first[r] + base + k
                here = (self.table.coord(run.src[a]), self.table.coord(run.dst[a]))
                there = (old.table.coord(was.src[b]), old.table.coord(was.dst[b]))
                if here != there:
                    return "adopt: robot {}'s move {} was {} {} -> {}, but the new plan has {} -> {}".format(
                        r, k, "made" if k < done else "sent", there[0], there[1], here[0], here[1])
        return None

    def _forced(self, r: int, a: int, now: float) -> float:
        """Of robot r's wait for action `a`, ending now, the time the cell was taken in a way no
        change of order could undo: the robot before it there was in it or had been sent its
        move in, or the cell is r's goal (`metrics`)."""
        ready = self.metrics.ready_at(r)
        if ready is None or now <= ready:
            return 0.0
        run = self.run
        d = run.dep[a]
        if d < 0 or run.agent[d] == r:
            return 0.0  # it waited for no cell: the strategy held it
        end = min(now, self._freed_at[d])
        if end <= ready:
            return 0.0
        p = run.agent[d]
        ep = d - 1
        if ep < run.first[p] or a == run.first[r + 1] - 1:
            return end - ready  # p started in the cell, or the cell is r's goal
        lo = run.dep[ep]
        there = self._freed_at[lo] if lo >= 0 and run.agent[lo] != p else -math.inf
        sent = self._sent_at[ep]
        if sent <= there:
            return end - ready
        return max(0.0, min(end, there) - ready) + max(0.0, end - max(ready, sent))

    # ---- decisions ----------------------------------------------------------------------
    def _dispatch(self, robots: Sequence[int], released_by: Optional[int], time: float,
                  operator: bool = True) -> List[Dispatch]:
        run, strategy, cap, frozen = self.run, self.strategy, self._cap, self._frozen
        out: List[Dispatch] = []
        self._out = out
        first, dep, done, step, agent = run.first, run.dep, run.done, run.step, run.agent
        dispatched, succ, follow, early = run.dispatched, run.succ, self.follow, self.early
        window, reorders = strategy.window, strategy.reorders
        coord = self.table.coord
        todo = deque(robots)
        while todo:
            r = todo.popleft()
            if run.out[r] is not None:
                continue
            base = first[r]
            limit = min(first[r + 1], base + run.completed[r] + window)
            if cap is not None:
                limit = min(limit, base + cap[r])
            if frozen is not None:
                limit = min(limit, base + frozen[r])
            a = base + dispatched[r]
            while a < limit:
                d = dep[a]
                leader = None
                by = released_by
                if d >= 0 and not done[d] and agent[d] != r:
                    # the leader's move out of the cell: complete, or (following) dispatched
                    if not follow or dispatched[agent[d]] <= d - first[agent[d]]:
                        if not (reorders and strategy.overtake(a)):
                            break
                        by = agent[d]  # it waited for the robot it passed
                        d = dep[a]  # passed the late robots ahead: a new leader, if any
                        if not run.released(d) and agent[d] != r:
                            break  # rule 4 holds whatever a strategy says
                    if d >= 0 and not done[d] and agent[d] != r:
                        leader = (agent[d], d - first[agent[d]])
                        by = agent[d]  # it waited for the robot it follows
                if strategy.holds(a):
                    break
                k = a - base
                forced = 0.0
                if dispatched[r] == run.completed[r]:
                    run.dispatched_at[r] = time
                    forced = self._forced(r, a, time)
                self._sent_at[a] = time
                if follow:
                    self._freed_at[a] = time
                dispatched[r] = k + 1
                if k >= run.sent[r]:
                    run.sent[r] = k + 1
                if leader is not None:
                    early[a] = d
                out.append(Dispatch(r, k, step[a], coord(run.src[a]), coord(run.dst[a]), leader))
                self.metrics.record_dispatch(r, k, time, by, forced, operator)
                if follow and succ[a] >= 0 and not done[a]:
                    todo.append(agent[succ[a]])  # its follower may go now too
                a += 1
        self._out = []
        return out
