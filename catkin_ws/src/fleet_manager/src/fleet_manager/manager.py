"""The manager process: the loop, the sockets and the run log around the run core.

One thread, one poller (`LinkSet`): the robots' command sockets, the console
channel, the ZAP handler and the Vicon socket are all read as they become
readable, and what arrives goes into the core (`core.RunCore`) as values.
Between them the loop does what is due, one chore a turn so that replies
never wait behind all of them (each costs milliseconds at 300 robots): read
the robots' pose streams (every 50 ms), publish the state (soon after news,
at most 50 times a second, and 20 times a second without), log poses (10 Hz).
After each input the core's effects are carried out (`_apply`): commands to
the robots' links, records to the run folder, frames to consoles, lines to
the terminal, replanning and looks for reroutes to worker threads whose
results come back on a later turn. A batch's run-log records are written before its commands leave,
so that a command the robots may run is always in the folder a manager
started again on it reads (`resume.py`); such a manager takes the old one's
epoch and clock from the folder and appends to it.
"""
from __future__ import annotations

import logging
import queue
import secrets
import threading
import time
from contextlib import nullcontext
from datetime import datetime, timedelta, timezone
from pathlib import Path
from typing import Callable, List, Optional, Sequence, Tuple

from fleet_common.plan import Plan
from fleet_common.plan_loading import LoadedPlan
from fleet_common.planning.replan import replan
from fleet_common.robots import RobotDefinition
from fleet_common.runlog import RunLog, new_run_folder
from fleet_common.ratelimit import RateLimitedLog
from fleet_common.runlog.writer import cut_torn_tail
from fleet_common.runlog.records import plan_file
from fleet_common.runlog.summary import RunSummary
from fleet_common.transport.console_channel import ConsoleServer
from fleet_common.transport.context import fleet_context
from fleet_common.transport.curve_keys import ManagerKeys
from fleet_common.transport.links import LinkSet
from fleet_common.transport.robot_link import RobotLink
from fleet_common.transport.zap import ZapHandler
from fleet_common.vicon.base_grid import load_vicon_to_base

from .core import RunCore
from .outbox import (Effect, LoadJob, NewRunFolder, PlanJob, Record, RerouteJob, ResumeRunFolder, Say, Send,
                     ToConsole, WriteFile)
from .plan_requests import solve_requested
from .rerouting import look
from .resume import ResumePoint
from .settings import ManagerSettings
from .vicon_provider import ViconProvider

__all__ = ["Manager", "ManagerSettings"]

_POSE_LOG_PERIOD = 0.1     # s between `poses` records (10 Hz)


class Manager:
    def __init__(self, loaded: LoadedPlan, robots: Sequence[RobotDefinition],
                 settings: ManagerSettings, *, keys: Optional[ManagerKeys] = None,
                 host: Optional[str] = None, clock: Callable[[], float] = time.monotonic,
                 say: Callable[[str], None] = print, log: Optional[logging.Logger] = None,
                 resume: Optional[Tuple[ResumePoint, Plan]] = None) -> None:
        self.settings = settings
        self.clock = clock
        self.say = say
        self.log = log or logging.getLogger("fleet_manager")
        # a resumed run goes on on its folder's clock: seconds since that run's manager started
        self.t0 = clock() - (0.0 if resume is None else resume_offset(resume[0]))
        self.runlog: Optional[RunLog] = None
        self.folder = None
        self._definitions: Optional[str] = None
        self._dropped = 0  # bytes of a torn last line cut off the folder of a resumed run
        self.epoch = (resume[0].epoch if resume is not None else None) or secrets.token_hex(8)
        self.context = fleet_context(len(robots))
        self.vicon: Optional[ViconProvider] = None
        #: work done off the loop: (the core's input for its outcome, job id, result, error)
        self._done: "queue.Queue[Tuple[Callable[..., None], int, object, Optional[str]]]" = queue.Queue()
        try:
            self.zap = ZapHandler(self.context, self.log, clock) if keys is not None else None
            # bind before connecting: the links' outgoing connections take ephemeral ports
            self.consoles = ConsoleServer(self.context, settings.bind, keys=keys, zap=self.zap,
                                          log=self.log)
            self.links = LinkSet([RobotLink(self.context, r, self.epoch, keys=keys, host=host, clock=clock,
                                            log=self.log) for r in robots], clock=clock)
            if settings.vicon_port is not None:
                self.vicon = ViconProvider(robots, load_vicon_to_base(settings.frames),
                                           port=settings.vicon_port, bind=settings.vicon_bind,
                                           stale_after=settings.stale_after, clock=clock, log=self.log)
            self.core = RunCore(loaded, robots, settings, secrets.token_hex(8), self.now(),
                                vicon=self.vicon is not None, resume=resume)
            self._apply(self.core.take())
        except BaseException:
            self._close_sockets()
            if self.runlog is not None:
                self.runlog.close()
            raise
        self.links.watch(self.consoles.socket, self._console_frames)
        if self.zap is not None:
            self.links.watch(self.zap.socket, self.zap.handle)
        if self.consoles.monitor is not None:
            self.links.watch(self.consoles.monitor.socket, self.consoles.monitor.handle)
        # what consoles get wrong, logged once a minute per console, then counted
        self.console_refusals = RateLimitedLog(self.log, clock=clock)
        self._next_flush = self.now() + 1.0
        if self.vicon is not None:
            self.links.watch(self.vicon.fileno(), self._vicon_readable)
        self._next_state = self._next_poses = self._last_state = self.now()
        self._fresh = False  # something arrived that the consoles have not been sent yet
        self._state_cost = 0.0  # seconds a state takes to build and send (smoothed)

    def now(self) -> float:
        """Seconds since the manager started (the run log's clock)."""
        return self.clock() - self.t0

    # ---- the loop ---------------------------------------------------------------------------

    def run(self, should_stop: Callable[[], bool], until_done: bool = False,
            time_limit: Optional[float] = None) -> Optional[str]:
        """Serve until `should_stop()`; with `until_done`, until the run is over. The reason it
        could not go on (None: done, or stopped from outside)."""
        deadline = None if time_limit is None else self.now() + time_limit
        while not should_stop():
            now = self.now()
            due = min(chore for chore, _ in self._chores())
            for event in self.links.poll(max(0.0, min(0.05, due - now)), drain=False):
                self._fresh = True
                self.core.link_event(event, self.now())
                self._apply(self.core.take())
            now = self.now()
            self._chore(now)
            self._timers(now)
            if until_done:
                if self.core.run.phase.phase == "done" and not self.core.news:  # the consoles saw it
                    return None
                failure = self.core.cannot_go_on(now)
                if failure is not None:
                    return failure
                if deadline is not None and now >= deadline:
                    return "not done after the time limit of {:g} s".format(time_limit)
        return None

    def _chores(self) -> List[Tuple[float, Callable[[float], None]]]:
        """The loop's periodic work, each with when it is due."""
        return [(self.links.next_drain - self.t0, self._read_poses),  # the links' clock
                (min(self._next_state, self._state_due()), self._publish),
                (self._next_poses, self._log_poses)]

    def _chore(self, now: float) -> None:
        """The most overdue chore, one per turn: each costs milliseconds with 300 robots, and
        between two of them the loop reads the robots' replies (a reply waiting behind all
        three would wait three times as long)."""
        due, chore = min(self._chores(), key=lambda c: c[0])
        if due <= now:
            chore(now)

    def _read_poses(self, now: float) -> None:
        for event in self.links.drain_poses():
            self._fresh = True
            self.core.link_event(event, now)
        self._apply(self.core.take())

    def _timers(self, now: float) -> None:
        while not self._done.empty():
            ready, job, result, error = self._done.get()
            ready(job, result, error, now)
        self.core.tick(now)
        self._apply(self.core.take())
        if self.core.news:  # a change the consoles have not been sent yet
            self._fresh = True
        if now >= self._next_flush:  # the counts of refusals held back, once their minute is over
            self._next_flush = now + 1.0
            self.console_refusals.flush()
            self.consoles.refusals.flush()
            if self.zap is not None:
                self.zap.flush()

    def _state_due(self) -> float:
        """When news (a pose, a reply) goes out: at once, but at most `state_max_rate` times a
        second, and at most a tenth of the loop's time (a state of 300 robots costs a few ms
        to build and send); without news the state still goes out `state_rate` times a second."""
        if not self._fresh:
            return float("inf")
        return self._last_state + max(1.0 / self.settings.state_max_rate, 10.0 * self._state_cost)

    def _publish(self, now: float) -> None:
        began = time.perf_counter()
        self._next_state = now + 1.0 / self.settings.state_rate
        self._last_state, self._fresh = now, False
        self.core.publish(now)
        self._apply(self.core.take())
        self._state_cost = 0.8 * self._state_cost + 0.2 * (time.perf_counter() - began)

    def _log_poses(self, now: float) -> None:
        self._next_poses = now + _POSE_LOG_PERIOD
        self.core.log_poses(now)
        self._apply(self.core.take())

    def _vicon_readable(self) -> None:
        self._fresh = True
        self.core.vicon(self.vicon.handle_readable(), self.now())  # type: ignore[union-attr]
        self._apply(self.core.take())

    def _console_frames(self) -> None:
        for peer, data in self.consoles.receive():
            key = "console {!r}".format(peer[:16])
            try:
                refusal = self.core.console_frame(peer, data, self.now())
                if refusal is not None:
                    self.console_refusals.event(logging.WARNING, key, "refused console frames", "%s", refusal)
            except Exception:  # one bad request must not take the fleet down
                self.console_refusals.event(logging.ERROR, key, "failed requests", "%s: request failed",
                                            key, exc_info=True)
            self._apply(self.core.take())
        if self.core.news:  # a change a request made goes out with the next State
            self._fresh = True

    # ---- carrying out the core's effects ----------------------------------------------------

    def _apply(self, effects: List[Effect]) -> None:
        if not effects:
            return
        # the batch's records reach the kernel at its end, in one system call, before its commands
        with self.runlog.batch() if self.runlog is not None else nullcontext():
            sends = self._carry_out(effects)
        for send in sends:
            self.links[send.robot].send(send.command)

    def _carry_out(self, effects: List[Effect]) -> List[Send]:
        """Every effect but the commands, which are returned (sent after the records saying so)."""
        sends: List[Send] = []
        for effect in effects:
            if isinstance(effect, Record):
                if self.runlog is not None:
                    fields = effect.fields
                    if effect.kind == "run":
                        fields = dict(fields, started=self._wall_at(effect.t), definitions=self._definitions,
                                      epoch=self.epoch)
                    elif effect.kind == "resume":
                        fields = dict(fields, started=self._wall_at(effect.t), dropped=self._dropped)
                    self.runlog.record(effect.kind, t=effect.t, **fields)
            elif isinstance(effect, Send):
                sends.append(effect)  # after the records that say it was sent
            elif isinstance(effect, ToConsole):
                self.consoles.send(effect.peer, effect.data)
            elif isinstance(effect, Say):
                self.say(effect.text)
            elif isinstance(effect, PlanJob):
                self._off_loop("replan", effect.id, self.core.plan_ready, lambda job=effect: replan(
                    job.grid, job.current, job.goals, job.out, deadline=job.time_limit, method=job.method))
            elif isinstance(effect, RerouteJob):  # on the job's own snapshot of the engine
                self._off_loop("reroute", effect.id, self.core.reroute_ready, lambda job=effect: look(job))
            elif isinstance(effect, LoadJob):
                self._off_loop("solve", effect.id, self.core.load_ready,
                               lambda job=effect: solve_requested(job.requested))
            elif isinstance(effect, NewRunFolder):
                self._new_folder(effect.plan_text)
            elif isinstance(effect, ResumeRunFolder):
                self._resume_folder(effect.folder)
            elif isinstance(effect, WriteFile) and self.runlog is not None:
                self.runlog.write_text(effect.name, effect.text)
        return sends

    def _wall_at(self, t: float) -> str:
        """The wall clock (UTC) at the run log's time `t`: a record made earlier in the turn (the
        core's time of its input) says when it was made, to the millisecond, not when written."""
        return (datetime.now(timezone.utc) - timedelta(seconds=max(0.0, self.now() - t))).isoformat(
            timespec="milliseconds")

    def _new_folder(self, plan_text: str) -> None:
        if self.runlog is not None:
            self.runlog.close()
            self.runlog = None
        self._definitions = None
        if self.settings.log_dir is None:
            return
        self.folder = new_run_folder(self.settings.log_dir)
        self.runlog = RunLog(self.folder, clock=self.clock)
        self.runlog.start = self.t0
        self.runlog.write_text(plan_file(1), plan_text)
        if self.settings.definitions is not None:
            self._definitions = self.runlog.copy_in(self.settings.definitions)

    def _resume_folder(self, folder: Path) -> None:
        """Go on writing `folder` (a run resumed after its manager died)."""
        if self.runlog is not None:
            self.runlog.close()
        self._dropped = cut_torn_tail(folder)
        self.folder = folder
        self.runlog = RunLog(folder, clock=self.clock)
        self.runlog.start = self.t0

    def _off_loop(self, name: str, job_id: int, ready: Callable[..., None], work: Callable[[], object]) -> None:
        """`work` in a worker thread while the loop goes on; its outcome comes back on a later turn
        as the core's input `ready` (job id, result, error)."""
        def run() -> None:
            try:
                self._done.put((ready, job_id, work(), None))
            except Exception as err:  # a failing job must not kill the manager
                self._done.put((ready, job_id, None, "{}: {}".format(type(err).__name__, err)))

        threading.Thread(target=run, name=name, daemon=True).start()

    def start(self) -> Tuple[bool, str]:
        """Start the run as a console's Start would (--start)."""
        answer = self.core.request("start", {}, self.now())
        self._apply(self.core.take())
        return answer

    # ---- the end ----------------------------------------------------------------------------

    def summary(self) -> RunSummary:
        return self.core.summary()

    def stop_robots(self) -> None:
        """Tell every connected robot to stop now, and give the messages a moment to leave."""
        self.core.stop_all(self.now())
        self._apply(self.core.take())
        end = self.clock() + 0.3
        while self.clock() < end:
            self.links.poll(0.05)

    def close(self, reason: str) -> None:
        self.core.close(reason, self.now())
        self._apply(self.core.take())
        if self.runlog is not None:
            self.runlog.close()
        self._close_sockets()

    def _close_sockets(self) -> None:
        for name in ("links", "consoles", "vicon"):
            part = getattr(self, name, None)
            if part is not None:
                part.close()
        zap = getattr(self, "zap", None)
        if zap is not None:
            zap.socket.close(linger=0)
        self.context.destroy(linger=200)


def resume_offset(point: ResumePoint) -> float:
    """Where a resumed run's clock goes on: the seconds since its first manager started (by the
    wall clock, so the time the run stood still shows), and never before its last record."""
    elapsed = 0.0
    started = point.run.get("started")
    if isinstance(started, str):
        try:
            elapsed = (datetime.now(timezone.utc) - datetime.fromisoformat(started)).total_seconds()
        except (ValueError, TypeError):
            elapsed = 0.0
    return max(point.last_t + 0.001, elapsed)
