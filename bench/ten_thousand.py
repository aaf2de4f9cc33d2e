"""Benchmark: 10,000 agents offline: solved, checked, simulated with delays and played back.

On a 10,000-agent instance of a MovingAI map (bench/make_instance.py: by default ost000a,
the largest shipped map, 130,478 free cells; random distinct starts, each goal a random free
cell at most --radius moves from its start), each step as a user runs it, a whole process
timed from start to exit with GNU time (wall, CPU, peak RSS):

1. `fleetctl solve -s lacam` (the instance's plan);
2. `fleetctl validate` of that plan;
3. `fleetctl simulate` of it (default delays: moves take 0.8-1.5 x nominal, stalls);
4. `fleetctl console --replay PLAN --screenshot PNG --at T` (a private Xvfb: open, draw, write);
5. the plan player's load time and frame time at full speed (`bench/console.py --case player
   --plan PLAN`, in its own process);
6. mapf-IR's `app` (PIBT; $MAPF_IR_APP, or --mapf-ir-src CHECKOUT as bench/side_by_side.py
   builds it) on the same instance, under a memory cap (--mapf-ir-memory, GB of address space),
   since it keeps a full distance table per agent; where it solves, steps 2 and 3 on its plan.

    .venv/bin/python bench/ten_thousand.py [--map ost000a.map] [--agents 10000] [--radius 60]
                                           [--keep DIR] [--mapf-ir] [--mapf-ir-memory 8]
"""
from __future__ import annotations

import argparse
import os
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Optional, Sequence

sys.path.insert(0, str(Path(__file__).resolve().parent))
from make_instance import SHARED, random_instance  # noqa: E402
from side_by_side import FLEETCTL, build_mapf_ir, timed  # noqa: E402

from fleet_common.planning.mapf_ir import find_map_dir, resolve_app  # noqa: E402

#: What each step's output is searched for, to print beside its figures.
SUMMARY = {
    "solve": r"solved=|no plan|error",
    "validate": r"valid|INVALID",
    "simulate": r"executed makespan|collisions|reached goal|rotations? repaired|cannot",
    "console": r"time step|error",
}


def step(label: str, argv: Sequence[str], cwd: Optional[str] = None, limit_s: float = 900.0) -> int:
    ms, cpu, rss, code, out = timed(argv, cwd=cwd, limit_s=limit_s)
    key = next((k for k in SUMMARY if k in label), "")
    lines = [ln.split(": ", 1)[-1] if key == "validate" else ln
             for ln in out.splitlines() if re.search(SUMMARY.get(key, r"."), ln)]
    print("{:<28} exit {:>3}  {:7.2f} s wall  {:7.2f} s CPU  {:6.0f} MB peak".format(label, code, ms / 1000, cpu, rss))
    for line in lines[:4]:
        print("    " + line[:200])
    sys.stdout.flush()
    return code


def player(plan: Path) -> None:
    proc = subprocess.run([sys.executable, str(Path(__file__).with_name("console.py")), "--case", "player",
                           "--plan", str(plan), "--only-plans", "--frames", "100"],
                          stdout=subprocess.PIPE, stderr=subprocess.STDOUT, universal_newlines=True)
    for line in proc.stdout.splitlines()[1:]:
        print("    " + line)


def mapf_ir(app: Path, instance: Path, out: Path, memory_gb: float, work: Path) -> bool:
    """mapf-IR's PIBT on `instance` under an address-space cap; True if it wrote a solved plan."""
    cap = int(memory_gb * 1e9)
    # the cap is set in a small launcher, so that GNU time (and this process) keep theirs
    launcher = work / "capped.py"
    launcher.write_text("import os, resource, sys\nresource.setrlimit(resource.RLIMIT_AS, ({0}, {0}))\n"
                        "os.execv(sys.argv[1], sys.argv[1:])\n".format(cap))
    code = step("mapf-IR PIBT ({:g} GB cap)".format(memory_gb),
                [sys.executable, str(launcher), str(app), "-i", str(instance.resolve()), "-s", "PIBT", "-o",
                 str(out)], cwd=str(find_map_dir(app)))
    text = out.read_text() if out.is_file() else ""
    solved = "solved=1" in text
    print("    mapf-IR output: {}".format("solved" if solved else "none (exit {})".format(code) if not text
                                          else "solved=0"))
    return solved


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--map", default="ost000a.map")
    parser.add_argument("--agents", type=int, default=10000)
    parser.add_argument("--radius", type=int, default=60, help="goals at most this many moves from starts "
                                                               "(0: anywhere)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--keep", type=Path, default=None, help="write the files here and keep them")
    parser.add_argument("--mapf-ir", action="store_true", help="step 6: mapf-IR's PIBT beside ours")
    parser.add_argument("--mapf-ir-src", type=Path, default=None, metavar="CHECKOUT")
    parser.add_argument("--mapf-ir-memory", type=float, default=8.0, metavar="GB")
    parser.add_argument("--time-limit", type=float, default=60.0, help="solve's time limit (default 60 s)")
    args = parser.parse_args()
    print("load average {:.2f} {:.2f} {:.2f} on {} CPUs".format(*os.getloadavg(), os.cpu_count()))
    work = args.keep or Path(tempfile.mkdtemp(prefix="fleetcontrol-10k-"))
    work.mkdir(parents=True, exist_ok=True)
    try:
        name = "{}_{}agents{}".format(Path(args.map).stem, args.agents,
                                      "_r{}".format(args.radius) if args.radius else "")
        instance = work / (name + ".txt")
        map_path = Path(args.map) if Path(args.map).is_file() else SHARED / "maps" / args.map
        random_instance(map_path, args.agents, instance, args.radius or None, args.seed)
        print("instance {}: {} agents on {}, {}".format(
            instance.name, args.agents, map_path.name,
            "goals within {} moves of their starts".format(args.radius) if args.radius else "goals anywhere"))
        plan = work / (name + "_lacam.txt")
        maps = ["--map-dir", str(work)]
        if step("fleetctl solve -s lacam", [FLEETCTL, "solve", str(instance), "-s", "lacam", "-o", str(plan),
                                             "--time-limit", str(args.time_limit)]) != 0:
            return 1
        step("fleetctl validate", [FLEETCTL, "validate", str(plan)] + maps)
        step("fleetctl simulate", [FLEETCTL, "simulate", str(plan)] + maps)
        makespan = int(re.search(r"^makespan=(\d+)", plan.read_text(), re.M).group(1))  # type: ignore[union-attr]
        png = work / (name + ".png")
        step("fleetctl console --screenshot", [FLEETCTL, "console", "--replay", str(plan), "--screenshot",
                                               str(png), "--at", str(makespan // 2)] + maps)
        print("plan player (load, open, frames at full speed):")
        player(plan)
        if args.mapf_ir:
            app = build_mapf_ir(args.mapf_ir_src) if args.mapf_ir_src else resolve_app()
            theirs = work / (name + "_mapf-ir_pibt.txt")
            if mapf_ir(app, instance, theirs, args.mapf_ir_memory, work):
                step("fleetctl validate (mapf-IR)", [FLEETCTL, "validate", str(theirs)] + maps)
                step("fleetctl simulate (mapf-IR)", [FLEETCTL, "simulate", str(theirs)] + maps)
    finally:
        if args.keep is None:
            shutil.rmtree(str(work), ignore_errors=True)
    print("load average {:.2f} {:.2f} {:.2f} at the end".format(*os.getloadavg()))
    return 0


if __name__ == "__main__":
    sys.exit(main())

