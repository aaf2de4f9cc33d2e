"""Re-ordering through the manager: a robot held up inside a drive it accepted is passed.

The simulator's delays make a robot stand still before its move begins; a real
robot (and the virtual fleet) accepts its drive first and then stands still in
it, so the manager counts the move begun. Until 2026-11-26 the manager passed
such a robot never: the re-ordering counted a begun move as ending now
whatever its age, and the manager never sent the strategy its `Tick`, so a
robot that stood still did not become passable as time went on. The chain
experiment (`experiments/chain.yaml`, EVALUATION.md) showed it: on the lab plan
at p = 0.2, seed 3, the engine's re-ordering ended 11 % sooner than the ADG and
the manager's as late as the ADG.

The scenario is that experiment's seed 0, in memory: the lab's five robots,
every drive meeting the fate the simulator draws for the same move
(`events=bernoulli:0.2:1-5`, seed 0, paired). Robot 2 stands about four moves
inside its first drive; robot 4 is due after it at (9, 5). Then the same paired
delays over many seeds and p up to 0.3: every robot home, no two true centres
closer than the safe distance; and the negative control, the tempting wrong
fix (pass a robot standing inside its drive into the cell), caught by that
check.
"""
from __future__ import annotations

from typing import Dict, List, Optional, Tuple, Union

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from fleet_common.delays import parse_delay_model
from fleet_common.execution import ReorderStrategy, Strategy, SwitchStrategy
from fleet_common.execution.actions import ActionTable
from fleet_common.execution.run import RunState
from fleet_common.lab import lab_instance_path
from fleet_common.plan_loading import LoadedPlan, load_plan
from fleet_common.robot_size import TURTLEBOT2
from fleet_manager.settings import ManagerSettings
from memory_fleet import MemoryFleet, lab_fleet
from test_manager_core import run_recording
from virtual_fleet.delays import FleetDelays

STEP = 0.5  # s: a nominal move of the memory fleet's robots (2 cells/s)


def paired_run(strategy: Union[str, Strategy], p: float = 0.2, seed: int = 0) -> Tuple[MemoryFleet, List[float]]:
    """The run to its end, and the closest distance of two robots' true centres at each tick."""
    loaded = lab_plan()
    first = ActionTable.from_plan(loaded.plan).first
    moves = [int(first[i + 1] - first[i]) for i in range(len(first) - 1)]
    name = strategy if isinstance(strategy, str) else "adg"
    f = MemoryFleet(loaded, lab_fleet(), ManagerSettings(step_time=STEP, size=TURTLEBOT2, strategy=name))
    model = FleetDelays(parse_delay_model("events=bernoulli:{}:1-5".format(p)), nominal_s=STEP, seed=seed,
                        num_robots=5).paired_with(moves)
    for i, robot in enumerate(f.robots.values()):
        robot.navigator.model = model.for_robot(i)
    f.link_up()
    if not isinstance(strategy, str):  # a strategy object: switched to as the run starts
        f.core.run.driver.handle(SwitchStrategy(strategy, f.now), f.now)
    assert f.ask(f.console(), "start").ok
    seen = run_recording(f, limit=60.0)
    assert f.phase == "done", f.said[-3:]
    return f, seen


def lab_plan() -> LoadedPlan:
    if not _LAB:
        _LAB.append(load_plan(lab_instance_path(), 5, "the lab fleet", [], solver="cbs"))
    return _LAB[0]


_LAB: List[LoadedPlan] = []


def arrivals(f: MemoryFleet) -> Dict[int, float]:
    """Robot id -> when it completed its last move."""
    last: Dict[int, float] = {}
    for kind, t, data in f.records:
        if kind == "action" and data["phase"] == "completed":
            last[data["robot"]] = t
    return last


@pytest.fixture(scope="module")
def runs() -> Dict[str, Tuple[MemoryFleet, List[float]]]:
    return {s: paired_run(s) for s in ("adg", "reorder")}


def test_a_robot_standing_inside_its_drive_is_passed(runs):
    (adg, _), (reorder, _) = runs["adg"], runs["reorder"]
    passes: List[dict] = reorder.kinds("pass")
    assert [(p["robot"], p["passed"], tuple(p["cell"])) for p in passes] == [(4, 2, (9, 5))]
    # robot 2 had been sent its drive into (10, 5) and stood still in it: the pass came while
    # its move was begun (accepted) and not completed
    began = [t for kind, t, d in reorder.records if kind == "action" and d["robot"] == 2
             and d["index"] == 0 and d["phase"] == "started"]
    done = [t for kind, t, d in reorder.records if kind == "action" and d["robot"] == 2
            and d["index"] == 0 and d["phase"] == "completed"]
    passed_at = [t for kind, t, d in reorder.records if kind == "pass"][0]
    assert began[0] < passed_at < done[0]
    # robot 4 no longer waits for it: home well over a move sooner than under the ADG
    assert arrivals(reorder)[4] < arrivals(adg)[4] - 2 * STEP
    assert not adg.kinds("pass")


def test_every_robot_home_and_apart(runs):
    for f, seen in runs.values():
        assert f.at_goals()
        assert min(seen) >= TURTLEBOT2.safe_cells - 1e-9


@settings(max_examples=24, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(p=st.sampled_from([0.1, 0.2, 0.3]), seed=st.integers(0, 2 ** 31 - 1))
def test_reordering_in_the_manager_keeps_robots_apart_and_brings_every_one_home(p, seed):
    f, seen = paired_run("reorder", p, seed)
    assert f.at_goals()
    assert min(seen) >= TURTLEBOT2.safe_cells - 1e-9


class PassesStandingRobots(ReorderStrategy):
    """Wrong on purpose, the tempting fix: a robot standing still inside its drive into the cell
    counts as not set off, so it is passed there (it is on its way: when it moves on, it drives
    into the robot that passed it)."""

    def _passable(self, run: RunState, q: int, ep: int) -> Optional[bool]:
        p = run.agent[ep + 1]
        if ep < run.first[p] or ep - run.first[p] < run.completed[p]:
            return None
        lo = run.dep[ep]
        if not (lo < 0 or run.agent[lo] == q or run.released(lo)):
            return None
        return False

    def _late(self, run: RunState, p: int, k: int, standing: bool) -> bool:
        return True


def test_a_wrong_reordering_in_the_manager_is_caught():
    """The negative control: passing a robot that stands still inside its drive into the cell
    brings robots closer than the safe distance."""
    wrong = [min(paired_run(PassesStandingRobots(), 0.3, seed)[1]) for seed in range(6)]
    assert sum(d < TURTLEBOT2.safe_cells for d in wrong) >= 2, wrong
    right = [min(paired_run("reorder", 0.3, seed)[1]) for seed in range(6)]  # the same delays
    assert min(right) >= TURTLEBOT2.safe_cells - 1e-9, right

