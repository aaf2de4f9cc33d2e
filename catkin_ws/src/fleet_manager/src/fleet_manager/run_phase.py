"""The run's state machine: which phase a run is in, and what may move it.

    waiting --start--> running <--pause/start--> paused
       |                  |  --stop--> stopped --start--> running
       |                  '--(every robot at its goal)--> done --leg--> running
       '--step--> paused (one round released)
    waiting, paused, stopped, done --reset--> waiting (the same plan, from its starts)
    waiting --to_starts--> waiting (the way to the starts is planned, then run as a run of its own)

`TRANSITIONS` is the whole machine: (phase, trigger) -> the next phase. A
trigger the table does not have for the current phase is refused with the
reason from `REFUSALS` (or a general one) and changes nothing, as h11 refuses
an illegal event. Triggers are the operator's requests that move the run
(start, pause, stop, step, halt, load, replan, reset, to_starts) and the
run's own news (arrived: every robot taking part is at its goal; resume: a
replan was answered; leg: a robot enabled again after the end drives on;
no_way: the way to the starts could not be planned; resumed: a manager
started again on the folder of a run under way takes it over, paused). The
phase names are what consoles and run logs show.
"""
from __future__ import annotations

from typing import Dict, Optional, Tuple

__all__ = ["RunPhase", "WAITING", "RUNNING", "PAUSED", "STOPPED", "DONE", "TRANSITIONS"]

WAITING, RUNNING, PAUSED, STOPPED, DONE = "waiting", "running", "paused", "stopped", "done"

TRANSITIONS: Dict[Tuple[str, str], str] = {
    (WAITING, "start"): RUNNING,
    (PAUSED, "start"): RUNNING,
    (STOPPED, "start"): RUNNING,
    (RUNNING, "pause"): PAUSED,
    (RUNNING, "stop"): STOPPED,
    (PAUSED, "stop"): STOPPED,
    (WAITING, "step"): PAUSED,
    (RUNNING, "step"): PAUSED,
    (PAUSED, "step"): PAUSED,
    (STOPPED, "step"): PAUSED,
    (RUNNING, "halt"): PAUSED,
    (PAUSED, "halt"): PAUSED,
    (STOPPED, "halt"): PAUSED,
    (RUNNING, "arrived"): DONE,
    (PAUSED, "arrived"): DONE,  # (stepped to the end: `RunPhase.stepped`)
    (WAITING, "load"): WAITING,
    (STOPPED, "load"): WAITING,
    (DONE, "load"): WAITING,
    (RUNNING, "replan"): PAUSED,
    (PAUSED, "replan"): PAUSED,
    (STOPPED, "replan"): STOPPED,
    (PAUSED, "resume"): RUNNING,
    (WAITING, "resumed"): PAUSED,
    (DONE, "leg"): RUNNING,
    (WAITING, "reset"): WAITING,
    (PAUSED, "reset"): WAITING,
    (STOPPED, "reset"): WAITING,
    (DONE, "reset"): WAITING,
    (WAITING, "to_starts"): WAITING,
    (WAITING, "no_way"): WAITING,
}

#: Why a trigger is refused in a phase, where "not now" needs saying better.
REFUSALS: Dict[Tuple[str, str], str] = {
    (RUNNING, "start"): "already running",
    (DONE, "start"): "the run is done; Reset runs it again from the starts",
    (DONE, "step"): "the run is done",
    (WAITING, "halt"): "nothing is moving (the run is waiting)",
    (DONE, "halt"): "nothing is moving (the run is done)",
    (WAITING, "replan"): "replanning is for a run under way (the run is waiting)",
    (DONE, "replan"): "replanning is for a run under way (the run is done)",
    (RUNNING, "reset"): "pause or stop the run first",
    (RUNNING, "to_starts"): "the run is under way: pause or stop it, then Reset",
    (PAUSED, "to_starts"): "the run has begun: Reset sends the robots back to their starts",
    (STOPPED, "to_starts"): "the run has begun: Reset sends the robots back to their starts",
    (DONE, "to_starts"): "the run is done: Reset sends the robots back to their starts",
}


class RunPhase:
    """The current phase and the sentence that says why the run is in it."""

    def __init__(self) -> None:
        self.phase = WAITING
        self.reason = "waiting for Start"
        self.trigger = ""  # what moved it last

    def refusal(self, trigger: str) -> Optional[str]:
        """Why `trigger` cannot move the run now (None: it can)."""
        if (self.phase, trigger) in TRANSITIONS:
            return None
        reason = REFUSALS.get((self.phase, trigger))
        if reason is not None:
            return reason
        if trigger == "load":
            return "load another plan when the run is waiting, stopped or done (it is {})".format(self.phase)
        return "not running (the run is {})".format(self.phase)

    def move(self, trigger: str, reason: str = "") -> bool:
        """Apply `trigger`; True if the phase or its reason changed. ValueError if refused."""
        refusal = self.refusal(trigger)
        if refusal is not None:
            raise ValueError("{}: {}".format(trigger, refusal))
        phase = TRANSITIONS[(self.phase, trigger)]
        changed = (phase, reason) != (self.phase, self.reason)
        self.phase, self.reason, self.trigger = phase, reason, trigger
        return changed

    @property
    def stepped(self) -> bool:
        """Paused by a step, and by nothing since: a run stepped to its end is done."""
        return self.phase == PAUSED and self.trigger == "step"


    @property
    def under_way(self) -> bool:
        """Started and not over: running, paused or stopped."""
        return self.phase in (RUNNING, PAUSED, STOPPED)
