"""Benchmark: frame time of the console at many agents: the plan player at full speed, and the
live console on 300 virtual robots driven by a real manager.

Renders on a private Xvfb (started and stopped here). Each frame is what the
player's `after()` loop does at the top speed (64 time steps per second, at
30 frames per second: about two time steps a frame, so every agent that
moves is moved every frame): poll the clock, move the canvas items, let Tk
redraw (`update_idletasks`), and wait for the X server to have drawn it all
(a round trip). Frame times are wall times of that, in milliseconds.

Plans:
- arena_300agents_1: the built-in PIBT solver's plan.
- brc202d_1500agents_1: the built-in solvers refuse it (distance tables for
  1,500 goals on 255,000 cells would not fit in memory), so the plan is
  generated: each agent starts on its instance start and shuttles between it
  and a free neighbouring cell that no other agent starts on or uses, for
  200 steps; the agents' cell pairs are disjoint, so the plan is valid (the
  validator checks it) and every agent moves every step.

Live (`--case live`): `fleetctl virtual-fleet` with 300 robots on the
arena_300agents_1 starts and a manager (`bench/stamped_manager.py`:
`fleetctl manager` noting when it sent each State) planning it with PIBT, ADG,
20 states a second; the live console (`LiveApp` and its network thread, as
`fleetctl console --manager` runs them) in this process. A frame is what its
`after()` loop does every 15 ms (drain the feed, draw the newest state,
panels at 4 Hz) plus the X round trip; pose-to-screen latency is from the manager sending a
State to the end of the frame that drew it (CLOCK_MONOTONIC, one clock for
all processes).

With `--instance FILE --robots N --fleets K` the live case runs N robots of another instance
(e.g. 1,000 on den520d, from bench/make_instance.py) served by K virtual-fleet processes.

    .venv/bin/python bench/console.py [--case player|live|all] [--frames 300] [--lines goal|path|none]
    .venv/bin/python bench/console.py [--case player|live|all] [--frames 300] [--lines goal|path|none]
                                      [--robots 300] [--seconds 15] [--time-scale 4] [--present]
                                      [--instance FILE] [--fleets 1]

With `--present` the live case runs twice, the second time in the presentation view
(full screen, title, legend, the story's ticker), for the ratio of the two.
"""
from __future__ import annotations

import argparse
import gc
import os
import platform
import statistics
import sys
import time
from pathlib import Path
from typing import List, Optional, Set, Tuple

# This file is bench/console.py: run as a script, its folder comes first on sys.path and
# `import console` would find this file instead of the console package.
sys.path[:] = [p for p in sys.path if Path(p or ".").resolve() != Path(__file__).resolve().parent]

import numpy as np  # noqa: E402

from console.player import default_canvas_size
from console.scene import Scene, scene_from_plan
from console.sources import MAX_SPEED
from console.view_options import ViewOptions
from console.xvfb import Xvfb
from fleet_common.formats.instance import read_instance
from fleet_common.grid import Coord, Grid
from fleet_common.plan import Plan
from fleet_common.planning import solve

DATA = Path(__file__).resolve().parents[2] / "shared" / "data" / "mapf-ir"
FPS = 30.0
SHUTTLE_STEPS = 200


def shuttle_plan(grid: Grid, starts: List[Coord], steps: int) -> Plan:
    """Each agent between its start and a private free neighbour (waits if it has none)."""
    taken: Set[Coord] = set(starts)
    partner: List[Coord] = []
    for s in starts:
        free = [n for n in grid.neighbors(s) if n not in taken]
        partner.append(free[0] if free else s)
        taken.add(partner[-1])
    a, b = np.array(starts), np.array(partner)
    positions = np.where((np.arange(steps + 1) % 2 == 0)[:, None, None], a[None], b[None])
    return Plan(positions)


def arena_scene() -> Scene:
    inst = read_instance(str(DATA / "instances" / "arena_300agents_1.txt"), map_dirs=None)
    result = solve("pibt", inst.grid, inst.starts, inst.goals, seed=0)
    return scene_from_plan(inst.grid, result.plan, info=["solver pibt"], title="arena_300agents_1")


def brc_scene() -> Scene:
    inst = read_instance(str(DATA / "instances" / "brc202d_1500agents_1.txt"), map_dirs=None)
    plan = shuttle_plan(inst.grid, inst.starts, SHUTTLE_STEPS)
    scene = scene_from_plan(inst.grid, plan, info=["generated shuttle plan"], title="brc202d_1500agents_1")
    if scene.findings:
        raise SystemExit("generated plan is invalid: {}".format(scene.findings[0]))
    return scene


def file_scene(path: Path) -> Tuple[Scene, float]:
    """A solution file as `fleetctl console --replay` loads it (read, validate, style), and the seconds taken."""
    from console.scene import scene_from_solution

    began = time.perf_counter()
    scene = scene_from_solution(path, map_dirs=[path.parent, DATA / "maps"])
    return scene, time.perf_counter() - began


def frame_times(scene: Scene, frames: int, lines: str) -> Tuple[List[float], Tuple[int, int], float]:
    import tkinter as tk

    from console.ui.app import PlayerApp

    size = default_canvas_size(scene.grid.width, scene.grid.height)
    root = tk.Tk()
    try:
        root.geometry("+0+0")
        began = time.perf_counter()
        app = PlayerApp(root, scene, ViewOptions(lines=lines), canvas_size=size, playing=False)
        root.update()
        opened = time.perf_counter() - began
        clock = app.clock
        step = MAX_SPEED / FPS
        times: List[float] = []
        t = 0.0
        for _ in range(frames):
            t = (t + step) % (clock.makespan + 1)
            started = time.perf_counter()
            clock.seek(t)
            app.refresh()
            root.update_idletasks()
            root.winfo_pointerxy()  # a round trip: the X server has drawn everything sent before
            times.append((time.perf_counter() - started) * 1000.0)
        return times, size, opened
    finally:
        root.destroy()


def cpu_seconds(pid: int) -> float:
    """User + system CPU seconds of process `pid` so far (from /proc)."""
    fields = Path("/proc/{}/stat".format(pid)).read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def live_times(robots: int, seconds: float, time_scale: float, xvfb_pid: int,
               instance: Optional[Path] = None, fleets: int = 1, present: bool = False) -> None:
    """The live console on `robots` virtual robots through a manager; prints its figures
    (`present`: in the presentation view, full screen).

    `instance` (default arena_300agents_1; its map beside it or among the shared maps) gives
    the starts and the plan; `fleets` virtual-fleet processes serve parts of the robots."""
    import shutil
    import tempfile
    import tkinter as tk

    from console.live.feed import LiveFeed
    from console.live.link import ManagerLink
    from console.live.model import LiveModel
    from console.palette import distinct_colours
    from console.ui.live_app import LiveApp
    from fleet_common.children import Child
    from fleet_common.local_fleet import local_definitions
    from fleet_common.robots import RobotDefinition

    work = Path(tempfile.mkdtemp(prefix="bench-console-"))
    children: List[Child] = []
    try:
        source = instance or DATA / "instances" / "arena_300agents_1.txt"
        name = source.name
        shutil.copy(str(source), str(work / name))
        map_name = read_instance(str(source), map_dirs=[source.parent, DATA / "maps"]).map_file
        beside = source.parent / map_name
        shutil.copy(str(beside if beside.is_file() else DATA / "maps" / map_name), str(work / map_name))
        fleet = [RobotDefinition(i + 1, "127.0.0.1", 1, "tb", "tb{}".format(i + 1), c)
                 for i, c in enumerate(distinct_colours(robots))]
        defs, feedback, port = local_definitions(fleet, work / "robots.txt")
        endpoint = "tcp://127.0.0.1:{}".format(port)
        for k, part in enumerate(np.array_split(np.arange(1, robots + 1), fleets)):
            children.append(Child.start("fleet{}".format(k), [
                "virtual-fleet", "--definitions", str(defs), "--no-curve", "--time-scale", str(time_scale),
                "--instance", str(work / name), "--feedback-base", str(feedback), "--log-level", "warning",
                "--robots", "{}-{}".format(part[0], part[-1])], log=work / "fleet{}.log".format(k)))
        stamps = work / "stamps.tsv"
        children.append(Child.spawn("manager", [
            sys.executable, str(Path(__file__).with_name("stamped_manager.py")), str(stamps), "--",
            str(work / name), "--definitions", str(defs), "--no-curve", "--host", "127.0.0.1", "--bind",
            endpoint, "--start", "--no-log", "-s", "pibt", "--connect-timeout", "120",
            "--step-time", str(2.2 / time_scale)], log=work / "manager.log"))
        feed, model = LiveFeed(), LiveModel(endpoint)
        link = ManagerLink(endpoint, feed, name="bench").start()
        root = tk.Tk()
        try:
            root.geometry("+0+0")
            app = LiveApp(root, feed, model, link.request, present=present)
            root.after_cancel(app._after)  # this loop runs the frames instead
            app._after = None
            began = time.monotonic()
            while not (model.state is not None and model.state.run.state == "running"):
                if time.monotonic() - began > 180 or not children[-1].running():
                    raise SystemExit("the run did not start: see {}".format(work / "manager.log"))
                root.update()
                app.refresh()
                time.sleep(0.02)
            started = time.monotonic() - began
            times, drawn_at, arrived_at, drawing = [], {}, {}, []
            cpu0, x0, wall0 = time.process_time(), cpu_seconds(xvfb_pid), time.monotonic()
            while time.monotonic() - wall0 < seconds:
                t0 = time.perf_counter()
                before = app.state.version if app.state is not None else None
                app.refresh()
                root.update_idletasks()
                root.winfo_pointerxy()
                spent = time.perf_counter() - t0
                times.append(spent * 1000.0)
                if app.state is not None and app.state.version != before:
                    drawn_at[app.state.version] = time.monotonic()
                    arrived_at[app.state.version] = model.state_at  # when the link thread got it
                    drawing.append(spent * 1000.0)
                root.update()
                time.sleep(max(0.0, app.frame_ms / 1000.0 - (time.perf_counter() - t0)))
            wall = time.monotonic() - wall0
            cpu = ((time.process_time() - cpu0) / wall, (cpu_seconds(xvfb_pid) - x0) / wall)
            canvas = (app.canvas.winfo_width(), app.canvas.winfo_height())
        finally:
            link.stop()
            root.destroy()
            del app
            gc.collect()  # Tk's images die on Tk's thread
        for child in reversed(children):
            child.stop()
        sent = dict((int(a), float(b)) for a, b in (line.split("\t") for line in stamps.read_text().splitlines()))
        latency = [1000.0 * (t - sent[seq]) for seq, t in drawn_at.items() if seq in sent]
        transit = [1000.0 * (arrived_at[seq] - sent[seq]) for seq in drawn_at if seq in sent]
        inside = [1000.0 * (t - arrived_at[seq]) for seq, t in drawn_at.items()]
        states = [seq for seq in sent if min(drawn_at) <= seq <= max(drawn_at)]
        print("live{}: {} robots, connected and started in {:.1f} s, canvas {}x{}, {} frames".format(
            " (presentation view)" if present else "", robots, started, canvas[0], canvas[1], len(times)))
        print("  frame time, all frames:          median {:5.1f} ms  p99 {:5.1f} ms  max {:5.1f} ms".format(
            statistics.median(times), float(np.percentile(times, 99)), max(times)))
        print("  frame time, frames with a state: median {:5.1f} ms  p99 {:5.1f} ms  ({} frames)".format(
            statistics.median(drawing), float(np.percentile(drawing, 99)), len(drawing)))
        print("  pose-to-screen (State sent -> drawn): p50 {:5.1f} ms  p99 {:5.1f} ms  max {:5.1f} ms".format(
            float(np.percentile(latency, 50)), float(np.percentile(latency, 99)), max(latency)))
        print("    of which sent -> the network thread has it: p50 {:5.1f} ms  p99 {:5.1f} ms; then -> drawn "
              "(decode, wait for the frame, draw): p50 {:5.1f} ms  p99 {:5.1f} ms".format(
                  float(np.percentile(transit, 50)), float(np.percentile(transit, 99)),
                  float(np.percentile(inside, 50)), float(np.percentile(inside, 99))))
        print("  states sent meanwhile {} ({:.1f} a second), drawn {}, coalesced {} (a newer one came in the "
              "same frame); feed dropped {}".format(len(states), len(states) / wall, len(drawn_at),
                                                     len(states) - len(drawn_at), feed.dropped))
        print("  CPU: console process {:.0%} of a core (Tk thread and network thread), Xvfb {:.0%}; "
              "per state drawn {:.1f} ms + {:.1f} ms".format(cpu[0], cpu[1], 1000 * cpu[0] * wall / len(drawn_at),
                                                           1000 * cpu[1] * wall / len(drawn_at)))
    finally:
        for child in children:
            if child.running():
                child.stop()
        shutil.rmtree(str(work), ignore_errors=True)


def synthetic_states(robots: int, count: int):
    """A scene of `robots` on a 49 x 49 floor and `count` States in which every robot moves and
    every tenth waits for the next one: what the live console draws, without a network."""
    from fleet_common.control import (Activity, PlanData, RobotInfo, RobotState, RunInfo, RunSetup,
                                      State, Waiting)

    side = 49
    starts = [(i % side, (i // side) * 2) for i in range(robots)]
    plan = Plan.from_paths([[s, (s[0], s[1] + 1)] * 10 for s in starts])
    scene = RunSetup("floor", tuple("." * side for _ in range(side)),
                  tuple(RobotInfo(i + 1, "red", "tb") for i in range(robots)),
                  PlanData(1, tuple(range(1, robots + 1)), plan.positions, "synthetic"), ("adg",), 1.0)
    states = []
    for k in range(1, count + 1):
        f = (k % 20) / 20.0
        run = RunInfo("running", "", "adg", 1, 1.0 + k * 0.05, 1.0 + k * 0.05, 1, 0, robots, None, 0, None)
        states.append(State(k, 5, run, tuple(
            RobotState(i + 1, "up", "", s[0], s[1] + f, 1.57, "robot", 0.05, False, (), None,
                       Activity("drive", 3, float(s[0]), s[1] + 1.0), 3, 10, 4,
                       Waiting((i + 2,), (s[0], s[1] + 1), "cell") if i % 10 == 0 and i + 1 < robots else None,
                       0.0) for i, s in enumerate(starts))))
    return scene, states


def draw_and_decode_costs(robots: int, xvfb_pid: int, count: int = 120) -> None:
    """CPU per State, in parts: decoding it (the network thread) and drawing it (Tk), measured
    as CPU time (this process; the X server's from /proc), so the machine's load counts less."""
    import json
    import tkinter as tk

    from console.live.feed import CONNECTED, LinkStatus, LiveFeed
    from console.live.model import LiveModel
    from console.ui.live_app import LiveApp
    from fleet_common.control import encode
    from fleet_common.control.codec import decode
    from fleet_common.control.messages import MANAGER_MESSAGES

    scene, states = synthetic_states(robots, count)
    frames = [encode(st) for st in states[:40]]
    times = {"json.loads": [], "decode": []}
    for frame in frames:
        for name, fn in (("json.loads", json.loads), ("decode", lambda f: decode(f, MANAGER_MESSAGES, 1 << 28))):
            t0 = time.process_time()
            fn(frame)
            times[name].append((time.process_time() - t0) * 1000.0)
    print("  decoding a {}-robot State ({:.0f} KB): {:.1f} ms CPU median (json.loads alone {:.1f} ms)".format(
        robots, len(frames[0]) / 1000, statistics.median(times["decode"]), statistics.median(times["json.loads"])))
    root = tk.Tk()
    try:
        feed, model = LiveFeed(), LiveModel("synthetic")
        app = LiveApp(root, feed, model, lambda *a, **k: None)
        root.after_cancel(app._after)
        app._after = None
        feed.offer(LinkStatus(CONNECTED, "synthetic"), 0.0)
        feed.offer(scene, 0.0)
        app.refresh()
        root.update()
        cpu0, x0 = time.process_time(), cpu_seconds(xvfb_pid)
        for st in states:
            feed.offer(st, 0.0)
            app.refresh()
            root.update_idletasks()
            root.winfo_pointerxy()
        cpu, x = time.process_time() - cpu0, cpu_seconds(xvfb_pid) - x0
        print("  drawing it (every robot moved, a tenth waiting, panels at 4 Hz): {:.1f} ms CPU a State in the "
              "console, {:.1f} ms in the X server".format(1000 * cpu / count, 1000 * x / count))
    finally:
        root.destroy()
        del app
        gc.collect()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--case", choices=("player", "live", "all"), default="all")
    parser.add_argument("--frames", type=int, default=300)
    parser.add_argument("--lines", choices=("goal", "path", "none"), default="goal")
    parser.add_argument("--robots", type=int, default=300, help="live: virtual robots (default 300)")
    parser.add_argument("--time-scale", type=float, default=4.0, help="live: the fleet's time scale")
    parser.add_argument("--seconds", type=float, default=15.0, help="live: seconds measured (default 15)")
    parser.add_argument("--present", action="store_true",
                        help="live: the operator's window, then the presentation view, one after the other")
    parser.add_argument("--instance", type=Path, default=None,
                        help="live: the robots' instance (default arena_300agents_1)")
    parser.add_argument("--fleets", type=int, default=1, help="live: virtual-fleet processes (default 1)")
    parser.add_argument("--plan", type=Path, action="append", default=[],
                        help="player: also this solution file, loaded as `fleetctl console --replay` loads it "
                             "(repeatable; its load time is printed too)")
    parser.add_argument("--only-plans", action="store_true", help="player: only the --plan files")
    args = parser.parse_args()
    print("python {}, {}, {} cores".format(platform.python_version(), platform.machine(), os.cpu_count()))
    with Xvfb.start(1600, 1200) as server:
        os.environ["DISPLAY"] = server.display
        if args.case in ("live", "all"):
            live_times(args.robots, args.seconds, args.time_scale, server.pid, args.instance, args.fleets)
            if args.present:
                live_times(args.robots, args.seconds, args.time_scale, server.pid, args.instance, args.fleets,
                           present=True)
            draw_and_decode_costs(args.robots, server.pid)
        if args.case == "live":
            return
        print("{:<22s} {:>6s} {:>10s} {:>6s} {:>7s} {:>10s} {:>8s} {:>8s} {:>8s}".format(
            "plan", "agents", "canvas", "lines", "frames", "open s", "median", "p99", "max"))
        scenes = [] if args.only_plans else [arena_scene(), brc_scene()]
        for path in args.plan:
            scene, loaded = file_scene(path)
            print("{}: loaded (read, validated, styled) in {:.2f} s".format(path.name, loaded))
            scenes.append(scene)
        for scene in scenes:
            times, size, opened = frame_times(scene, args.frames, args.lines)
            p99 = float(np.percentile(times, 99))
            print("{:<22s} {:>6d} {:>10s} {:>6s} {:>7d} {:>10.2f} {:>5.1f} ms {:>5.1f} ms {:>5.1f} ms".format(
                scene.title, scene.num_agents, "{}x{}".format(*size), args.lines, len(times), opened,
                statistics.median(times), p99, max(times)))


if __name__ == "__main__":
    main()
