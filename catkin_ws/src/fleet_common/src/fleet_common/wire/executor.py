"""The robot's command executor: each command id runs at most once, one at a time.

Pure: it drives a `PollingNavigator` and returns replies; the transport sends them.
Every reply comes out as `(epoch, reply)`, the epoch being the manager's
(from its Hello), so the transport can route it to that manager's newest
connection: a command may finish after the connection that sent it was
replaced by a reconnect.

Rules, in the order they are applied to a command:

- a (epoch, id) seen before is acknowledged again and never executed again:
  `Accepted(duplicate=True)` plus its outcome if it has one (a refused command
  gets its `Failed` again). Ids strictly increase within an epoch, so an id
  at or below the highest seen that has dropped out of the bounded memory is
  refused, not run;
- `GetStatus` is answered at once (reading has no effect to repeat);
- a drive or turn the robot's world forbids is refused (`command_check`: off
  the map, into an obstacle, more than a step, an unreasonable time);
- `Release` moves the running drive's hold point on (if it names the drive that
  runs; otherwise there is nothing to release) and is accepted and completed at
  once: it never waits behind the drive it releases;
- `Stop` preempts: the navigator halts, the running command fails with
  "stopped by command N", the stop is accepted and completed at once;
- a drive or turn is refused while the robot has faults or another command
  runs (one at a time: the manager sends `Stop` first to change its mind),
  or when the navigator refuses it (or fails starting it: its error is the
  reason); otherwise it starts and is accepted, and `poll()` reports its
  `Completed` or `Failed` when the navigator says so.
"""
from __future__ import annotations

from collections import OrderedDict
from typing import Callable, Dict, List, Optional, Tuple

from ..limits import one_line
from .command_check import CommandCheck
from .messages import (Accepted, Command, Completed, DriveToPosition, Failed, GetStatus, Release,
                       Reply, Status, Stop, Turn)
from .navigator import MotionRefused, PollingNavigator

__all__ = ["CommandExecutor", "Routed"]

Routed = Tuple[str, Reply]  # (epoch of the manager to tell, reply)
_Key = Tuple[str, int]


class CommandExecutor:
    """Runs commands through `navigator`; remembers the last `memory` outcomes. `check`
    says what the robot's world forbids (default: no map, the default limits)."""

    def __init__(self, navigator: PollingNavigator, memory: int = 4096,
                 check: Optional[CommandCheck] = None,
                 on_execute: Optional[Callable[[str, Command], None]] = None) -> None:
        if memory < 1:
            raise ValueError("memory must be at least 1 command, got {}".format(memory))
        self.navigator = navigator
        self.check = check if check is not None else CommandCheck()
        self.memory = memory
        #: told (epoch, command) each time a motion starts or a stop is carried out: the
        #: virtual fleet's ground truth of what ran, to check that nothing ran twice
        self.on_execute = on_execute
        # (epoch, id) -> (was accepted, final reply or None while running)
        self._seen: "OrderedDict[_Key, Tuple[bool, Optional[Reply]]]" = OrderedDict()
        self._highest: Dict[str, int] = {}
        self._running: Optional[_Key] = None
        #: id of the last motion (drive or turn) it accepted that has ended: completed, failed or
        #: stopped (pose feedback names it: a manager tells a pose taken before a motion began from
        #: one taken after it; a refused motion never began, and a running one ends after it)
        self.ended: Optional[int] = None
        self.executed = 0  # motions started and stops carried out, for tests and logs

    @property
    def current(self) -> Optional[int]:
        """Id of the command running now, None when idle."""
        return None if self._running is None else self._running[1]

    def status(self, command_id: int) -> Status:
        return Status(command_id, self.navigator.pose(), self.current,
                      tuple(self.navigator.faults()))

    def handle(self, epoch: str, command: Command) -> List[Routed]:
        """Replies to `command` from the manager of `epoch`, in the order to send them."""
        if isinstance(command, GetStatus):
            return [(epoch, self.status(command.id))]
        key = (epoch, command.id)
        if key in self._seen:
            accepted, outcome = self._seen[key]
            replies: List[Reply] = [Accepted(command.id, duplicate=True)] if accepted else []
            replies += [outcome] if outcome is not None else []
            return [(epoch, r) for r in replies]
        if command.id <= self._highest.get(epoch, -1):
            return [(epoch, Failed(command.id, "command id {} is older than the last {} "
                                   "remembered; it is not executed again".format(
                                       command.id, self.memory)))]
        self._highest[epoch] = command.id
        if isinstance(command, Stop):
            return self._stop(key, command)
        if isinstance(command, Release):
            return self._release(key, command)
        refusal = self._refusal(command)
        if refusal is not None:
            return [self._settle(key, Failed(command.id, refusal), accepted=False)]
        self._remember(key, True, None)
        self._running = key
        self.executed += 1
        if self.on_execute is not None:
            self.on_execute(epoch, command)
        return [(epoch, Accepted(command.id))]

    def poll(self) -> List[Routed]:
        """The running command's outcome once the navigator reports it, else []."""
        if self._running is None:
            return []
        outcome = self.navigator.poll()
        if outcome is None:
            return []
        key, self._running = self._running, None
        self.ended = key[1]
        reply = Completed(key[1]) if outcome.ok else Failed(key[1], outcome.reason or "failed")
        return [self._settle(key, reply, accepted=True)]

    # ---- internals ---------------------------------------------------------------

    def _refusal(self, command: Command) -> Optional[str]:
        """Why `command` cannot start now (None: it has started)."""
        refusal = self.check.refusal(command, self.navigator.pose())
        if refusal is not None:
            return refusal
        faults = list(self.navigator.faults())
        if faults:
            return "robot has faults: {}".format(", ".join(faults))
        if self._running is not None:
            return "busy with command {}; send stop first or wait for it".format(self._running[1])
        try:
            if isinstance(command, DriveToPosition):
                self.navigator.start_drive(command.x, command.y, command.time, command.hold)
            elif isinstance(command, Turn):
                self.navigator.start_turn(command.angle)
        except MotionRefused as err:
            return str(err) or "refused by the navigator"
        except Exception as err:  # a navigator bug must not leave the command unanswered
            return one_line("navigator failed: {}: {}".format(type(err).__name__, err), 200)
        return None

    def _stop(self, key: _Key, command: Command) -> List[Routed]:
        self.navigator.halt()
        self.executed += 1
        if self.on_execute is not None:
            self.on_execute(key[0], command)
        out: List[Routed] = []
        if self._running is not None:
            running, self._running = self._running, None
            self.ended = running[1]
            out.append(self._settle(running, Failed(running[1], "stopped by command {}".format(
                key[1])), accepted=True))
        self._remember(key, True, None)
        out.append((key[0], Accepted(key[1])))
        out.append(self._settle(key, Completed(key[1]), accepted=True))
        return out

    def _release(self, key: _Key, command: Release) -> List[Routed]:
        if self._running == (key[0], command.drive):
            self.navigator.release(command.x, command.y)
        self._remember(key, True, None)
        return [(key[0], Accepted(key[1])), self._settle(key, Completed(key[1]), accepted=True)]

    def _settle(self, key: _Key, reply: Reply, accepted: bool) -> Routed:
        self._remember(key, accepted, reply)
        return key[0], reply

    def _remember(self, key: _Key, accepted: bool, reply: Optional[Reply]) -> None:
        self._seen[key] = (accepted, reply)
        self._seen.move_to_end(key)
        while len(self._seen) > self.memory:
            oldest = next(iter(self._seen))
            if oldest == self._running:  # never forget the command still running
                self._seen.move_to_end(oldest)
                continue
            del self._seen[oldest]
