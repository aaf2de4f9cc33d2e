"""What a line of events.jsonl says: one kind per line, its fields listed here.

Every line is a JSON object with `t` (seconds since the run started: wall
seconds for the manager, plan steps for `fleetctl simulate`; the `run`
record's `time_unit` says which) and `k` (the kind). Robots are named by
their id from robot_definitions.txt (`robot`); the `run` and `plan` records
map plan agents to robot ids (`robots[i]` is agent i's robot). Cells are
base-grid `[x, y]`; headings radians. Fields not listed are allowed (readers
ignore what they do not know), so later versions can add detail.

    run        version, started (ISO 8601, UTC: the wall clock at this record's
               `t`; in a manager's run, started + t - t_of_run puts any record
               on the wall clock to the millisecond), source ("manager" | "simulate"),
               time_unit ("s" | "step"), plan (file name), definitions (file
               name or null), robots [ids by agent], strategy, settings {},
               size {diameter_m, margin_m, cell_m, safe_m} (the robots' size;
               absent in older folders: robots as large as a cell), epoch (the
               manager's command epoch, so that a manager started again on the
               folder speaks to the robots as the same manager), trim (optional: the
               run's plans trimmed, `planning.trim`; a manager resuming keeps it), walls (optional,
               as in plan: a way to the starts' own)
    resume     started (ISO 8601, UTC, at this record's `t`), plan (the file being run), completed
               [actions of it completed, by agent], sent [commands sent again:
               [robot, id, type]], dropped (bytes of a torn last line cut off),
               downtime (s since the last record): a manager started again on
               this folder (`fleetctl manager --resume`) continues the run here;
               the records after it are that manager's, on the same clock
    plan       file, robots [ids by agent], reason ("loaded" | "replan" | "reroute"),
               at (plan step of the old plan the new one starts from, or null),
               actions [by agent], starts [[x, y] by agent]; a reroute's also base (by agent:
               the old plan's move the new plan starts with) and done (moves of the new plan
               done already, by agent: a follower's move made before its leader left);
               walls (optional; [[x, y], ...]: the map's cells the plan keeps its reroutes
               off, around robots left between cells; a manager taking the run over keeps
               to them instead of inferring them from where robots out stand, which took a
               robot carried into a cell for one left leaning into it)
    reroute    robots [ids rerouted], around (the late robot's id), late (steps, null:
               out), gain (steps sooner, predicted), text (the operator's line), plan (its
               file), base [by agent: the old plan's move the new plan starts with], look
               (s from the look's cut to the hand-over): the run was handed over to a
               reroute's plan without stopping (the `plan` record before it); dispatches,
               actions and commands after it count in the new plan
    reroute_mode  mode ("off" | "propose" | "auto"), scope ("held" | "all"), trim (optional,
               true | false), by (operator): the reroute mode, scope or trim switched
    reroute_proposed  proposal (id), robots, text: a reroute awaits the operator (propose mode)
    reroute_dropped   reason, robots and look (optional, as in reroute): a reroute found was
               not handed over (the robots moved since, a proposal gone stale, a look that
               failed); nothing changed
    state      run ("waiting" | "running" | "paused" | "stopped" | "done" |
               "failed"), reason
    strategy   name, settings {}, by ("start" | operator's console id)
    operator   console, action, args {}, ok (bool), reason (refused requests: the
               first of each console a minute; the rest are counted in `refused`)
    refused    console, requests (how many refused requests were not recorded),
               seconds (the window they came in)
    command    robot, id, type ("drive" | "turn" | "stop" | "get_status"),
               x, y, time (drive) | angle (turn), action (plan action index or null)
    reply      robot, id, type ("accepted" | "completed" | "failed" | "status"),
               reason (failed), duplicate (accepted)
    dispatch   robot, index, step, src, dst, waited (s the robot was ready
               before it), released_by (robot id or null: the operator, unless cause
               says otherwise), cause (optional: "reroute" when the rerouting ended the
               wait, a look that kept new moves back or the hand-over to its plan)
    action     robot, index, phase ("started" | "completed"), src, dst
    out        robot, why ("disabled" | "failed" | null = back in), reason
    pass       robot, passed (robot ids), cell [x, y], taken_back (bool), index,
               passed_index (their moves into the cell): a re-ordering strategy lets
               `robot` into `cell` before `passed`, which was due first (taken_back:
               `passed` had been sent that move, stood still, and gave it back)
    link       robot, state ("up" | "down" | "failed"), reason, restarted
    fault      robot, faults [strings] (a change of the robot's fault list)
    poses      p [[robot, x, y, theta, source ("robot" | "vicon"), age_s], ...]
               (every robot's pose, at 10 Hz or more)
    waits      w [[robot, [robot ids it waits for], cell or null, reason], ...]
               (written when the set of waits changes)
    vicon      robot, event ("disagree" | "agree" | "stale" | "seen"), distance
    end        reason, arrived, robots (counts), summary {} (the figures the
               manager printed; `closest`: {distance_m, robots [a, b], t,
               place [x, y]}, the closest approach of the run)
"""
from __future__ import annotations

from typing import Dict, Tuple

#: Bumped when a field changes meaning; readers refuse newer major versions.
FORMAT_VERSION = 1

#: Every kind and the fields a writer must give it (others may follow).
KINDS: Dict[str, Tuple[str, ...]] = {
    "run": ("version", "started", "source", "time_unit", "plan", "robots", "strategy"),
    "plan": ("file", "robots", "reason"),
    "state": ("run",),
    "strategy": ("name",),
    "operator": ("action", "ok"),
    "command": ("robot", "id", "type"),
    "reply": ("robot", "id", "type"),
    "dispatch": ("robot", "index", "step", "src", "dst"),
    "action": ("robot", "index", "phase"),
    "out": ("robot", "why"),
    "pass": ("robot", "passed", "cell"),
    "link": ("robot", "state"),
    "fault": ("robot", "faults"),
    "poses": ("p",),
    "waits": ("w",),
    "vicon": ("robot", "event"),
    "end": ("reason",),
    "resume": ("started", "plan"),
    "refused": ("console", "requests"),
    "reroute": ("robots", "around", "gain"),
    "reroute_mode": ("mode",),
    "reroute_proposed": ("proposal", "robots"),
    "reroute_dropped": ("reason",),
}

#: Kinds a manager started again on the folder needs (what was decided and sent): written
#: through at once, so that a killed manager loses none of them (poses wait for the flush).
DURABLE = frozenset(("run", "plan", "state", "strategy", "command", "reply", "dispatch", "action",
                     "out", "resume", "end", "reroute"))

EVENTS_FILE = "events.jsonl"
DEFINITIONS_FILE = "robot_definitions.txt"


def size_fields(size: "RobotSize") -> Dict[str, float]:  # noqa: F821
    """A robot size as the `run` record carries it."""
    return {"diameter_m": size.diameter, "margin_m": size.margin, "cell_m": size.cell,
            "safe_m": round(size.safe, 6)}


def approach_fields(closest: "Approach", size: "RobotSize") -> Dict[str, object]:  # noqa: F821
    """The closest approach of a run as the `end` record's summary carries it."""
    return {"distance_m": round(closest.distance * size.cell, 4), "robots": list(closest.agents),
            "t": round(closest.time, 4), "place": [round(v, 3) for v in closest.place]}


def plan_file(number: int) -> str:
    """File name of the run's `number`-th plan (1 = the plan it started with)."""
    return "plan-{}.txt".format(number)
