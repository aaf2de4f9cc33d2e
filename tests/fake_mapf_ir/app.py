"""A stand-in for mapf-IR's `app` executable, for CI machines without the C++ build.

It follows the real command line as mapf-IR's app.cpp, problem.cpp, graph.cpp
and solver.cpp define it (learned from them, not copied):

* options `-i/--instance`, `-o/--output` (default ./result.txt),
  `-s/--solver`, `-v/--verbose`, `-h/--help`, `-T/--time-limit` (ms),
  `-P/--make-scen`; any other option is ignored (getopt with opterr=0) and
  belongs to the solver;
* without `-i` it prints how to give one and exits 0;
* `map_file=` is opened as the compiled-in map folder plus the name, by plain
  string concatenation: here the folder is `../map/` from this script's real
  location, so an absolute `map_file` fails just as it does in mapf-IR;
* errors print `error@<where>: <message>` on stdout and exit 1 (mapf-IR's
  `halt`); an unknown solver name warns and falls back to PIBT;
* the output is mapf-IR's log, byte for byte in layout; without a plan it is
  `solved=0`, `soc=0`, `makespan=-1` and an empty `solution=` block.

It plans by prioritized planning with a space-time BFS, enough for tiny maps.

`FAKE_MAPF_IR_MODE` makes it misbehave, to test the adapter's error paths:
`crash` (abort by signal), `exit` (exit 3 after some output), `garbage`
(exit 0 with an unreadable output file), `no-output` (exit 0 without writing,
as an old mapf-IR did on invalid results), `fail` (a well-formed failed output), `invalid` (solved=1 but agents jump
from start to goal),
`hang` (sleep until killed). `FAKE_MAPF_IR_ARGV_LOG=FILE` records the command
line (JSON: argv and working directory).
"""
import json
import os
import re
import signal
import sys
import time
from collections import deque

MAP_DIR = os.path.join(os.path.dirname(os.path.dirname(os.path.realpath(__file__))), "map") + "/"
KNOWN_SOLVERS = (
    "PIBT", "winPIBT", "HCA", "WHCA", "CBS", "ICBS", "PIBT_COMPLETE", "ECBS", "RevisitPP",
    "PushAndSwap", "IR", "IR_SINGLE_PATHS", "IR_FIX_AT_GOALS", "IR_FOCUS_GOALS", "IR_MDD",
    "IR_BOTTLENECK", "IR_HYBRID",
)
SHORT_WITH_ARG = {"i": "instance", "o": "output", "s": "solver", "T": "time-limit"}
LONG_NAMES = {"instance": "i", "output": "o", "solver": "s", "verbose": "v", "help": "h",
              "time-limit": "T", "make-scen": "P"}


def halt(where, message):
    print("error@{}: {}".format(where, message))
    sys.stdout.flush()
    sys.exit(1)


def parse_args(argv):
    opts = {"o": "./result.txt"}
    i = 0
    while i < len(argv):
        arg = argv[i]
        i += 1
        if arg.startswith("--") and len(arg) > 2:
            name, eq, value = arg[2:].partition("=")
            short = LONG_NAMES.get(name)
            if short is None:
                continue
            if short in SHORT_WITH_ARG:
                if not eq:
                    if i >= len(argv):
                        continue
                    value = argv[i]
                    i += 1
                opts[short] = value
            else:
                opts[short] = True
        elif arg.startswith("-") and len(arg) > 1:
            short = arg[1]
            if short in SHORT_WITH_ARG:
                value = arg[2:]
                if not value:
                    if i >= len(argv):
                        continue
                    value = argv[i]
                    i += 1
                opts[short] = value
            elif short in "vhP":
                opts[short] = True
    return opts


def read_instance(path):
    try:
        with open(path) as f:
            lines = f.read().splitlines()
    except OSError:
        halt("Problem", "file " + path + " is not found.")
    inst = {"agents": 0, "seed": 0, "max_timestep": 0, "max_comp_time": 0, "pairs": []}
    for line in lines:
        if re.fullmatch(r"#.+", line):
            continue
        m = re.fullmatch(r"map_file=(.+)", line)
        if m:
            inst["map_file"] = m.group(1)
            inst["grid"] = read_map(m.group(1))
            continue
        m = re.fullmatch(r"(agents|seed|max_timestep|max_comp_time)=(\d+)", line)
        if m:
            inst[m.group(1)] = int(m.group(2))
            continue
        m = re.fullmatch(r"(\d+),(\d+),(\d+),(\d+)", line)
        if m and len(inst["pairs"]) < inst["agents"]:
            sx, sy, gx, gy = (int(v) for v in m.groups())
            for label, x, y in (("start", sx, sy), ("goal", gx, gy)):
                if (x, y) not in inst["grid"]["free"]:
                    halt("Problem", "{} node ({}, {}) does not exist, invalid scenario".format(label, x, y))
            inst["pairs"].append(((sx, sy), (gx, gy)))
    if inst["agents"] <= 0:
        halt("Problem", "invalid number of agents")
    if len(inst["pairs"]) < inst["agents"]:
        halt("Problem", "given starts/goals are not sufficient (random instances: not in the stand-in)")
    inst["max_timestep"] = inst["max_timestep"] or 5000
    inst["max_comp_time"] = inst["max_comp_time"] or 60000
    return inst


def read_map(map_file):
    try:
        with open(MAP_DIR + map_file) as f:
            lines = f.read().splitlines()
    except OSError:
        halt("Grid", "file " + map_file + " is not found.")
    width = height = 0
    k = 0
    while k < len(lines):
        line = lines[k]
        k += 1
        m = re.fullmatch(r"(height|width)\s(\d+)", line)
        if m:
            if m.group(1) == "height":
                height = int(m.group(2))
            else:
                width = int(m.group(2))
        if line == "map":
            break
    if not (width > 0 and height > 0):
        halt("Grid", "failed to load width/height.")
    rows = lines[k:]
    if len(rows) != height or any(len(r) != width for r in rows):
        halt("Grid", "map format is invalid")
    free = {(x, y) for y, row in enumerate(rows) for x, ch in enumerate(row) if ch not in "T@"}
    return {"width": width, "height": height, "free": free, "name": map_file}


def neighbours(free, v):
    x, y = v
    return [u for u in ((x - 1, y), (x + 1, y), (x, y - 1), (x, y + 1)) if u in free]


def distances(free, goal):
    dist = {goal: 0}
    queue = deque([goal])
    while queue:
        v = queue.popleft()
        for u in neighbours(free, v):
            if u not in dist:
                dist[u] = dist[v] + 1
                queue.append(u)
    return dist


def plan_prioritized(grid, pairs, max_timestep, deadline):
    """Space-time BFS per agent against the paths of the agents before it."""
    free = grid["free"]
    paths = []
    for start, goal in pairs:
        path = _spacetime_bfs(free, start, goal, paths, max_timestep, deadline)
        if path is None:
            return None
        paths.append(path)
    makespan = max((len(p) for p in paths), default=1) - 1
    return [p + [p[-1]] * (makespan + 1 - len(p)) for p in paths]


def _occupied(paths, v, t):
    return any((p[t] if t < len(p) else p[-1]) == v for p in paths)


def _swapped(paths, a, b, t):
    for p in paths:
        here = p[t] if t < len(p) else p[-1]
        there = p[t + 1] if t + 1 < len(p) else p[-1]
        if here == b and there == a:
            return True
    return False


def _spacetime_bfs(free, start, goal, paths, max_timestep, deadline):
    if any(p[-1] == goal for p in paths):
        return None  # someone rests on this goal for ever
    last_busy = max((t for p in paths for t, v in enumerate(p) if v == goal), default=-1)
    queue = deque([(start, 0)])
    parent = {(start, 0): None}
    while queue:
        if time.monotonic() > deadline:
            return None
        v, t = queue.popleft()
        if v == goal and t > last_busy:
            out = []
            node = (v, t)
            while node is not None:
                out.append(node[0])
                node = parent[node]
            return out[::-1]
        if t >= max_timestep:
            continue
        for u in neighbours(free, v) + [v]:
            key = (u, t + 1)
            if key in parent or _occupied(paths, u, t + 1) or _swapped(paths, v, u, t):
                continue
            parent[key] = (v, t)
            queue.append(key)
    return None


def soc_of(paths):
    total = 0
    for p in paths:
        cost = len(p) - 1
        while cost > 0 and p[cost - 1] == p[-1]:
            cost -= 1
        total += cost
    return total


def cells(cs):
    return "".join("({},{}),".format(x, y) for x, y in cs)


def write_log(path, instance_file, inst, solver_name, solved, paths, comp_time):
    dists = [distances(inst["grid"]["free"], g) for _, g in inst["pairs"]]
    lb = [d.get(s, 0) for d, (s, _) in zip(dists, inst["pairs"])]
    makespan = (len(paths[0]) - 1) if solved else -1
    out = [
        "instance=" + instance_file,
        "agents={}".format(inst["agents"]),
        "map_file=" + inst["map_file"],
        "solver=" + solver_name,
        "solved={}".format(int(solved)),
        "soc={}".format(soc_of(paths) if solved else 0),
        "lb_soc={}".format(sum(lb)),
        "makespan={}".format(makespan),
        "lb_makespan={}".format(max(lb)),
        "comp_time={}".format(comp_time),
        "starts=" + cells(s for s, _ in inst["pairs"]),
        "goals=" + cells(g for _, g in inst["pairs"]),
        "solution=",
    ]
    for t in range(makespan + 1):
        out.append("{}:{}".format(t, cells(p[t] for p in paths)))
    try:
        with open(path, "w") as f:
            f.write("\n".join(out) + "\n")
    except OSError:
        pass  # std::ofstream fails silently, and so does mapf-IR


def main(argv):
    log = os.environ.get("FAKE_MAPF_IR_ARGV_LOG")
    if log:
        with open(log, "w") as f:
            json.dump({"argv": argv, "cwd": os.getcwd()}, f)
    opts = parse_args(argv)
    if opts.get("h"):
        print("\nUsage: ./app [OPTIONS] [SOLVER-OPTIONS]  (FleetControl's stand-in)")
        return 0
    if not opts.get("i"):
        print("specify instance file using -i [INSTANCE-FILE], e.g.,")
        print("> ./app -i ../instance/sample.txt")
        return 0
    inst = read_instance(opts["i"])
    if opts.get("T") is not None:
        inst["max_comp_time"] = int(re.match(r"-?\d*", opts["T"]).group(0) or 0)
    solver_name = opts.get("s", "")
    if solver_name not in KNOWN_SOLVERS:
        print("warn@getSolver: unknown solver name, " + solver_name + ", continue by PIBT")
        solver_name = "PIBT"

    mode = os.environ.get("FAKE_MAPF_IR_MODE", "")
    sys.stdout.flush()
    if mode == "crash":
        print("  start solving MAPF by", solver_name)
        sys.stdout.flush()
        os.kill(os.getpid(), signal.SIGABRT)
    if mode == "exit":
        print("something went wrong in the solver")
        print("error@run: the stand-in was told to exit 3")
        return 3
    if mode == "hang":
        time.sleep(3600)
    if mode == "no-output":
        print("error@app: invalid results")
        return 0
    if mode == "garbage":
        with open(opts["o"], "w") as f:
            f.write("instance=x\nagents=banana\n")
        return 0

    t0 = time.monotonic()
    paths = None
    if mode == "invalid":
        paths = [[s, g] for s, g in inst["pairs"]]
    elif mode != "fail":
        paths = plan_prioritized(inst["grid"], inst["pairs"], inst["max_timestep"],
                                 t0 + inst["max_comp_time"] / 1000.0)
    comp_time = int((time.monotonic() - t0) * 1000)
    solved = paths is not None
    soc = soc_of(paths) if solved else 0
    makespan = len(paths[0]) - 1 if solved else -1
    print("solved={}, solver={:>8}, comp_time(ms)={:>8}, soc={:>6}, makespan={:>4}".format(
        int(solved), solver_name, comp_time, soc, makespan))
    write_log(opts["o"], opts["i"], inst, solver_name, solved, paths or [], comp_time)
    if opts.get("v"):
        print("save result as " + opts["o"])
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
