"""Benchmark: the manager driving 300 virtual robots (or 1,000, from several fleet processes; CURVE on).

Starts `fleetctl virtual-fleet` for N robots at the starts of an instance (arena_300agents_1
by default) and `fleetctl manager` on that instance (planned by the built-in lacam, or
`--solver`), with
--start --until-done and a run folder; a scripted console watches the state stream. With
--fleets K the robots are served by K virtual-fleet processes, each a contiguous part of
one definitions file (`--robots a-b`), as several hosts would serve them. Prints:

- state messages received per second by the console (min over 1 s windows, and mean);
- command round trip, drive or turn sent -> Accepted, from the run log (p50, p99, max);
- CPU of each process (share of one core) over the run;
- the overhead ratio: executed makespan over the engine-only makespan for the same plan
  and the same move durations. Each move's duration is measured in the run (from the
  robot's first Accepted command for it after its dispatch to its completion), so the
  engine-only run (fleet_common.execution.simulate_engine) has every move take exactly
  what it took on the virtual robot; what the ratio shows is what dispatching over the
  wire adds (replies, decisions, commands), nothing else.

    .venv/bin/python bench/manager.py [--robots 300] [--time-scale 4] [--instance FILE] [--solver S [--solver-seed N]] [--fleets 1]
                                      [--robot-size turtlebot|cell] [--keep FOLDER]
                                      [--delay-model SPEC [--seed N]] [--reroute MODE [--reroute-scope S]] [--trim]

`--robot-size cell` writes a `size` line making the robots as large as a cell (no followers, no
hold points, no Releases: the run of before issue 25), to tell that work from the rest;
`--keep FOLDER` copies the run's files there (run folder, truth files, logs) for a closer look.
`--delay-model` gives the virtual robots delays (the virtual fleet's option); `--reroute auto`
has the manager reroute, and the last line counts its reroutes handed over and dropped (a
robot given a new path moved between the look's snapshot and the hand-over).

A 1,000-robot instance: bench/make_instance.py den520d.map 1000 OUT.txt --radius 60.
"""
from __future__ import annotations

import argparse
import os
import shutil
import sys
import tempfile
import time
from pathlib import Path
from typing import TYPE_CHECKING, Dict, List, Optional, Tuple

import numpy as np

if TYPE_CHECKING:
    from fleet_common.robot_size import RobotSize

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from fleet_common.execution import Engine  # noqa: E402
from fleet_common.execution.simulate import simulate_engine  # noqa: E402
from fleet_common.formats.instance import make_instance, read_instance, write_instance  # noqa: E402
from fleet_common.formats.solution import read_solution  # noqa: E402
from fleet_common.planning.pibt_turns import moves_and_turns, slowest_need  # noqa: E402
from fleet_common.robot_size import LAB_CELL_M  # noqa: E402
from fleet_common.robots import SIZE_LINE  # noqa: E402
from fleet_common.runlog import read_run  # noqa: E402
from fleet_common.transport.curve_keys import make_keys  # noqa: E402
from live import Proc, fleetctl_args, free_port_block  # noqa: E402
from virtual_fleet.kinematics import SPEED, TURN_SPEED  # noqa: E402

SHARED = Path(__file__).resolve().parents[2] / "shared" / "data" / "mapf-ir"


def cpu_seconds(pid: int) -> float:
    fields = Path("/proc/{}/stat".format(pid)).read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def percentile(values: List[float], q: float) -> float:
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, int(q * len(ordered)))]


def round_trips(records: List[dict]) -> List[float]:
    sent: Dict[Tuple[int, int], float] = {}
    out = []
    for r in records:
        if r["k"] == "command" and r.get("type") in ("drive", "turn"):
            sent[(r["robot"], r["id"])] = r["t"]
        elif r["k"] == "reply" and r.get("type") == "accepted":
            t = sent.pop((r["robot"], r["id"]), None)
            if t is not None:
                out.append(r["t"] - t)
    return out


def split_round_trips(records: List[dict], started: str, at: float,
                      truths: List[Path]) -> Tuple[List[float], List[float]]:
    """Each round trip cut where the virtual robot started the command (its truth file, wall
    clock), the run log's times put on the wall clock by the run's start: the manager's side
    and the robot's side of the latency (to about a millisecond). It needs the `run` record's
    `started` to be the wall clock at that record's `t` (a manager that wrote it later, as one
    did after issue 24, shifts every send later and the robot's side to nil)."""
    import json
    from datetime import datetime

    t0 = datetime.fromisoformat(started).timestamp() - at  # the wall clock at the log's t = 0
    executed: Dict[Tuple[int, int], float] = {}
    for truth in truths:
        for line in truth.read_text().splitlines():
            r = json.loads(line)
            if r.get("k") == "exec":
                executed.setdefault((r["robot"], r["id"]), r["t"])
    sent: Dict[Tuple[int, int], float] = {}
    outbound, back = [], []
    for r in records:
        if r["k"] == "command" and r.get("type") in ("drive", "turn"):
            sent[(r["robot"], r["id"])] = t0 + r["t"]
        elif r["k"] == "reply" and r.get("type") == "accepted":
            key = (r["robot"], r["id"])
            if key in sent and key in executed:
                outbound.append(max(0.0, executed[key] - sent[key]))
                back.append(max(0.0, t0 + r["t"] - executed[key]))
    return outbound, back


def move_durations(records: List[dict], robots: List[int], first: np.ndarray) -> np.ndarray:
    """Per flat action: completion minus the first Accepted command for it after its dispatch."""
    agent = {rid: i for i, rid in enumerate(robots)}
    dispatched: Dict[Tuple[int, int], float] = {}
    began: Dict[Tuple[int, int], float] = {}
    cmd_action: Dict[Tuple[int, int], int] = {}
    durations = np.zeros(int(first[-1]), dtype=np.float64)
    for r in records:
        k = r["k"]
        if k == "dispatch":
            dispatched[(r["robot"], r["index"])] = r["t"]
        elif k == "command" and r.get("action") is not None:
            cmd_action[(r["robot"], r["id"])] = r["action"]
        elif k == "reply" and r.get("type") == "accepted":
            a = cmd_action.get((r["robot"], r["id"]))
            key = (r["robot"], a)
            if a is not None and key in dispatched and key not in began:
                began[key] = max(r["t"], dispatched[key])
        elif k == "action" and r.get("phase") == "completed":
            key = (r["robot"], r["index"])
            start = began.get(key, dispatched.get(key, r["t"]))
            durations[int(first[agent[r["robot"]]]) + r["index"]] = r["t"] - start
    return durations


def inst_map(instance: Path, name: str) -> Path:
    """The map of an instance: beside it, else among the shared maps."""
    beside = instance.parent / name
    return beside if beside.is_file() else SHARED / "maps" / name


def run_size(fields: object) -> Optional["RobotSize"]:
    """The robots' size the run record gives (None: a run of old, robots as large as a cell)."""
    from fleet_common.robot_size import RobotSize

    try:
        return RobotSize(float(fields["diameter_m"]), float(fields["margin_m"]), float(fields["cell_m"]))  # type: ignore[index]
    except (TypeError, KeyError, ValueError):
        return None


def main() -> int:
    work = Path(tempfile.mkdtemp(prefix="fleet-bench-manager-"))
    try:
        return bench(work)
    finally:
        shutil.rmtree(str(work), ignore_errors=True)


def bench(work: Path) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robots", type=int, default=300)
    parser.add_argument("--time-scale", type=float, default=4.0)
    parser.add_argument("--instance", type=Path, default=SHARED / "instances" / "arena_300agents_1.txt")
    parser.add_argument("--strategy", default="adg")
    parser.add_argument("--solver", default="lacam", help="the manager's built-in solver for the instance "
                        "(EVALUATION.md's 300-robot plan: pibt)")
    parser.add_argument("--solver-seed", type=int, default=0, help="the solver's seed (the manager's --seed)")
    parser.add_argument("--fleets", type=int, default=1, help="virtual-fleet processes serving the robots")
    parser.add_argument("--robot-size", choices=("turtlebot", "cell"), default="turtlebot",
                        help="the robots' size: a TurtleBot 2 (followers, hold points) or a whole cell")
    parser.add_argument("--keep", type=Path, help="copy the run's files (run folder, truth, logs) here")
    parser.add_argument("--delay-model", default=None, metavar="SPEC",
                        help="the virtual fleet's delay model (e.g. events=bernoulli:0.1:1-5); default none")
    parser.add_argument("--seed", type=int, default=0, help="the delay model's seed")
    parser.add_argument("--turn-speed", type=float, default=None, help="the virtual robots' (rad/s; default theirs)")
    parser.add_argument("--reroute", choices=("off", "propose", "auto"), default="off",
                        help="the manager's reroute mode (auto: count reroutes handed over and dropped)")
    parser.add_argument("--reroute-scope", choices=("held", "all"), default="held")
    parser.add_argument("--trim", action="store_true", help="the manager's --trim: the plan and every reroute's "
                        "plan trimmed of moves that bring nobody in sooner")
    parser.add_argument("--profile", action="store_true",
                        help="run the manager as bench/profiled_manager.py: CPU of its loop's parts")
    args = parser.parse_args()
    make_keys(work / "keys")
    inst = read_instance(str(args.instance), map_dirs=[args.instance.parent, SHARED / "maps"])
    if args.robots > len(inst.starts):
        raise SystemExit("{} has only {} agents".format(args.instance, len(inst.starts)))
    if args.robots < len(inst.starts):  # the first N agents, as a file of their own
        first = make_instance(inst.grid, inst.map_file, inst.starts[:args.robots],
                              inst.goals[:args.robots])
        source = inst_map(args.instance, inst.map_file)
        args.instance = work / "first-{}-{}".format(args.robots, args.instance.name)
        write_instance(first, str(args.instance))
        (work / inst.map_file).write_text(source.read_text())
    base = free_port_block(2 * args.robots + 1)
    size_line = "{} diameter={:g} margin=0\n".format(SIZE_LINE, LAB_CELL_M) if args.robot_size == "cell" else ""
    (work / "robots.txt").write_text(size_line + "".join(
        "{} 127.0.0.1 {} u tb{} red\n".format(i + 1, base + i, i + 1) for i in range(args.robots)))
    console_port, feedback = base + 2 * args.robots, base + args.robots
    parts = np.array_split(np.arange(1, args.robots + 1), args.fleets)
    truths = [work / "truth{}.jsonl".format(k) for k in range(args.fleets)]
    fleets = [Proc(fleetctl_args("virtual-fleet", "--definitions", work / "robots.txt", "--keys",
                                 work / "keys", "--time-scale", args.time_scale, "--feedback-base",
                                 feedback, "--instance", args.instance, "--log-level", "warning",
                                 "--truth", truth, "--robots", "{}-{}".format(part[0], part[-1]),
                                 *(("--delay-model", args.delay_model, "--seed", args.seed)
                                   if args.delay_model else ()),
                                 *(("--turn-speed", args.turn_speed) if args.turn_speed else ())),
                   work / "fleet{}.log".format(k))
              for k, (part, truth) in enumerate(zip(parts, truths))]
    manager = None
    try:
        for fleet in fleets:
            fleet.wait_line(r"^virtual fleet: ", timeout=120)
        command = fleetctl_args("manager")
        if args.profile:
            command = [sys.executable, str(Path(__file__).with_name("profiled_manager.py")),
                       str(work / "profile.tsv"), "--"]
        manager = Proc(command + [str(a) for a in (
            args.instance, "--definitions", work / "robots.txt", "--keys", work / "keys",
            "--host", "127.0.0.1", "--bind", "tcp://127.0.0.1:{}".format(console_port), "--start",
            "--until-done", "--log", work / "runs", "--strategy", args.strategy, "--time-limit",
            "1800", "--connect-timeout", "120", "--step-time", str(3.0 / args.time_scale),
            "--reroute", args.reroute, "--reroute-scope", args.reroute_scope, "--solver", args.solver,
            "--seed", args.solver_seed,
            *(["--trim"] if args.trim else []))],
            work / "manager.log")
        from live import ScriptedConsole
        console = ScriptedConsole(console_port, "bench", keys=work / "keys")
        states: List[float] = []
        seen = -1
        cpu0 = None
        t0 = time.monotonic()
        looked = t0
        while manager.popen.poll() is None:
            time.sleep(0.01)
            with console.lock:
                state = console.session.state
            now = time.monotonic()
            if state is not None and state.seq != seen:
                seen = state.seq
                states.append(now)
            # running: the console says so, or (a console starved of States) the manager's log does
            running = state is not None and state.run.state == "running"
            if cpu0 is None and not running and now - looked > 1.0:
                looked = now
                running = "started: every robot" in manager.text()
            if cpu0 is None and running:
                cpu0 = (now, cpu_seconds(manager.popen.pid), *(cpu_seconds(f.popen.pid) for f in fleets))
            if cpu0 is not None and (state is None or state.run.state not in ("done", "failed", "stopped")):
                cpu1 = (now, cpu_seconds(manager.popen.pid), *(cpu_seconds(f.popen.pid) for f in fleets))
        if cpu0 is None:
            print("the run never started ({} states); manager said:\n{}".format(len(states), manager.tail(20)))
            return 1
        console.close()
        if manager.popen.wait() != 0:
            print(manager.tail(30))
            return 1
        elapsed = time.monotonic() - t0
    finally:
        if manager is not None:
            manager.stop()
        for fleet in fleets:
            fleet.stop()
    if args.keep is not None:
        shutil.copytree(str(work), str(args.keep), dirs_exist_ok=True)
    out = manager.text()
    folder = Path(out.split("run folder: ")[1].split()[0])
    run = read_run(folder)
    records = run.records
    rtt = round_trips(records)
    outbound, back = split_round_trips(records, run.run["started"], run.run["t"], truths)
    plan = read_solution(str(run.plan_files()[0]), map_dirs=[SHARED / "maps", args.instance.parent]).plan
    size = run_size(run.run.get("size"))
    engine = Engine(plan, args.strategy, follow=size is not None and not size.cell_sized)
    durations = move_durations(records, run.robots, engine.table.first)
    engine_only = simulate_engine(engine, durations, size=size).metrics.makespan
    executed = float([line for line in out.splitlines() if line.startswith("executed makespan")][0]
                     .split(":")[1].split()[0])
    running = [t for t in states if cpu0 is not None and cpu0[0] <= t <= cpu1[0]]
    windows = [sum(1 for t in running if w <= t < w + 1.0)
               for w in np.arange(running[0], running[-1] - 1.0, 1.0)] if len(running) > 2 else []
    windows = windows or [0]
    span = cpu1[0] - cpu0[0]
    ms = 1000.0
    print("robots {} ({} fleet process{}, {}), instance {}, strategy {}, time scale {:g}; whole run {:.1f} s".format(
        args.robots, args.fleets, "" if args.fleets == 1 else "es",
        "as large as a cell" if args.robot_size == "cell" else "TurtleBot size", args.instance.name,
        args.strategy, args.time_scale, elapsed))
    print("state at the console: min {} per 1 s window, mean {:.1f}/s while running".format(
        min(windows), len(running) / max(1e-9, running[-1] - running[0]) if len(running) > 1 else 0))
    print("command sent -> Accepted: p50 {:.1f} ms, p99 {:.1f} ms, max {:.1f} ms over {}".format(
        percentile(rtt, 0.5) * ms, percentile(rtt, 0.99) * ms, max(rtt) * ms, len(rtt)))
    print("  of which manager sent -> robot started it: p50 {:.1f} ms, p99 {:.1f} ms; robot started -> "
          "manager read the Accepted: p50 {:.1f} ms, p99 {:.1f} ms".format(
              percentile(outbound, 0.5) * ms, percentile(outbound, 0.99) * ms,
              percentile(back, 0.5) * ms, percentile(back, 0.99) * ms))
    print("CPU while running (share of one core): manager {:.0f}%, virtual fleet{} {}".format(
        100 * (cpu1[1] - cpu0[1]) / span, "" if args.fleets == 1 else "s",
        " + ".join("{:.0f}%".format(100 * (b - a) / span) for a, b in zip(cpu0[2:], cpu1[2:]))))
    if any(r["k"] == "reroute" for r in records):  # the engine-only run knows the first plan only
        print("executed makespan {:.2f} s (rerouted: no engine-only run to compare)".format(executed))
    else:
        print("executed makespan {:.2f} s; engine-only with the same move durations {:.2f} s; "
              "ratio {:.3f}".format(executed, engine_only, executed / engine_only))
    # the plan against the virtual robots' pace (their speed, and turn speed unless --turn-speed)
    move_s = 1.0 / SPEED / args.time_scale
    need = slowest_need(moves_and_turns(plan), (np.pi / 2) / (args.turn_speed or TURN_SPEED) * SPEED) * move_s
    print("planned makespan {} steps, {:.1f} s at {:g} s a move: executed / planned {:.3f}; the slowest robot's "
          "own moves and turns need {:.1f} s ({:.3f} of planned)".format(
              plan.makespan, plan.makespan * move_s, move_s, executed / (plan.makespan * move_s), need,
              need / (plan.makespan * move_s)))
    if args.reroute != "off":
        kinds = [r["k"] for r in records]
        print("reroute {} (scope {}{}): {} handed over, {} dropped ({})".format(
            args.reroute, args.reroute_scope, ", trimmed" if args.trim else "", kinds.count("reroute"), kinds.count("reroute_dropped"),
            "; ".join(sorted({str(r.get("reason", ""))[:100] for r in records
                              if r["k"] == "reroute_dropped"})[:3]) or "none"))
        for kind in ("reroute", "reroute_dropped"):  # s from a look's cut to its hand-over
            looks = [r["look"] for r in records if r["k"] == kind and isinstance(r.get("look"), (int, float))]
            if looks:
                print("  {}: look to hand-over mean {:.0f} ms, max {:.0f} ms".format(
                    kind, 1e3 * sum(looks) / len(looks), 1e3 * max(looks)))
    if args.profile:
        print_profile(work / "profile.tsv")
    print("load average {:.2f} {:.2f} {:.2f}".format(*os.getloadavg()))
    return 0


def print_profile(path: Path) -> None:
    """The manager loop's parts while the run ran: CPU seconds, share of one core, per call."""
    rows = [line.split("\t") for line in path.read_text().splitlines()]
    wall, cpu = float(rows[0][1]), float(rows[0][2])
    print("manager's loop thread while running: {:.1f} s of CPU in {:.1f} s ({:.0%} of a core); its parts "
          "(CPU time, inclusive):".format(cpu, wall, cpu / wall))
    for label, calls, seconds in rows[1:]:
        n, sec = int(calls), float(seconds)
        print("  {:<58} {:>9} calls {:7.1f} s  {:5.1%} of a core  {:8.1f} us a call".format(
            label, n, sec, sec / wall, 1e6 * sec / n if n else 0.0))


if __name__ == "__main__":
    sys.exit(main())
