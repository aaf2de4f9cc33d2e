"""The report of one run folder, from its records alone (manager or `fleetctl simulate --log`).

Charts (each keeps the numbers it plots in `Chart.data`):

    gantt      per robot, over time: moving (action started -> completed), and within
               a move the stretches where its reported pose stood still for a second
               or more (stalled: a slow or stuck robot others may wait on), turning
               (a turn command -> its completion), waiting and on whom (`waits`),
               disabled, faults (`out` failed, `fault`)
    progress   position along the plan over time: the plan step each robot has
               reached, executed against planned (planned only when time is in steps)
    deviation  distance of each reported pose (robot feedback, Vicon) from where the
               robot should be: its cell at rest, the segment of its move while moving

and the events, in words (`words`), as a table filterable by a word, a robot and a kind,
replans and operator actions marked there and on the timelines. Robots have the
colours the live console gives them (their robot_definitions.txt colours, kept in
the run folder; else distinct ones), and each legend lists what its chart draws.
"""
from __future__ import annotations

import math
from collections import defaultdict
from typing import Any, Callable, Dict, List, Optional, Tuple

from console.palette import distinct_colours, hex_colour
from fleet_common.angles import wrap_angle
from fleet_common.errors import FleetError
from fleet_common.robots import colour_to_rgb, read_robot_definitions
from fleet_common.runlog import RunFolder

from .figures import Chart, new_figure, to_png
from .html import Page, Table
from .words import OPERATOR, REPLAN, Line, words

COLOURS = {"moving": "#3a9a3a", "stalled": "#1f4d1f", "turning": "#4a7fc1", "waiting": "#f0a020",
           "delayed": "#b58ad6", "disabled": "#999999", "fault": "#d03030"}
#: A moving robot whose pose stays within this many cells and radians (a turn is progress
#: too) for STALL_S seconds is stalled.
STALL_CELLS = 0.02
STALL_RAD = 0.05
STALL_S = 1.0
Span = Tuple[float, float]
MAX_EVENTS = 2000


def robot_colours(run: RunFolder) -> Dict[int, str]:
    """Each robot's colour as the live console draws it: its definition's, else a distinct one."""
    spare = distinct_colours(len(run.robots))
    by_id: Dict[int, str] = {}
    path = run.definitions
    if path is not None:
        try:
            for d in read_robot_definitions(path):
                try:
                    by_id[d.id] = hex_colour(colour_to_rgb(d.colour))
                except ValueError:
                    pass
        except (FleetError, OSError):
            pass
    return {rid: by_id.get(rid, spare[i]) for i, rid in enumerate(run.robots)}


def file_cells(run: RunFolder) -> Callable[[Any], Tuple[float, float]]:
    """Base cells -> the run's plan file's own coordinates (as its messages said them)."""
    from fleet_common.formats.mapsearch import default_map_dirs
    from fleet_common.formats.solution import read_solution

    plans = run.plan_files()
    try:
        sol = read_solution(str(plans[0]), map_dirs=default_map_dirs()) if plans else None
    except (FleetError, OSError):
        sol = None
    if sol is None or sol.orientation != "mapf-ir":
        return lambda c: (float(c[0]), float(c[1]))
    height = sol.grid.height
    return lambda c: (float(c[0]), float(height - 1 - float(c[1])))


def _end(run: RunFolder) -> float:
    return max((float(r.get("t", 0.0)) for r in run.records), default=0.0)


def timelines(run: RunFolder) -> Dict[int, Dict[str, List[Any]]]:
    """Per robot id, its spans by state; waiting spans carry the robots waited for."""
    end = _end(run)
    lines: Dict[int, Dict[str, List[Any]]] = {r: defaultdict(list) for r in run.robots}
    started: Dict[Tuple[int, int], float] = {}
    dispatched: Dict[Tuple[int, int], float] = {}
    free_at: Dict[int, float] = {}  # when each robot last completed a move
    turns: Dict[Tuple[int, Any], float] = {}
    out_since: Dict[int, Tuple[str, float]] = {}
    fault_since: Dict[int, float] = {}
    waiting: Dict[int, Tuple[float, Tuple[int, ...]]] = {}
    running = False  # before the first Start, robots wait for the operator, not for each other
    for rec in run.records:
        k, t = rec.get("k"), float(rec.get("t", 0.0))
        robot = rec.get("robot")
        if k == "state" and rec.get("run") == "running":
            running = True
        if k == "dispatch":
            dispatched[(robot, rec["index"])] = t
        elif k == "action":
            if rec.get("phase") == "started":
                started[(robot, rec["index"])] = t
                ready = max(dispatched.pop((robot, rec["index"]), t), free_at.get(robot, 0.0))
                if t > ready + 1e-9:  # it had its move but did not start: a delay
                    lines.setdefault(robot, defaultdict(list))["delayed"].append((ready, t))
            elif (robot, rec["index"]) in started:
                lines.setdefault(robot, defaultdict(list))["moving"].append((started.pop((robot, rec["index"])), t))
                free_at[robot] = t
        elif k == "command" and rec.get("type") == "turn":
            turns[(robot, rec.get("id"))] = t
        elif k == "reply" and rec.get("type") in ("completed", "failed") and (robot, rec.get("id")) in turns:
            lines.setdefault(robot, defaultdict(list))["turning"].append((turns.pop((robot, rec.get("id"))), t))
        elif k == "out":
            if robot in out_since:
                why, since = out_since.pop(robot)
                lines.setdefault(robot, defaultdict(list))[why].append((since, t))
            if rec.get("why") is not None:
                out_since[robot] = ("fault" if rec["why"] == "failed" else "disabled", t)
        elif k == "fault":
            if rec.get("faults") and robot not in fault_since:
                fault_since[robot] = t
            elif not rec.get("faults") and robot in fault_since:
                lines.setdefault(robot, defaultdict(list))["fault"].append((fault_since.pop(robot), t))
        elif k == "waits" and running:
            now = {w[0]: tuple(w[1]) for w in rec.get("w", [])}
            for r, (since, on) in list(waiting.items()):
                if now.get(r) != on:
                    lines.setdefault(r, defaultdict(list))["waiting"].append((since, t, list(on)))
                    del waiting[r]
            for r, on in now.items():
                if r not in waiting:
                    waiting[r] = (t, on)
    for (robot, _), since in started.items():
        lines[robot]["moving"].append((since, end))
    for robot, (why, since) in out_since.items():
        lines[robot][why].append((since, end))
    for robot, since in fault_since.items():
        lines[robot]["fault"].append((since, end))
    for r, (since, on) in waiting.items():
        lines[r]["waiting"].append((since, end, list(on)))
    tracks = _tracks(run)
    for robot, states in lines.items():
        stalls = [s for since, until in states.get("moving", [])
                  for s in _still(tracks.get(robot, []), since, until)]
        if stalls:
            states["stalled"] = stalls
    return {r: dict(v) for r, v in lines.items()}


Pose = Tuple[float, float, float, float]  # t, x, y, heading


def _tracks(run: RunFolder) -> Dict[int, List[Pose]]:
    """Per robot, its reported poses over time."""
    tracks: Dict[int, List[Pose]] = defaultdict(list)
    for rec in run.of("poses"):
        t = float(rec.get("t", 0.0))
        for entry in rec.get("p") or []:
            if isinstance(entry, list) and len(entry) >= 4 and None not in entry[1:4]:
                tracks[entry[0]].append((t, float(entry[1]), float(entry[2]), float(entry[3])))
    return tracks


def _still(track: List[Pose], since: float, until: float) -> List[Span]:
    """Within [since, until], the stretches of at least STALL_S where the pose did not change."""
    spans: List[Span] = []
    anchor: Optional[Pose] = None
    last = since
    for t, x, y, heading in track:
        if t < since or t > until:
            continue
        if anchor is None or math.hypot(x - anchor[1], y - anchor[2]) > STALL_CELLS or \
                abs(wrap_angle(heading - anchor[3])) > STALL_RAD:
            if anchor is not None and last - anchor[0] >= STALL_S:
                spans.append((anchor[0], last))
            anchor = (t, x, y, heading)
        last = t
    if anchor is not None and last - anchor[0] >= STALL_S:
        spans.append((anchor[0], last))
    return spans


def marks(lines: List[Line]) -> List[Tuple[float, Optional[int], str]]:
    """What the timelines mark: (time, the robot or None for the whole run, a short label)."""
    out: List[Tuple[float, Optional[int], str]] = []
    for line in lines:
        if line.mark == REPLAN:
            out.append((line.t, None, "replan"))
        elif line.mark == OPERATOR:
            action = line.text.split(": ", 1)[1] if ": " in line.text else line.text
            out.append((line.t, line.robot, action.split(" (")[0]))
    return out


def gantt_chart(run: RunFolder, lines: Optional[List[Line]] = None) -> Chart:
    spans = timelines(run)
    robots = list(spans)
    colours = robot_colours(run)
    marked = marks(lines if lines is not None else words(run.records))
    fig = new_figure((8.0, min(0.32 * len(robots) + 1.2, 24.0)))
    ax = fig.add_subplot(1, 1, 1)
    drawn = set()
    for y, robot in enumerate(robots):
        for state, colour in COLOURS.items():  # in this order: a stall is drawn over its move
            bars = [(s[0], s[1] - s[0]) for s in spans[robot].get(state, []) if s[1] > s[0]]
            if bars:
                height = 0.8 if state != "waiting" else 0.5
                ax.broken_barh(bars, (y - height / 2, height), facecolors=colour)
                drawn.add(state)
        if len(robots) <= 20:
            for since, until, on in spans[robot].get("waiting", []):
                if on and until - since > 0.8:
                    ax.text((since + until) / 2, y, "on " + ",".join(map(str, on)), ha="center",
                            va="center", fontsize=6)
    row = {robot: y for y, robot in enumerate(robots)}
    for t, robot, label in marked:
        if robot is None:  # the whole run: a line across every robot
            ax.axvline(t, color="#2b4c9b" if label != "replan" else "#c05800", linestyle=":", linewidth=1)
            ax.text(t, -0.7, label, rotation=90, fontsize=6, ha="right", va="bottom",
                    color="#c05800" if label == "replan" else "#2b4c9b")
            drawn.add("replan" if label == "replan" else "operator")
        elif robot in row:
            ax.plot([t], [row[robot]], marker="v", color="#2b4c9b", markersize=6)
            ax.text(t, row[robot] - 0.45, label, fontsize=6, ha="center", va="bottom", color="#2b4c9b")
            drawn.add("operator")
    labels = ["robot {}".format(r) for r in robots] if len(robots) <= 40 else [str(r) for r in robots]
    ax.set_yticks(range(len(robots)), labels, fontsize=7 if len(robots) <= 40 else 4)
    for tick, robot in zip(ax.get_yticklabels(), robots):  # the robot's own colour, as on the console
        tick.set_color(colours.get(robot, "#222222"))
    ax.invert_yaxis()
    ax.set_xlabel("time ({})".format("plan steps" if run.time_unit == "step" else "s"))
    handles = [_patch(c, s) for s, c in COLOURS.items() if s in drawn]
    if "operator" in drawn:
        handles.append(_mark("#2b4c9b", "operator's action"))
    if "replan" in drawn:
        handles.append(_mark("#c05800", "replan"))
    if handles:
        ax.legend(handles=handles, fontsize=7, ncol=min(len(handles), 7), loc="upper center",
                  bbox_to_anchor=(0.5, 1.08))
    ax.grid(axis="x", alpha=0.3)
    words_of = {"moving": "green: moving", "stalled": "dark green: stalled (its pose still for a second or more)",
                "turning": "blue: turning", "waiting": "orange: waiting for other robots (on whom)",
                "delayed": "purple: delayed (free to move, not moving)", "disabled": "grey: disabled",
                "fault": "red: fault", "operator": "blue marks: the operator's actions",
                "replan": "dotted orange: a replan"}
    caption = "; ".join(words_of[s] for s in list(COLOURS) + ["operator", "replan"] if s in drawn)
    data = dict(spans)
    data["marks"] = marked  # type: ignore[assignment]
    return Chart("gantt", "What each robot did", to_png(fig), data,
                 (caption[0].upper() + caption[1:] + ".") if caption else "Nothing happened.")


def _patch(colour: str, label: str) -> Any:
    from matplotlib.patches import Patch
    return Patch(facecolor=colour, label=label)


def _mark(colour: str, label: str) -> Any:
    from matplotlib.lines import Line2D
    return Line2D([0], [0], color=colour, linestyle=":", marker="v", label=label)


def _action_steps(run: RunFolder) -> Dict[Tuple[int, int], int]:
    return {(r["robot"], r["index"]): r["step"] for r in run.of("dispatch")}


def progress_chart(run: RunFolder) -> Chart:
    steps = _action_steps(run)
    data: Dict[int, Dict[str, List[Tuple[float, float]]]] = {r: {"executed": [(0.0, 0.0)], "planned": []}
                                                             for r in run.robots}
    for rec in run.of("action"):
        if rec.get("phase") == "completed" and (rec["robot"], rec["index"]) in steps:
            step = steps[(rec["robot"], rec["index"])] + 1
            data.setdefault(rec["robot"], {"executed": [(0.0, 0.0)], "planned": []})
            data[rec["robot"]]["executed"].append((float(rec["t"]), float(step)))
            data[rec["robot"]]["planned"].append((float(step), float(step)))
    fig = new_figure((7.5, 4.2))
    ax = fig.add_subplot(1, 1, 1)
    colours = robot_colours(run)
    for robot, series in data.items():
        xs, ys = zip(*series["executed"])
        ax.step(xs, ys, where="post", linewidth=1, color=colours.get(robot),
                label="robot {}".format(robot) if len(data) <= 10 else None)
    top = max((p[0] for s in data.values() for p in s["planned"]), default=1.0)
    # on schedule: a step a step (simulated runs), or a step every `step_time` seconds (the manager's)
    per_step = 1.0 if run.time_unit == "step" else _step_time(run)
    begin = next((float(r["t"]) for r in run.of("state") if r.get("run") == "running"), 0.0)
    schedule = ""
    if per_step is not None:
        ax.plot([begin, begin + top * per_step], [0, top], "k--", linewidth=1, label="on schedule")
        schedule = "; dashed: on schedule ({})".format(
            "a plan step each time step" if run.time_unit == "step"
            else "a plan step every {:g} s, from Start".format(per_step))
    ax.set_xlabel("time ({})".format("plan steps" if run.time_unit == "step" else "s"))
    ax.set_ylabel("plan step reached")
    ax.grid(alpha=0.3)
    if ax.get_legend_handles_labels()[0]:
        ax.legend(fontsize=7, ncol=2)
    return Chart("progress", "Position along the plan: executed against planned", to_png(fig), data,
                 "Each robot's last completed move, as the plan step it ends, in the robot's colour{}.".format(
                     schedule))


def _step_time(run: RunFolder) -> Optional[float]:
    value = run.run.get("step_time")
    return float(value) if isinstance(value, (int, float)) and value > 0 else None


def _segment_distance(px: float, py: float, a: List[float], b: List[float], frac_free: bool) -> float:
    ax, ay, bx, by = float(a[0]), float(a[1]), float(b[0]), float(b[1])
    dx, dy = bx - ax, by - ay
    length2 = dx * dx + dy * dy
    f = 0.0 if length2 == 0 or not frac_free else max(0.0, min(1.0, ((px - ax) * dx + (py - ay) * dy) / length2))
    return math.hypot(px - (ax + f * dx), py - (ay + f * dy))


def deviations(run: RunFolder) -> Dict[str, Dict[int, Dict[str, List[float]]]]:
    """Per pose source, per robot: times and distances (cells) from where it should be."""
    state: Dict[int, Tuple[List[float], List[float], bool]] = {}  # robot -> (a, b, moving)
    out: Dict[str, Dict[int, Dict[str, List[float]]]] = {}
    for rec in run.records:
        k = rec.get("k")
        if k in ("dispatch", "action") and rec["robot"] not in state:
            state[rec["robot"]] = (rec["src"], rec["src"], False)
        if k == "action":
            moving = rec.get("phase") == "started"
            state[rec["robot"]] = (rec["src"], rec["dst"], moving) if moving else (rec["dst"], rec["dst"], False)
        elif k == "poses":
            t = float(rec["t"])
            for p in rec.get("p", []):
                robot, x, y, source = p[0], p[1], p[2], p[4] if len(p) > 4 else "robot"
                a, b, moving = state.get(robot, ([x, y], [x, y], False))
                series = out.setdefault(str(source), {}).setdefault(robot, {"t": [], "dev": []})
                series["t"].append(t)
                series["dev"].append(_segment_distance(float(x), float(y), a, b, moving))
    return out


def deviation_chart(run: RunFolder) -> Chart:
    data = deviations(run)
    sources = sorted(data) or ["robot"]
    fig = new_figure((7.5, 2.8 * len(sources)))
    colours = robot_colours(run)
    for i, source in enumerate(sources):
        ax = fig.add_subplot(len(sources), 1, i + 1)
        for robot, s in data.get(source, {}).items():
            ax.plot(s["t"], s["dev"], linewidth=0.8, color=colours.get(robot),
                    label="robot {}".format(robot) if len(data[source]) <= 10 else None)
        ax.set_title("pose source: {}".format(source), fontsize=9)
        ax.set_ylabel("distance from plan (cells)")
        ax.grid(alpha=0.3)
        if data.get(source) and len(data[source]) <= 10:
            ax.legend(fontsize=7, ncol=2)
    ax.set_xlabel("time ({})".format("plan steps" if run.time_unit == "step" else "s"))
    return Chart("deviation", "Deviation of the reported pose from the plan", to_png(fig), data,
                 "At rest: distance from the robot's cell; moving: from the segment of its move.")


def event_table(lines: List[Line]) -> Table:
    """The events in words, filterable by a word, a robot and a kind (operator actions and
    replans marked)."""
    shown = lines[:MAX_EVENTS]
    rows = [["{:.2f}".format(line.t), "" if line.robot is None else line.robot, line.kind, line.text]
            for line in shown]
    tags = [("" if line.robot is None else str(line.robot), line.kind, line.mark) for line in shown]
    return Table(["t", "robot", "kind", "what happened"], rows, left=4, name="events", tags=tags)


def run_page(run: RunFolder) -> Page:
    r = run.run
    page = Page("Run report: {}".format(run.folder.name))
    page.meta.append("source {}, started {}, strategy {}, {} robots, time in {}".format(
        r.get("source"), r.get("started"), r.get("strategy_text") or r.get("strategy"), len(run.robots),
        "plan steps" if run.time_unit == "step" else "seconds"))
    end: Optional[dict] = run.last("end")
    if end is not None:
        for line in (end.get("summary") or {}).get("lines", []):
            page.meta.append(line)
    elif run.torn:
        page.meta.append("the run did not end cleanly (its last line was cut off)")
    for rec in run.of("resume"):  # a manager that died, replaced: one run, said where
        page.meta.append("resumed at {:.1f} s by a manager started again on this folder, after {:.1f} s "
                         "without one ({}, {} actions done)".format(
                             float(rec.get("t", 0.0)), float(rec.get("downtime") or 0.0), rec.get("plan"),
                             sum(rec.get("completed") or [])))
    lines = words(run.records, file_cells(run))
    page.add("Robots over time", gantt_chart(run, lines))
    page.add("Planned and executed", progress_chart(run), deviation_chart(run))
    count = len(lines)
    page.add("Events", "{} events{}, cells in the plan file's coordinates; poses and waits are in the charts "
             "above. Operator actions are blue, replans orange.".format(
                 count, " (the first {} listed)".format(MAX_EVENTS) if count > MAX_EVENTS else ""),
             event_table(lines))
    return page
