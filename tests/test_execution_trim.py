"""Runs on trimmed plans (`simulate(trim=True)`, `RerouteRule.trim`), judged by what happened.

Each run is judged as test_execution_reroute.py judges a rerouted one: the robots' executed
paths in continuous time (`approach.judge`: no pair closer than the safe distance), the executed
trace, every robot at its goal, every hand-over accepted, every reroute's plan valid. Runs: random
maps and plans, both scopes, sizes, strategies and delays, and the operator's faults, disables and
switches. The negative control trims a reroute's plan from its first step, before the moves sent
at the cut are made: the hand-over's fit check refuses it and the checks fail the run; with the
fit check off too, runs break (a robot sent a move from a cell it is not in, robots too close).
"""
from __future__ import annotations


import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from fleet_common.delays import DelayModel, EventDelays
from fleet_common.execution import engine as engine_module
from fleet_common.execution import trim_cut
from fleet_common.execution.motion import Feedback
from fleet_common.execution.reroute import RerouteRule
from fleet_common.execution.simulate import simulate
from fleet_common.planning.trim import trim_moves
from fleet_common.robot_size import TURTLEBOT2, RobotSize, cell_sized
from fleet_common.validate import validate_plan
from random_runs import PLAN_SEEDS, operator_actions, operator_case, random_problem, sizes
from test_execution_reroute import assert_safe_and_complete

HELD = RerouteRule(trim=True)
ALL = RerouteRule(scope="all", trim=True)


def run_trimmed(plan_seed: int, seed: int, size: RobotSize, p: float, strategy: str = "adg",
                rule: RerouteRule = ALL):
    plan, grid = random_problem(plan_seed)
    model = DelayModel(events=EventDelays("bernoulli", p, 1, 5))
    return plan, grid, simulate(plan, strategy, model, seed=seed, size=size, reroute=rule, grid=grid, trim=True)


def assert_all_good(plan, grid, size, result) -> None:
    assert_safe_and_complete(plan, grid, size, result)
    for _, rr in result.reroutes:
        assert validate_plan(rr.plan, grid, strict_rotations=True).ok


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(plan_seed=st.sampled_from(PLAN_SEEDS), seed=st.integers(0, 1000), size=st.one_of(st.just(cell_sized()), sizes()),
       p=st.floats(0.05, 0.4), strategy=st.sampled_from(["adg", "reorder"]), rule=st.sampled_from([HELD, ALL]))
def test_trimmed_runs_are_safe_complete_and_every_hand_over_accepted(plan_seed, seed, size, p, strategy, rule):
    plan, grid, result = run_trimmed(plan_seed, seed, size, p, strategy, rule)
    assert_all_good(plan, grid, size, result)


def test_trimmed_runs_beside_the_operators_hand_stay_safe_and_every_robot_arrives():
    """Both scopes, trimmed, while the operator acts: faults and disables cleared again, switches
    between every strategy mid-run, late pose reports. Every run safe, every robot home."""
    rerouted = total = 0
    for plan_seed in PLAN_SEEDS:
        for seed in range(2):
            plan, grid, rng, size, model = operator_case(plan_seed, seed, 2027)
            controls = operator_actions(plan, rng, plan.makespan)
            start = ("adg", "reorder", "step")[(plan_seed + seed) % 3]
            rule = (HELD, ALL)[seed % 2]
            result = simulate(plan, start, model, seed=seed, size=size, reroute=rule, grid=grid, trim=True,
                              controls=controls, feedback=Feedback(0.05, float(rng.uniform(0.0, 0.3))))
            assert_all_good(plan, grid, size, result)
            total += 1
            rerouted += bool(result.reroutes)
    assert rerouted >= total // 4, (rerouted, total)


FIXED = [(s, k, TURTLEBOT2 if k % 2 else cell_sized()) for s in PLAN_SEEDS for k in range(2)]


def spy_on_trims(monkeypatch) -> list:
    """The list every trim of a plan from a cut (`trim_cut`) appends its result to, from now on."""
    real = trim_cut.trim_moves
    trims = []

    def spy(*args, **kwargs):
        result = real(*args, **kwargs)
        trims.append(result)
        return result
    monkeypatch.setattr(trim_cut, "trim_moves", spy)
    return trims


def test_runs_trim_their_reroutes_plans_and_stay_good(monkeypatch):
    """The property above is about runs that trim a reroute's plan: every plan handed over came out
    of the trim, and on these fixed runs many hand over one in which a rerouted robot makes fewer
    moves than the look planned (scope all trims each plan before judging it)."""
    trims = spy_on_trims(monkeypatch)
    runs_trimmed = 0
    for plan_seed, seed, size in FIXED:
        trims.clear()
        plan, grid, result = run_trimmed(plan_seed, seed, size, 0.2)
        assert_all_good(plan, grid, size, result)
        out = {id(t.plan): t for t in trims}
        assert all(id(rr.plan) in out for _, rr in result.reroutes)  # every plan handed over was trimmed
        runs_trimmed += any(out[id(rr.plan)].robots for _, rr in result.reroutes)
    assert runs_trimmed >= len(FIXED) // 4, runs_trimmed


def test_scope_all_trims_its_plans_without_trim_and_the_held_scope_does_not(monkeypatch):
    """Scope all's replans wind as PIBT makes them, so it trims every plan it hands over whatever
    `trim` says (`reroute.decide`); the held scope's reroutes are trimmed only with `trim`. The
    plan given is not trimmed without `trim`: at p = 0 scope all's run is the ADG's exactly."""
    trims = spy_on_trims(monkeypatch)
    handed = {"all": 0, "held": 0}
    for scope in ("all", "held"):
        for plan_seed, seed, size in FIXED[:16]:
            trims.clear()
            plan, grid = random_problem(plan_seed)
            model = DelayModel(events=EventDelays("bernoulli", 0.2, 1, 5))
            result = simulate(plan, "adg", model, seed=seed, size=size, reroute=RerouteRule(scope=scope), grid=grid)
            assert_all_good(plan, grid, size, result)
            out = {id(t.plan) for t in trims}
            handed[scope] += len(result.reroutes)
            if scope == "all":
                assert all(id(rr.plan) in out for _, rr in result.reroutes)
            else:
                assert not trims
    assert handed["all"] >= 8 and handed["held"] >= 8, handed
    for plan_seed in PLAN_SEEDS[:8]:
        plan, grid = random_problem(plan_seed)
        plain = simulate(plan, "adg", DelayModel(), seed=1, size=TURTLEBOT2)
        rerouted = simulate(plan, "adg", DelayModel(), seed=1, size=TURTLEBOT2, grid=grid,
                            reroute=RerouteRule(scope="all"))
        assert rerouted.reroutes == () and rerouted.metrics.makespan == plain.metrics.makespan
        assert rerouted.trace.moves == plain.trace.moves


def test_a_trimmed_run_meets_the_same_fates_robot_by_robot():
    """Paired: a robot's k-th move keeps the fate of its k-th move in the plan given, so a robot the
    trim left alone is as long alone as untrimmed, and a trimmed one no longer."""
    for plan_seed in PLAN_SEEDS[:8]:
        plan, grid = random_problem(plan_seed)
        model = DelayModel(events=EventDelays("bernoulli", 0.3, 1, 5))
        plain = simulate(plan, "adg", model, seed=5, size=TURTLEBOT2, grid=grid)
        trimmed = simulate(plan, "adg", model, seed=5, size=TURTLEBOT2, grid=grid, trim=True)
        moved = set(trim_moves(plan, grid).robots)
        for r in range(plan.num_agents):
            if r in moved:
                assert trimmed.alone[r] <= plain.alone[r] + 1e-9
            else:
                assert trimmed.alone[r] == pytest.approx(plain.alone[r])


@pytest.mark.parametrize("strategy", ["adg", "reorder", "step"])
def test_without_delays_a_trimmed_plan_ends_no_later(strategy):
    for plan_seed in PLAN_SEEDS[:8]:
        plan, grid = random_problem(plan_seed)
        size = cell_sized() if plan_seed % 2 else TURTLEBOT2
        plain = simulate(plan, strategy, DelayModel(), seed=1, size=size)
        trimmed = simulate(plan, strategy, DelayModel(), seed=1, size=size, grid=grid, trim=True, reroute=ALL)
        assert trimmed.reroutes == ()
        assert trimmed.metrics.makespan <= plain.metrics.makespan + 1e-9
        assert sum(len(m) for m in trimmed.trace.moves) <= sum(len(m) for m in plain.trace.moves)


def test_trimming_needs_the_map():
    plan, _ = random_problem(PLAN_SEEDS[0])
    with pytest.raises(ValueError, match="map"):
        simulate(plan, "adg", trim=True)


def wrong_trim(monkeypatch) -> None:
    """Trim a reroute's plan from its first step, before the moves sent at the cut are made."""
    monkeypatch.setattr(trim_cut, "sent_moves_in", lambda plan, cut, grid: [[] for _ in range(plan.num_agents)])


def test_without_the_cells_of_moves_sent_kept_hand_overs_are_refused(monkeypatch):
    """Negative control: each robot keeps its own moves sent, but the cells those moves enter are
    not kept from the others until their robots are in: some trimmed plans send a robot where one
    with a move sent is about to be (or, a follower, is already), and the fit check refuses them
    (held scope, plan seeds 4, 7, 18, 22 and 23 when written)."""
    real = trim_cut.trim_moves
    monkeypatch.setattr(trim_cut, "trim_moves", lambda *a, **k: real(*a, **{**k, "reserved": ()}))
    refused = 0
    for plan_seed in (4, 7, 18, 22, 23):
        for seed in range(6):
            refused += run_trimmed(plan_seed, seed, TURTLEBOT2, 0.2, rule=HELD)[2].refused
    assert refused >= 3, refused


def test_the_control_runs_are_good_with_the_product():
    for plan_seed in (4, 7, 18, 22, 23):
        for seed in range(6):
            for rule in (HELD, ALL):
                plan, grid, result = run_trimmed(plan_seed, seed, TURTLEBOT2, 0.2, rule=rule)
                assert_all_good(plan, grid, TURTLEBOT2, result)


def caught_runs():
    for plan_seed in PLAN_SEEDS:
        for seed in range(3):
            yield (plan_seed, seed)


def first_caught(monkeypatch):
    wrong_trim(monkeypatch)
    for plan_seed, seed in caught_runs():
        plan, grid, result = run_trimmed(plan_seed, seed, TURTLEBOT2, 0.2)
        if result.refused:
            return plan_seed, seed
    return None


def test_trimming_before_the_moves_sent_are_made_is_refused(monkeypatch):
    """Negative control: trimmed from the cut's first step, a reroute's plan changes moves already
    sent, or has robots go where a robot with a move sent is about to be: the hand-over's fit check
    refuses it (13 of these 72 runs when written), and the checks fail the run."""
    found = first_caught(monkeypatch)
    assert found is not None, "the wrong trim was never refused"
    plan, grid, result = run_trimmed(*found, TURTLEBOT2, 0.2)
    with pytest.raises(AssertionError):
        assert_all_good(plan, grid, TURTLEBOT2, result)


def test_without_the_fit_check_the_wrong_trim_breaks_runs(monkeypatch):
    """Negative control: the same wrong trim with the hand-over's fit check off (`Engine._misfit`) is
    handed over. The engine then believes robots drive moves they were never sent: the simulated
    robots' trace refuses a move from a cell the robot is not in, or the judge of the executed paths
    finds two robots closer than the safe distance (plan seed 22, seed 1 when written)."""
    wrong_trim(monkeypatch)
    monkeypatch.setattr(engine_module.Engine, "_misfit", lambda self, progress, old: None)
    broken = 0
    for plan_seed, seed in caught_runs():
        try:
            plan, grid, result = run_trimmed(plan_seed, seed, TURTLEBOT2, 0.2)
        except ValueError as err:
            assert "cannot move" in str(err)
            broken += 1
            continue
        broken += bool(result.safety.violations)
    assert broken >= 3, broken
