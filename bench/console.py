"""Benchmark: frame time of the console's plan player at full speed, many agents.

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

    .venv/bin/python bench/console.py [--frames 300] [--lines goal|path|none]
"""
from __future__ import annotations

import argparse
import os
import platform
import statistics
import sys
import time
from pathlib import Path
from typing import List, Set, Tuple

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


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=300)
    parser.add_argument("--lines", choices=("goal", "path", "none"), default="goal")
    args = parser.parse_args()
    print("python {}, {}, {} cores".format(platform.python_version(), platform.machine(), os.cpu_count()))
    with Xvfb.start(1600, 1200) as server:
        os.environ["DISPLAY"] = server.display
        print("{:<22s} {:>6s} {:>10s} {:>6s} {:>7s} {:>10s} {:>8s} {:>8s} {:>8s}".format(
            "plan", "agents", "canvas", "lines", "frames", "open s", "median", "p99", "max"))
        for scene in (arena_scene(), brc_scene()):
            times, size, opened = frame_times(scene, args.frames, args.lines)
            p99 = float(np.percentile(times, 99))
            print("{:<22s} {:>6d} {:>10s} {:>6s} {:>7d} {:>10.2f} {:>5.1f} ms {:>5.1f} ms {:>5.1f} ms".format(
                scene.title, scene.num_agents, "{}x{}".format(*size), args.lines, len(times), opened,
                statistics.median(times), p99, max(times)))


if __name__ == "__main__":
    main()
