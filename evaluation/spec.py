"""An experiment file: what to sweep, read into the list of cells to run.

    name: lab-and-arena                 # optional; default: the file's stem
    plans:                              # each a solution file, or an instance and a solver
      - solution: ../shared/data/mapf-ir/solutions/pibt_sample.txt
      - instance: lab                   # the embedded lab scenario
        solver: cbs
      - instance: ../shared/data/mapf-ir/instances/arena_300agents_1.txt
        solver: pibt                    # built-in solver (seed 0, `time_limit` s, default 60)
    strategies: [adg, step]             # or {adg: {lookahead: 2}, step: {}}
    delays: ["events=bernoulli:{p}:1-5", btpg]   # delay-model specs; {p} takes each value of p
    p: [0, 0.05, 0.1, 0.2, 0.3]
    seeds: 30                           # 0..29, or a list
    disable: [none, "0@10"]             # optional: robot ROBOT out for good at plan step STEP
    recover: [none, replan]             # optional: replan the others when the run stalls
    reroute: [none, auto]               # optional: reroute robots a late one holds up (default none)
    reroute_scope: [held, all]          # optional: whom a reroute may give new paths: the held-up
                                        # robots (default) or every robot (`execution.reroute_all`)
    trim: [false, true]                 # optional: the plan and the held scope's reroutes' plans
                                        # trimmed of moves that do not bring a robot in sooner
                                        # (`planning.trim`; scope all trims its own always)
    chain: [engine, wire]               # optional: engine alone (default), or also virtual
                                        # robots and the manager over loopback (wire_cell.py)
    time_scale: 10                      # wire cells: the virtual fleet's time scale

Paths are relative to the experiment file. Every combination is one cell; a
cell's `key` names it, so a results table tells which cells are done.
"""
from __future__ import annotations

import itertools
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Dict, List, Optional, Tuple

from fleet_common.delays import DelayModelError, parse_delay_model
from fleet_common.errors import FormatError
from fleet_common.execution import STRATEGIES
from fleet_common.planning import SOLVER_NAMES
from fleet_common.robot_size import TURTLEBOT2, RobotSize, cell_sized
from fleet_common.yaml_lines import load_marked, read_yaml_text, where

KEYS = ("name", "plans", "strategies", "delays", "p", "seeds", "disable", "recover", "chain",
        "time_scale", "sizes", "reroute", "reroute_scope", "trim")
#: Robot sizes a sweep names: "turtlebot" (the lab's robots, 354 mm on 700 mm cells, 0.1 m margin),
#: "cell" (as large as a cell: the cell rule of robots before they had a size), or D:M (metres).
SIZES = ("turtlebot", "cell")
RECOVER = ("none", "replan")
REROUTE = ("none", "auto")
#: `execution.reroute.SCOPES`, as a sweep names them
REROUTE_SCOPES = ("held", "all")
CHAINS = ("engine", "wire")


class ExperimentSpecError(FormatError):
    """An experiment file that does not say what to sweep."""


@dataclass(frozen=True)
class PlanSource:
    """Where a plan comes from: a solution file, or an instance solved by `solver`."""

    name: str
    path: Path
    solver: Optional[str] = None   # None: `path` is a solution
    time_limit: float = 60.0


@dataclass(frozen=True)
class Cell:
    """One run of the sweep."""

    plan: str
    strategy: str
    settings: Tuple[Tuple[str, Any], ...]
    delay: str
    p: Optional[float]
    seed: int
    disable: str
    recover: str
    chain: str = "engine"     # or "wire": virtual robots and the manager (wire_cell.py)
    time_scale: float = 10.0  # wire cells: the virtual fleet's
    size: str = "turtlebot"   # the robots' size (SIZES, or D:M in metres)
    reroute: str = "none"     # REROUTE: new paths mid-run for robots a late one holds up
    reroute_scope: str = "held"  # REROUTE_SCOPES: whom a reroute may give new paths
    trim: bool = False        # the plan and the held scope's reroutes' plans trimmed (`planning.trim`)

    @property
    def robot_size(self) -> RobotSize:
        return robot_size_named(self.size)

    @property
    def key(self) -> str:
        parts = [self.plan, self.strategy + "".join(":{}={}".format(k, v) for k, v in self.settings),
                 self.delay, "" if self.p is None else repr(self.p), str(self.seed), self.disable,
                 self.recover]
        if self.chain != "engine":  # engine keys stay as they were: older tables resume
            parts.append("{}:x{:g}".format(self.chain, self.time_scale))
        if self.size != "cell":  # tables from before robots had a size were of cell-sized robots
            parts.append("size={}".format(self.size))
        if self.reroute != "none":  # tables from before rerouting never rerouted
            parts.append("reroute={}".format(self.reroute))
            if self.reroute_scope != "held":  # keys from before the scope rerouted the held-up robots
                parts.append("reroute_scope={}".format(self.reroute_scope))
        if self.trim:  # keys from before trimming ran the plans as given
            parts.append("trim")
        return "|".join(parts)


@dataclass
class Experiment:
    name: str
    path: Path
    plans: List[PlanSource]
    cells: List[Cell]


def read_experiment(path: Path) -> Experiment:
    data = load_marked(read_yaml_text(str(path), ExperimentSpecError), str(path), ExperimentSpecError)
    if not isinstance(data, dict):
        raise ExperimentSpecError("expected a mapping with plans, strategies, delays, seeds", str(path), 1)
    unknown = [k for k in data if k not in KEYS]
    if unknown:
        raise _error(path, data, unknown[0], "unknown key {!r}; expected one of {}".format(
            unknown[0], ", ".join(KEYS)))
    for key in ("plans", "strategies", "seeds"):
        if key not in data:
            raise ExperimentSpecError("missing key {!r}".format(key), str(path), 1)
    plans = _plans(path, data)
    strategies = _strategies(path, data)
    ps = _list(path, data, "p", [None])
    for p in ps:
        if p is not None and (isinstance(p, bool) or not isinstance(p, (int, float)) or not 0 <= p <= 1):
            raise _error(path, data, "p", "expected probabilities 0..1, got {!r}".format(p))
    delays = [(d, p) for d in _delays(path, data) for p in (ps if "{p}" in d else [None])]
    seeds = _seeds(path, data)
    disable = [str(d) for d in _list(path, data, "disable", ["none"])]
    for d in disable:
        if d != "none" and not re.fullmatch(r"\d+@\d+", d):
            raise _error(path, data, "disable", "expected none or ROBOT@STEP (e.g. 0@10), got {!r}".format(d))
    recover = [str(r) for r in _list(path, data, "recover", ["none"])]
    if any(r not in RECOVER for r in recover):
        raise _error(path, data, "recover", "expected none or replan, got {!r}".format(recover))
    chains = [str(c) for c in _list(path, data, "chain", ["engine"])]
    if any(c not in CHAINS for c in chains):
        raise _error(path, data, "chain", "expected engine or wire, got {!r}".format(chains))
    reroute = [str(r) for r in _list(path, data, "reroute", ["none"])]
    if any(r not in REROUTE for r in reroute):
        raise _error(path, data, "reroute", "expected none or auto, got {!r}".format(reroute))
    scopes = [str(r) for r in _list(path, data, "reroute_scope", ["held"])]
    if any(r not in REROUTE_SCOPES for r in scopes):
        raise _error(path, data, "reroute_scope", "expected held or all, got {!r}".format(scopes))
    if scopes != ["held"] and reroute == ["none"]:
        raise _error(path, data, "reroute_scope", "a scope needs reroute: [auto] (it says whom a reroute "
                     "may give new paths)")
    trims = _list(path, data, "trim", [False])
    if any(not isinstance(t, bool) for t in trims):
        raise _error(path, data, "trim", "expected true or false, got {!r}".format(trims))
    if "wire" in chains and (disable != ["none"] or recover != ["none"]):
        raise _error(path, data, "chain", "wire cells cannot disable robots or replan (an "
                     "operator's acts in the manager); sweep those on the engine alone")
    scale = data.get("time_scale", 10.0)
    if isinstance(scale, bool) or not isinstance(scale, (int, float)) or not 0 < scale <= 100:
        raise _error(path, data, "time_scale", "expected a number over 0 and at most 100, got {!r}".format(scale))
    sizes = [str(z) for z in _list(path, data, "sizes", ["turtlebot"])]
    for z in sizes:
        try:
            robot_size_named(z)
        except ValueError:
            raise _error(path, data, "sizes", "expected turtlebot, cell or DIAMETER:MARGIN in metres "
                         "(e.g. 0.354:0.1), got {!r}".format(z)) from None
    cells = [Cell(plan.name, s, settings, d.replace("{p}", _p(p)) if p is not None else d, p, seed, dis, rec,
                  chain, float(scale), size, rr, scope, trim)
             for plan, (s, settings), (d, p), seed, dis, rec, chain, size, rr, scope, trim in itertools.product(
                 plans, strategies, delays, seeds, disable, recover, chains, sizes, reroute, scopes, trims)
             if not (dis == "none" and rec != "none") and not (rr == "none" and scope != "held")]
    return Experiment(str(data.get("name") or path.stem), path, plans, cells)


def robot_size_named(name: str) -> RobotSize:
    """The size a sweep names (SIZES, or D:M in metres); ValueError if none."""
    if name == "turtlebot":
        return TURTLEBOT2
    if name == "cell":
        return cell_sized()
    try:
        diameter, margin = (float(v) for v in name.split(":"))
        return RobotSize(diameter, margin)
    except (ValueError, TypeError):
        raise ValueError("not a robot size: {!r}".format(name)) from None


def _p(p: float) -> str:
    return repr(float(p)).rstrip("0").rstrip(".") if p else "0"


def _error(path: Path, data: Any, key: str, message: str) -> ExperimentSpecError:
    return ExperimentSpecError("{}: {}".format(key, message), str(path), *where(data, key))


def _list(path: Path, data: Dict, key: str, default: List[Any]) -> List[Any]:
    value = data.get(key, default)
    if not isinstance(value, list) or not value:
        raise _error(path, data, key, "expected a non-empty list")
    return value


def _plans(path: Path, data: Dict) -> List[PlanSource]:
    out: List[PlanSource] = []
    entries = _list(path, data, "plans", [])
    for i, entry in enumerate(entries):
        line, col = where(entries, i)

        def bad(message: str) -> ExperimentSpecError:
            return ExperimentSpecError("plans[{}]: {}".format(i, message), str(path), line, col)
        if isinstance(entry, str):
            entry = {"solution": entry}
        if not isinstance(entry, dict) or ("solution" in entry) == ("instance" in entry):
            raise bad("expected {solution: FILE} or {instance: FILE|lab, solver: NAME}")
        extra = set(entry) - {"solution", "instance", "solver", "name", "time_limit"}
        if extra:
            raise bad("unknown key {!r}".format(sorted(extra)[0]))
        if "solution" in entry:
            file = (path.parent / str(entry["solution"])).resolve()
            solver = None
        else:
            solver = entry.get("solver")
            if solver not in SOLVER_NAMES:
                raise bad("solver: expected one of {}, got {!r}".format(", ".join(SOLVER_NAMES), solver))
            if entry["instance"] == "lab":
                from fleet_common.lab import lab_instance_path
                file = lab_instance_path()
            else:
                file = (path.parent / str(entry["instance"])).resolve()
        if not file.is_file():
            raise bad("no such file: {}".format(file))
        name = str(entry.get("name") or (file.stem if solver is None else "{}-{}".format(
            "lab" if entry.get("instance") == "lab" else file.stem, solver)))
        out.append(PlanSource(name, file, solver, float(entry.get("time_limit", 60.0))))
    names = [p.name for p in out]
    if len(set(names)) != len(names):
        raise _error(path, data, "plans", "two plans are named alike; give one a `name:`")
    return out


def _strategies(path: Path, data: Dict) -> List[Tuple[str, Tuple[Tuple[str, Any], ...]]]:
    value = data["strategies"]
    items = list(value.items()) if isinstance(value, dict) else [(s, {}) for s in _list(path, data, "strategies", [])]
    out = []
    for name, settings in items:
        if name not in STRATEGIES or not isinstance(settings, (dict, type(None))):
            raise _error(path, data, "strategies", "expected strategies from {} (with settings), got {!r}".format(
                ", ".join(STRATEGIES), name))
        out.append((str(name), tuple(sorted((settings or {}).items()))))
    return out


def _delays(path: Path, data: Dict) -> List[str]:
    specs = _list(path, data, "delays", ["none"])
    for spec in specs:
        if not isinstance(spec, str):
            raise _error(path, data, "delays", "expected delay-model specs (strings), got {!r}".format(spec))
        try:
            parse_delay_model(spec.replace("{p}", "0.5"), default="none")
        except DelayModelError as err:
            raise _error(path, data, "delays", str(err)) from None
    return specs


def _seeds(path: Path, data: Dict) -> List[int]:
    value = data["seeds"]
    seeds = list(range(value)) if isinstance(value, int) and not isinstance(value, bool) else value
    if not isinstance(seeds, list) or not seeds or not all(
            isinstance(s, int) and not isinstance(s, bool) and s >= 0 for s in seeds):
        raise _error(path, data, "seeds", "expected a count or a list of whole numbers >= 0")
    return seeds
