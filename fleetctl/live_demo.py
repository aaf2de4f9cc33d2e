"""The live demo: the lab scenario on virtual robots, driven by the manager, seen in the console.

Theory of operation. Three processes, each in its own process group
(`fleet_common.children`), all on 127.0.0.1 with free ports (`fleet_common.local_fleet`), never
the lab's addresses:

1. `fleetctl virtual-fleet`: the five lab robots on a definitions copy, with
   moderate random delays and one planned stall (`pick_stall`: the move of one
   robot that another robot's next move depends on most closely, about a third
   into the run), so a visitor sees one robot wait for another; with `switch`, a
   stall a re-ordering strategy can get around (`pick_passing_stall`); else,
   with rerouting on, a stall the manager's rule reroutes around
   (`pick_rerouting_stall`);
2. `fleetctl manager` on the demo's plan, ADG, until the run is done, writing
   its run folder (`reroute`: its --reroute mode);
3. `fleetctl console`, the live console in its presentation view for visitors
   (`--present`: the map full screen, a legend, the run's story in words), which
   presses Start once every robot is connected (`--start-when-ready`), with
   `switch` switches the run to that strategy once a robot waits for the
   stalled one (`--switch-when-stalled`, as an operator would), closes a
   few seconds after the run is done, and records frames into the run folder when
   it runs headless (frames.txt gives the sentences told at each frame).

The demo waits for the manager to finish, then for the console, then stops the
fleet; Ctrl-C, a console closed early or a process that dies stop everything,
in that order. At the end the run folder gets `summary.txt` (what the demo did
and the manager's summary), `report.html` (the run read as `fleetctl report`
reads it: what each robot did over time, planned against executed, the events)
and the fleet's and console's logs, and the demo prints where they are.
"""
from __future__ import annotations

import os
import shutil
import tempfile
import threading
import time
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Callable, List, Optional, Sequence

from fleet_common.children import Child
from fleet_common.errors import FleetError
from fleet_common.grid import Coord, Grid
from fleet_common.local_fleet import local_definitions
from fleet_common.plan import Plan
from fleet_common.robots import RobotDefinition

from virtual_fleet.stalls import parse_stall

if TYPE_CHECKING:
    from fleet_common.delays.draw import MoveFates
    from fleet_common.execution.reroute import RerouteRule

__all__ = ["StallChoice", "pick_stall", "pick_passing_stall", "pick_rerouting_stall", "DemoSettings",
           "run_live_demo"]

#: The virtual robots' driving speed (cells per fleet second): a nominal move of 2 s.
SPEED = 0.5
#: Moves start after up to this many nominal moves (the delay-model language's unit).
DELAY = 0.2
#: Fleet seconds a turn at a corner adds to a plan step (the robots turn ahead while they wait,
#: so less than a full turn).
TURN = 0.2
#: A plan step as the virtual robots take it, in nominal moves: the drive, the mean start
#: delay, a turn at corners (the manager's --step-time is this many moves of fleet time).
STEP_MOVES = 1.0 + DELAY / 2 + TURN * SPEED


@dataclass(frozen=True)
class StallChoice:
    agent: int    # the plan agent that stalls
    move: int     # during its move number `move` (from 1: the virtual fleet counts drives)
    waiter: int   # the agent that then waits for it
    cell: Coord   # the cell the waiter waits to enter (the one the staller is leaving)
    step: int     # the plan step the move starts at


def pick_stall(plan: Plan, at: float = 0.35) -> Optional[StallChoice]:
    """The move whose delay another robot feels soonest: robot A leaving cell c at step t,
    robot B entering c right after; among the closest such pairs, the one nearest `at` of
    the way through the plan. None if no robot ever enters a cell another one left."""
    pos = plan.positions
    best = None
    for a in range(plan.num_agents):
        moves = [t for t in range(plan.makespan) if (pos[t + 1, a] != pos[t, a]).any()]
        for k, t in enumerate(moves, 1):
            cell = tuple(int(v) for v in pos[t, a])
            for b in range(plan.num_agents):
                if b == a:
                    continue
                enters = [u for u in range(t, plan.makespan)
                          if tuple(pos[u + 1, b]) == cell and tuple(pos[u, b]) != cell]
                if not enters:
                    continue
                key = (enters[0] - t, abs(t - at * plan.makespan), a, b)
                if best is None or key < best[0]:
                    best = (key, StallChoice(a, k, b, cell, t))  # type: ignore[arg-type]
    return None if best is None else best[1]


def one_stall(n: int, i: int, moves: float, wait: float = 0.0) -> "MoveFates":
    """The fates of `n` moves at nominal speed, each starting after `wait`, move `i` halting
    `moves` moves halfway through (as the virtual fleet's planned stall does)."""
    import numpy as np

    from fleet_common.delays.draw import MoveFates

    stall = np.zeros(n)
    stall[i] = moves
    return MoveFates(np.full(n, wait), np.ones(n), stall, np.full(n, 0.5), np.zeros(n), np.zeros(n))


def pick_passing_stall(plan: Plan, moves: float, strategy: str = "reorder",
                       at: float = 0.35) -> Optional[StallChoice]:
    """A stall `strategy` gets around: robot A halts `moves` moves halfway through one drive,
    under the ADG robot B then waits for it at a cell A has yet to reach, and switched to
    `strategy` a moment later B goes first and arrives sooner. Tried on the simulator with
    robots of the lab's size and no other delay; among the stalls that save B half the stall
    or more, the one nearest `at` of the way through the plan (then the larger saving). The
    choice's `cell` is where B goes first. None if no stall does."""
    import numpy as np

    from fleet_common.execution import Engine, make_strategy
    from fleet_common.execution.events import SwitchStrategy
    from fleet_common.execution.simulate import simulate
    from fleet_common.robot_size import RobotSize

    size = RobotSize()
    table = Engine(plan, follow=True).table  # the moves, as every simulation below numbers them
    n = len(table.agent)
    best = None
    for i in range(n):
        fates = one_stall(n, i, moves)
        step = float(table.step[i])
        switched = simulate(plan, "adg", size=size, fates=fates,
                            controls=[SwitchStrategy(make_strategy(strategy), step + 1.0)])
        passes = [p for p in switched.engine.run.passes if p.passed == table.agent[i]]  # type: ignore[attr-defined]
        if not passes or switched.collisions:
            continue
        fixed = simulate(plan, "adg", size=size, fates=fates)
        b = passes[0].agent  # type: ignore[attr-defined]
        gain = (fixed.metrics.agents[b].arrival or 0.0) - (switched.metrics.agents[b].arrival or 0.0)
        if gain <= 0:
            continue
        a = int(table.agent[i])
        k = int(np.count_nonzero(table.agent[:i + 1] == a))
        cell = table.coord(passes[0].cell)  # type: ignore[attr-defined]
        if gain < moves / 2:
            continue  # a pass a visitor would hardly notice
        key = (abs(step - at * plan.makespan), -round(gain, 3), i)
        if best is None or key < best[0]:
            best = (key, StallChoice(a, k, b, cell, int(step)))  # type: ignore[arg-type]
    return None if best is None else best[1]


def pick_rerouting_stall(plan: Plan, grid: Grid, moves: float, rule: Optional[RerouteRule] = None,
                         at: float = 0.35) -> Optional[StallChoice]:
    """A stall the manager's reroute rule (`rule`, default the manager's own) gets around: robot A
    halts `moves` moves halfway through one drive, robot B is held up behind it, and the rule gives
    A or B a new path so that B arrives sooner. Each move of the plan is tried as the stall on the
    simulator, as the demo's manager and fleet run: robots of the lab's size, each move starting
    after the fleet's mean start delay, the manager's plan step (`STEP_MOVES`), the rule as the
    manager applies it; the run is compared with the same run without rerouting. Among the stalls
    whose first reroute saves its first held-up robot (B) half the stall or more, with no collision
    and every robot home, the one nearest `at` of the way through the plan (then the larger
    saving). The choice's `cell` is where A halts (the cell it is leaving). None if no stall does."""
    import numpy as np

    from fleet_common.execution import Engine
    from fleet_common.execution.reroute import RerouteRule
    from fleet_common.execution.simulate import simulate
    from fleet_common.robot_size import RobotSize

    size = RobotSize()
    rule = rule or RerouteRule()
    table = Engine(plan, follow=True).table  # the moves, as every simulation below numbers them
    n = len(table.agent)
    best = None
    for i in range(n):
        fates = one_stall(n, i, moves, wait=DELAY / 2)
        rerouted = simulate(plan, "adg", size=size, fates=fates, reroute=rule, grid=grid, step_time=STEP_MOVES)
        if not rerouted.reroutes or rerouted.collisions or rerouted.unfinished():
            continue
        b = rerouted.reroutes[0][1].held[0]
        fixed = simulate(plan, "adg", size=size, fates=fates, step_time=STEP_MOVES)
        gain = (fixed.metrics.agents[b].arrival or 0.0) - (rerouted.metrics.agents[b].arrival or 0.0)
        if gain < moves / 2:
            continue  # a reroute a visitor would hardly notice
        a = int(table.agent[i])
        k = int(np.count_nonzero(table.agent[:i + 1] == a))
        step = float(table.step[i])
        key = (abs(step - at * plan.makespan), -round(gain, 3), i)
        if best is None or key < best[0]:
            best = (key, StallChoice(a, k, b, table.coord(table.src[i]), int(step)))  # type: ignore[arg-type]
    return None if best is None else best[1]


@dataclass
class DemoSettings:
    log_dir: Optional[Path] = None  # where run folders go (None: the manager's default)
    time_scale: float = 1.5
    delay_model: str = "delay={:g},slow=0.1:1.5".format(DELAY)
    seed: int = 0
    stall: str = "auto"          # auto, none, or R:K:S as `fleetctl virtual-fleet --stall`
    stall_seconds: float = 8.0   # fleet seconds of the automatic stall
    switch: Optional[str] = None  # the console switches to this strategy once a robot waits for the stall
    reroute: str = "off"         # the manager's --reroute mode (not off: the automatic stall is one it reroutes)
    headless: bool = False
    record: bool = False
    linger: float = 3.0
    time_limit: float = 110.0


def stall_argument(settings: DemoSettings, plan: Plan, robots: Sequence[RobotDefinition],
                   grid: Optional[Grid] = None) -> Optional[str]:
    """The fleet's --stall value (None: no stall): with `switch`, a stall that strategy gets around;
    else with rerouting on (and the map, `grid`), one the manager reroutes around; else (or when
    there is none) the ADG's."""
    if settings.stall == "none":
        return None
    if settings.stall != "auto":
        return settings.stall
    choice = None
    if settings.switch is not None:
        choice = pick_passing_stall(plan, settings.stall_seconds * SPEED, settings.switch)
    elif settings.reroute != "off" and grid is not None:
        choice = pick_rerouting_stall(plan, grid, settings.stall_seconds * SPEED)
    if choice is None:
        choice = pick_stall(plan)
    if choice is None:
        return None
    return "{}:{}:{:g}".format(robots[choice.agent].id, choice.move, settings.stall_seconds)


def run_live_demo(solution: Path, plan: Plan, robots: Sequence[RobotDefinition], settings: DemoSettings,
                  say: Callable[[str], None] = print, grid: Optional[Grid] = None) -> int:
    """Run it (`grid`: the plan's map, for a stall the manager reroutes around); the exit status (0:
    every robot arrived, no collision, the console saw it)."""
    say = _whole_lines(say)  # the manager's lines come from its reader thread
    work = Path(tempfile.mkdtemp(prefix="fleetcontrol-demo-"))
    children: List[Child] = []
    try:
        definitions, feedback, port = local_definitions(robots[:plan.num_agents], work / "robots.txt")
        endpoint = "tcp://127.0.0.1:{}".format(port)
        stall = stall_argument(settings, plan, robots, grid)
        fleet_args = ["virtual-fleet", "--definitions", str(definitions), "--no-curve",
                      "--instance", str(solution),  # the robots stand on the plan's starts
                      "--time-scale", "{:g}".format(settings.time_scale), "--feedback-base", str(feedback),
                      "--delay-model", settings.delay_model, "--seed", str(settings.seed),
                      "--speed", "{:g}".format(SPEED), "--log-level", "warning"]
        if stall is not None:
            fleet_args += ["--stall", stall]
        say("live run: {} virtual robots on 127.0.0.1 (time x{:g}, delays {}{}), manager with ADG{}{}, "
            "console on {}".format(plan.num_agents, settings.time_scale, settings.delay_model,
                                   "; " + parse_stall(stall).describe() if stall else "",
                                   "" if settings.reroute == "off" else ", reroute " + settings.reroute,
                                   " (the console switches to {} once a robot waits for a stalled one)".format(
                                       settings.switch) if settings.switch else "", endpoint))
        children.append(Child.start("fleet", fleet_args, log=work / "virtual-fleet.log"))
        step_time = STEP_MOVES / SPEED / settings.time_scale  # a plan step as the virtual robots take it
        manager = Child.start("manager", [
            "manager", str(solution), "--definitions", str(definitions), "--no-curve", "--host", "127.0.0.1",
            "--bind", endpoint, "--strategy", "adg", "--until-done", "--time-limit", "{:g}".format(settings.time_limit),
            "--connect-timeout", "30", "--step-time", "{:.3f}".format(step_time), "--reroute", settings.reroute]
            + (["--log", str(settings.log_dir)] if settings.log_dir is not None else []),
            on_line=lambda line: say("  manager: " + (line[9:] if line.startswith("manager: ") else line)))
        children.append(manager)
        banner = manager.wait_for_line(lambda line: "run folder" in line or "fleetctl manager" in line, 30.0)
        if banner is None or "run folder" not in banner:
            raise FleetError("the manager did not start: {}".format(" / ".join(manager.lines[-3:]) or "no output"))
        folder = Path(banner.rsplit("run folder", 1)[1].strip())
        console = _start_console(endpoint, folder, settings, work, say)
        children.append(console)
        say("processes: virtual fleet pid {}, manager pid {}, console pid {} (each in its own process "
            "group; all stopped at the end, also on Ctrl-C)".format(children[0].pid, manager.pid, console.pid))
        status = _supervise(manager, console, settings, say)
        console_code = console.wait(settings.linger + 10.0)
        if console_code is None:
            console_code = console.stop()
        children[0].stop()  # the fleet, last
        _keep(work, folder, ("virtual-fleet.log", "console.log"))
        return _report(folder, manager, console, status, console_code, say)
    except KeyboardInterrupt:
        say("interrupted: stopping the console, the manager and the fleet")
        return 130
    finally:
        for child in reversed(children):
            if child.running():
                child.stop()
        shutil.rmtree(work, ignore_errors=True)


def _whole_lines(say: Callable[[str], None]) -> Callable[[str], None]:
    """`say` for several threads: one line at a time (print writes a line and its newline apart,
    and two threads' lines ran together: "processes: ..." after "robot 1 link up")."""
    lock = threading.Lock()

    def locked(line: str) -> None:
        with lock:
            say(line)
    return locked


def _start_console(endpoint: str, folder: Path, settings: DemoSettings, work: Path,
                   say: Callable[[str], None]) -> Child:
    env = dict(os.environ)
    headless = settings.headless or not env.get("DISPLAY")
    if headless:
        env.pop("DISPLAY", None)  # the console starts its own Xvfb
    args = ["console", "--manager", endpoint, "--no-curve", "--name", "demo console", "--present",
            "--start-when-ready", "--close-when-done", "{:g}".format(settings.linger if not headless else 1.0)]
    if settings.switch is not None:
        args += ["--switch-when-stalled", settings.switch]
    if headless or settings.record:
        args += ["--record", str(folder / "frames")]
    say("console: {}".format("headless on a private Xvfb, recording frames into {}".format(folder / "frames")
                             if headless else "a window on {}".format(env.get("DISPLAY"))))
    return Child.start("console", args, log=work / "console.log", env=env)


def _supervise(manager: Child, console: Child, settings: DemoSettings, say: Callable[[str], None]) -> str:
    """Wait for the run to end; why it ended."""
    deadline = time.monotonic() + settings.time_limit + 30.0
    while time.monotonic() < deadline:
        if not manager.running():
            return "manager finished"
        if not console.running():
            say("the console closed before the run was done: stopping the demo")
            manager.stop()
            return "console closed"
        time.sleep(0.1)
    manager.stop()
    return "time limit"


def _keep(work: Path, folder: Path, names: Sequence[str]) -> None:
    for name in names:
        if (work / name).is_file() and folder.is_dir():
            shutil.copy(str(work / name), str(folder / name))


def _run_report(folder: Path, say: Callable[[str], None]) -> bool:
    """`report.html` in the run folder; a report that cannot be written is said, and the run's
    own evidence (log, summary, frames) stands without it."""
    from evaluation.report import write_report
    from evaluation.report.run import run_page
    from fleet_common.runlog import read_run

    try:
        write_report(run_page(read_run(folder)), folder / "report.html")
    except (FleetError, OSError, ValueError) as error:
        say("report: not written ({})".format(error))
        return False
    return True


def _report(folder: Path, manager: Child, console: Child, status: str, console_code: int,
            say: Callable[[str], None]) -> int:
    code = manager.wait(5.0)
    frames = sorted((folder / "frames").glob("*.png")) if (folder / "frames").is_dir() else []
    lines = ["FleetControl live demo: {}".format(status),
             "manager exit status {}, console exit status {}".format(code, console_code), ""]
    lines += manager.lines + [""]
    log = folder / "console.log"
    if log.is_file():
        lines += ["console:"] + log.read_text().splitlines()
    if frames:
        lines.append("{} frames in {} (frames.txt says when each was taken)".format(len(frames), folder / "frames"))
    (folder / "summary.txt").write_text("\n".join(lines) + "\n")
    report = _run_report(folder, say)
    say("run folder: {}".format(folder))
    say("  events.jsonl (the run log), summary.txt, {}virtual-fleet.log, console.log{}".format(
        "report.html (open it in a browser), " if report else "",
        ", frames/ ({} frames, the last {})".format(len(frames), frames[-1].name) if frames else ""))
    return 0 if code == 0 and console_code == 0 else 1
