"""Robots of their real size follow one another, and never come closer than the safe distance.

Each run is judged from the robots' executed paths alone, in continuous time
(`approach.judge`: the closest approach of every pair against diameter +
margin). Over random maps, random plans of the built-in solvers, random
robot sizes, delay models whose stalls fall anywhere inside a move (also
right where a follower's hold point was), report periods and latencies up to
half a move (stale poses), and operator actions (faults, disables, strategy
switches), every run is safe and finishes; the same runs with followers let
go without the distance rule (the negative control) are caught.
"""
from __future__ import annotations

import math
from typing import List, Tuple
from unittest import mock

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from fleet_common.delays import DelayModel, MoveFates
from fleet_common.execution import Disabled, Enabled, Engine, RobotFailed, SwitchStrategy, make_strategy
from fleet_common.execution.approach import closest_approaches, judge, pairwise_reference
from fleet_common.execution.following import SLACK, hold_fraction
from fleet_common.execution.motion import Feedback
from fleet_common.execution.simulate import _Simulation, simulate
from fleet_common.formats import default_map_dirs, read_solution
from fleet_common.plan import Plan
from fleet_common.robot_size import TURTLEBOT2, cell_sized
from random_runs import PLAN_SEEDS, delay_models, fates_for, random_plan, sizes

def controls_for(plan: Plan, rng: np.random.Generator, horizon: float) -> list:
    """A few operator actions: a fault and its clearing, a disable and enable, a strategy switch."""
    controls: list = []
    n = plan.num_agents
    for _ in range(int(rng.integers(0, 3))):
        agent = int(rng.integers(0, n))
        t = float(rng.uniform(0.0, horizon))
        kind = rng.choice(["fail", "disable"])
        controls.append((RobotFailed if kind == "fail" else Disabled)(agent, t))
        controls.append(Enabled(agent, t + float(rng.uniform(0.1, 5.0))))
    if rng.random() < 0.5:
        controls.append(SwitchStrategy(make_strategy(str(rng.choice(["adg", "step"]))), float(rng.uniform(0, horizon))))
    return sorted(controls, key=lambda c: c.time)


def run_one(plan_seed, size, model, seed, strategy, period, latency, stall_at_hold, operated):
    plan = random_plan(plan_seed)
    fates = fates_for(plan, model, seed, (1.0 - size.safe_cells) if stall_at_hold else 0.0)
    controls = controls_for(plan, np.random.default_rng(seed), plan.makespan) if operated else ()
    return plan, simulate(plan, strategy, size=size, fates=fates, controls=controls,
                          feedback=Feedback(period, latency))


@settings(max_examples=500, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(plan_seed=st.sampled_from(PLAN_SEEDS), size=sizes(), model=delay_models(),
       seed=st.integers(0, 2 ** 32 - 1), period=st.floats(0.01, 0.3), latency=st.floats(0.0, 0.5),
       stall_at_hold=st.booleans(), operated=st.booleans())
def test_followers_never_come_closer_than_the_safe_distance_and_every_run_finishes(
        plan_seed, size, model, seed, period, latency, stall_at_hold, operated):
    for strategy in ("adg", "step"):  # 2 runs an example: 1,000 in all
        plan, result = run_one(plan_seed, size, model, seed, strategy, period, latency, stall_at_hold,
                               operated)
        assert result.safety.violations == (), result.safety.violations[:2]
        assert result.finished and not result.engine.stuck
        assert result.trace.final_cells() == plan.goals
        if result.closest is not None:
            assert result.closest.distance >= size.safe_cells - 1e-9


def test_followers_let_go_without_the_distance_rule_are_caught():
    """The negative control: the same engine and runs, but a follower drives to the end of its
    move whatever its leader does. The checker must see robots closer than allowed."""
    model = DelayModel(factor=(0.5, 2.0), stall_p=0.5, stall_moves=2.0)
    caught = runs = 0
    with mock.patch.object(_Simulation, "_hold", lambda self, r, d, progress: 1.0):
        for plan_seed in PLAN_SEEDS:
            for seed in range(3):
                plan, result = run_one(plan_seed, TURTLEBOT2, model, seed, "adg", 0.05, 0.025, True, False)
                runs += 1
                caught += bool(result.safety.violations)
    assert caught >= runs // 3, (caught, runs)
    # and the rule itself, on the same runs, is never caught
    plan, result = run_one(PLAN_SEEDS[0], TURTLEBOT2, model, 0, "adg", 0.05, 0.025, True, False)
    assert result.safety.violations == ()


def test_a_leader_that_stops_dead_leaves_its_follower_short_of_it():
    # two robots in a row, both moving east; the leader stalls for ever halfway
    plan = Plan(np.array([[[2, 0], [1, 0]], [[3, 0], [2, 0]], [[4, 0], [3, 0]]], dtype=np.int32))
    table = Engine(plan).table
    n = table.num_actions
    fates = MoveFates(np.zeros(n), np.ones(n), np.where(table.agent == 0, 50.0, 0.0),
                      np.full(n, 0.5), np.zeros(n), np.zeros(n))
    result = simulate(plan, "adg", size=TURTLEBOT2, fates=fates)
    safe = TURTLEBOT2.safe_cells
    assert result.safety.violations == ()
    assert result.closest.distance == pytest.approx(safe + SLACK, abs=1e-6)  # it came right up to it
    assert result.metrics.makespan > 50  # and waited there for the leader


def test_a_follower_behind_a_leader_out_for_good_waits_there_and_the_run_ends():
    # the leader is disabled (a dead battery) while it waits to start: its follower, already on its
    # way, stops short of it and says who it waits for; the simulation ends (nothing more can happen)
    plan = Plan(np.array([[[2, 0], [1, 0]], [[3, 0], [2, 0]]], dtype=np.int32))
    table = Engine(plan).table
    n = table.num_actions
    fates = MoveFates(np.where(table.agent == 0, 0.5, 0.0), np.ones(n), np.zeros(n), np.zeros(n),
                      np.zeros(n), np.zeros(n))
    result = simulate(plan, "adg", size=TURTLEBOT2, fates=fates, controls=[Disabled(0, 0.2)])
    assert result.unfinished() == [1] and result.engine.blocked_by() == {0: [1]}
    assert result.safety.violations == ()
    assert result.closest.distance == pytest.approx(TURTLEBOT2.safe_cells + SLACK, abs=1e-6)


def test_robots_as_large_as_a_cell_keep_the_cell_rule():
    plan = Plan(np.array([[[2, 0], [1, 0]], [[3, 0], [2, 0]]], dtype=np.int32))
    cell = simulate(plan, "adg", size=cell_sized())
    real = simulate(plan, "adg", size=TURTLEBOT2)
    assert cell.metrics.makespan == pytest.approx(2.0)  # the follower waits for the leader's whole move
    assert real.metrics.makespan == pytest.approx(1.0)  # the train moves as one
    assert not cell.engine.early and cell.collisions == [] and real.collisions == []


@pytest.mark.parametrize("name", ["pibt_sample.txt", "ecbs_random-32-32-20_30agents_1.txt"])
@pytest.mark.parametrize("strategy", ["adg", "step"])
def test_without_delays_a_plan_runs_as_planned(shared_data, name, strategy):
    plan = read_solution(shared_data / "solutions" / name, map_dirs=default_map_dirs()).plan
    result = simulate(plan, strategy, size=TURTLEBOT2)
    assert result.metrics.makespan <= 1.02 * plan.makespan
    assert result.safety.violations == ()
    cell = simulate(plan, strategy, size=cell_sized())
    assert cell.metrics.makespan > result.metrics.makespan  # what a robot as large as a cell costs


# ---- the geometry ----------------------------------------------------------------------------

def _dist_to_polyline(p, points) -> float:
    best = math.inf
    pts = list(points) if len(points) > 1 else [points[0], points[0]]
    for (ax, ay), (bx, by) in zip(pts, pts[1:]):
        dx, dy = bx - ax, by - ay
        t = 0.0 if dx * dx + dy * dy < 1e-18 else max(0.0, min(1.0, ((p[0] - ax) * dx + (p[1] - ay) * dy) / (dx * dx + dy * dy)))
        best = min(best, math.hypot(p[0] - ax - t * dx, p[1] - ay - t * dy))
    return best


MOVES = [(1, 0), (-1, 0), (0, 1), (0, -1)]


@settings(max_examples=300, deadline=None)
@given(fdir=st.sampled_from(MOVES), ldir=st.sampled_from(MOVES), progress=st.floats(-0.5, 1.0).map(lambda v: 0.0 if abs(v) < 1e-9 else v),
       safe=st.floats(0.1, 0.99), now=st.floats(0.0, 0.5))
def test_the_hold_point_keeps_the_follower_clear_of_the_leaders_path_and_no_farther(fdir, ldir, progress, safe, now):
    # the follower enters cell (0, 0) moving along fdir; the leader leaves (0, 0) along ldir and
    # is `progress` of the way out (below 0: still coming in, along fdir ahead of the follower)
    src, dst = (-fdir[0], -fdir[1]), (0, 0)
    assume((ldir[0], ldir[1]) != (-fdir[0], -fdir[1]))  # a swap: never two robots' plan
    if progress >= 0:
        path = [(ldir[0] * progress, ldir[1] * progress), (ldir[0], ldir[1])]
    else:
        path = [(fdir[0] * progress, fdir[1] * progress), (0, 0), (ldir[0], ldir[1])]
    start = (src[0] + (dst[0] - src[0]) * now, src[1] + (dst[1] - src[1]) * now)
    assume(_dist_to_polyline(start, path) >= safe)
    hold = hold_fraction(src, dst, path, safe, now)
    assert now <= hold <= 1.0
    for k in range(21):  # every point on the way to the hold point is clear
        f = now + (hold - now) * k / 20
        p = (src[0] + (dst[0] - src[0]) * f, src[1] + (dst[1] - src[1]) * f)
        assert _dist_to_polyline(p, path) >= safe - 1e-6
    if hold < 1.0:  # and it is the farthest such point
        f = min(1.0, hold + 1e-3)
        p = (src[0] + (dst[0] - src[0]) * f, src[1] + (dst[1] - src[1]) * f)
        assert _dist_to_polyline(p, path) < safe + 1e-2


@st.composite
def random_paths(draw) -> List[List[Tuple[float, float, float]]]:
    paths = []
    for _ in range(draw(st.integers(2, 6))):
        x, y, t = float(draw(st.integers(0, 4))), float(draw(st.integers(0, 4))), 0.0
        knots = [(0.0, x, y)]
        for _ in range(draw(st.integers(0, 6))):
            t += draw(st.sampled_from([0.0, 0.3, 1.0]))
            dx, dy = draw(st.sampled_from(MOVES))
            f = draw(st.sampled_from([1.0, 0.5, 0.3]))
            knots.append((t, x, y))
            t += draw(st.sampled_from([0.5, 1.0, 2.0]))
            x, y = x + dx * f, y + dy * f
            knots.append((t, x, y))
        paths.append(knots)
    return paths


@settings(max_examples=300, deadline=None)
@given(paths=random_paths())
def test_the_checker_finds_what_comparing_every_piece_with_every_other_finds(paths):
    fast = {k: a.distance for k, a in closest_approaches(paths).items()}
    slow = pairwise_reference(paths)
    assert fast.keys() == slow.keys()
    for key in fast:
        assert fast[key] == pytest.approx(slow[key], abs=1e-9)
    verdict = judge(paths, 0.5)
    assert {a.agents for a in verdict.violations} == {k for k, d in slow.items() if d < 0.5 - 1e-9}
