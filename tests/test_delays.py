"""One delay-model language for the simulator, the virtual fleet and sweeps (fleet_common.delays).

The spec language (terms, presets, the simulator's first spellings, YAML and
JSON files, a League of Robot Runners `delayConfig`), its errors (file, line,
key, what was expected), what the draws do (Bernoulli and Poisson events,
BTPG's delay-prone robots, waits that keep a robot in its cell), and the
papercut of issue 13: `fleetctl simulate` and `fleetctl virtual-fleet` read
the same specs, in the same units.
"""
from __future__ import annotations

import json
import random
import signal
import subprocess
import sys

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from fleet_common.delays import (
    DelayModel, DelayModelError, EventDelays, ProneDelays, parse_delay_model, robot_profile,
    simulator_durations,
)
from fleet_common.execution.simulate import simulate
from fleet_common.plan import Plan
from fleet_common.wire.messages import Pose
from helpers import fleetctl, free_ports
from virtual_fleet.delays import FleetDelays
from virtual_fleet.kinematics import VirtualNavigator


# ---- the language -------------------------------------------------------------------

def test_every_term_reads_and_writes_back():
    model = parse_delay_model("factor=0.9-1.2,delay=0.5,slow=0.1:2,stall=0.05:3,dropout=0.01:10,"
                              "robot=3:2,robot=1:1.5,events=poisson:0.02:2-6:gaussian,prone=0.2:0.3:4,seed=7")
    assert model == DelayModel(factor=(0.9, 1.2), delay=0.5, slow_p=0.1, slow_factor=2.0, stall_p=0.05,
                               stall_moves=3.0, dropout_p=0.01, dropout_moves=10.0,
                               robots=((1, 1.5), (3, 2.0)),
                               events=EventDelays("poisson", 0.02, 2, 6, "gaussian", 0.5, 0.25),
                               prone=ProneDelays(0.2, 0.3, 4.0), seed=7)
    assert parse_delay_model(model.spec()) == model
    assert parse_delay_model("none") == DelayModel() and DelayModel().spec() == "none"


@settings(max_examples=60)
@given(low=st.floats(0.1, 3), extra=st.floats(0, 3), p=st.floats(0, 1), moves=st.floats(0, 20),
       lo=st.integers(1, 5), span=st.integers(0, 5), model=st.sampled_from(["bernoulli", "poisson"]))
def test_a_model_written_as_a_spec_reads_back_the_same(low, extra, p, moves, lo, span, model):
    original = DelayModel(factor=(low, low + extra), stall_p=p, stall_moves=moves,
                          events=EventDelays(model, p, lo, lo + span))
    back = parse_delay_model(original.spec())
    assert back.describe() == original.describe()
    assert back.events.min == lo and back.events.max == lo + span and back.events.model == model


def test_presets_old_spellings_and_combining():
    assert parse_delay_model("moderate") == parse_delay_model("factor=0.8-1.5,stall=0.02:3")
    assert parse_delay_model("btpg").prone == ProneDelays(0.1, 0.3, 5.0)  # BTPG's 10 %, p=0.3, 5 steps
    # the simulator's first spellings still read, as the new terms
    assert parse_delay_model(["random:0.9-1.1", "stall:0.05:3", "slow:4:3"]) == parse_delay_model(
        "factor=0.9-1.1,stall=0.05:3,robot=4:3")
    # later terms replace earlier ones; none clears what came before
    assert parse_delay_model("moderate,stall=0.1:2").stall_p == 0.1
    assert parse_delay_model(["moderate", "none", "delay=1"]) == DelayModel(delay=1.0)
    assert parse_delay_model([], default="moderate") == parse_delay_model("moderate")


@pytest.mark.parametrize("spec, message", [
    ("jitter=1", "unknown term 'jitter=1'; expected factor=LOW-HIGH"),
    ("slow=0.5", "slow=0.5: expected slow=P:F with P a probability 0..1 and factor >= 1"),
    ("stall=2:1", "stall=2:1: expected stall=P:S with P a probability 0..1"),
    ("factor=2-1", "factor=2-1: expected factor=LOW-HIGH with 0 < LOW <= HIGH"),
    ("delay=-1", "delay=-1: expected delay=D, a non-negative number of moves"),
    ("events=sometimes:0.1:1-2", "expected events=MODEL bernoulli or poisson, not 'sometimes'"),
    ("events=poisson:0.1:3-2", "events=MIN-MAX whole numbers of moves with 1 <= MIN <= MAX"),
    ("prone=2:0.3:5", "prone=2:0.3:5: expected prone=FRACTION of robots 0..1"),
])
def test_bad_specs_say_what_was_expected(spec, message):
    with pytest.raises(DelayModelError) as err:
        parse_delay_model(spec)
    assert str(err.value).startswith("delay model {!r}: ".format(spec)) and message in str(err.value)


# ---- files ----------------------------------------------------------------------------

def test_a_yaml_file_takes_the_same_terms_plain_or_as_mappings(tmp_path):
    path = tmp_path / "lab.yaml"
    path.write_text("# the lab on a bad day\nfactor: 0.9-1.3\nstall: {p: 0.05, moves: 3}\n"
                    "robot: [\"2:1.5\", {robot: 4, factor: 2}]\nevents:\n  model: poisson\n  p: 0.01\n"
                    "  min: 1\n  max: 5\n")
    model = parse_delay_model(str(path))
    assert model == parse_delay_model("factor=0.9-1.3,stall=0.05:3,robot=2:1.5,robot=4:2,events=poisson:0.01:1-5")
    # a file combines with terms like any spec
    assert parse_delay_model([str(path), "seed=3"]).seed == 3


def test_a_league_of_robot_runners_problem_file_gives_its_delay_config(tmp_path):
    problem = {"mapFile": "maps/room-64-64-16.map", "teamSize": 150,
               "delayConfig": {"seed": 0, "minDelay": 10, "maxDelay": 30, "eventModel": "poisson",
                               "pDelay": 0.01, "durationModel": "gaussian", "gaussMeanRatio": 0.5,
                               "gaussStdRatio": 0.22}}
    path = tmp_path / "room.json"
    path.write_text(json.dumps(problem, indent=2))
    model = parse_delay_model(str(path))
    assert model.events == EventDelays("poisson", 0.01, 10, 30, "gaussian", 0.5, 0.22) and model.seed == 0


@pytest.mark.parametrize("text, where, message", [
    ("factor: 0.9-1.3\nstall: {p: 1.5, moves: 3}\n", ":2:8:",
     "stall: expected P:S with P a probability 0..1 and moves >= 0, got {'p': 1.5, 'moves': 3}"),
    ("stall: {p: 0.1, length: 3}\n", ":1:8:", "stall: expected P:S (keys p, moves), not 'length'"),
    ("factor: 1\nwobble: 2\n", ":2:9:", "unknown key 'wobble'; expected one of factor, delay, slow"),
    ("- stall=0.1:3\n", ":1:1:", "expected a mapping of delay terms"),
    ("delayConfig: {pDelay: 0.1, eventModle: poisson}\n", ":1:40:", "delayConfig: unknown key 'eventModle'"),
    ("delayConfig: {pDelay: 2}\n", ":1:14:", "delayConfig: expected a probability 0..1"),
    ("factor: [0.9\n", ":2:1:", "not valid YAML"),
])
def test_bad_files_name_the_file_line_and_key(tmp_path, text, where, message):
    path = tmp_path / "bad.yaml"
    path.write_text(text)
    with pytest.raises(DelayModelError) as err:
        parse_delay_model(str(path))
    assert str(err.value).startswith(str(path) + where), str(err.value)
    assert message in str(err.value)


def test_a_missing_file_is_named():
    with pytest.raises(DelayModelError, match="nowhere.yaml: cannot read: No such file or directory"):
        parse_delay_model("nowhere.yaml")


# ---- what the draws do ------------------------------------------------------------------

def test_bernoulli_and_poisson_events_happen_as_often_as_said():
    robots = np.zeros(40000, dtype=np.int64)
    bern, _ = simulator_durations(parse_delay_model("events=bernoulli:0.2:3-3"), robots, 1, seed=1)
    assert set(np.unique(bern)) == {0.0, 3.0} and abs((bern > 0).mean() - 0.2) < 0.01
    pois, _ = simulator_durations(parse_delay_model("events=poisson:0.5:1-1"), robots, 1, seed=1)
    assert abs(pois.mean() - 0.5) < 0.02 and pois.max() >= 3  # a Poisson count, not a coin
    gauss, _ = simulator_durations(parse_delay_model("events=bernoulli:1:2-10:gaussian"), robots, 1, seed=1)
    assert gauss.min() >= 2 and gauss.max() <= 10 and abs(gauss.mean() - 6) < 0.1 and np.all(gauss == np.rint(gauss))


def test_btpg_delays_only_the_delay_prone_tenth_of_the_robots():
    model = parse_delay_model("btpg")
    robots = np.repeat(np.arange(50), 400)
    waits, moves = simulator_durations(model, robots, 50, seed=4)
    per_robot = waits.reshape(50, 400)
    delayed = np.nonzero(per_robot.any(axis=1))[0]
    assert delayed.tolist() == np.nonzero(robot_profile(model, 4, 50)[1])[0].tolist() and len(delayed) == 5
    assert set(np.unique(per_robot[delayed])) == {0.0, 5.0}
    assert abs((per_robot[delayed] > 0).mean() - 0.3) < 0.04 and np.all(moves == 1.0)


def test_the_same_seed_gives_the_same_fates_and_another_term_does_not_reshuffle_them():
    robots = np.arange(200) % 5
    one = simulator_durations(parse_delay_model("moderate"), robots, 5, seed=3)
    two = simulator_durations(parse_delay_model("moderate,events=bernoulli:0.3:2-2"), robots, 5, seed=3)
    assert np.array_equal(one[1], two[1]) and not np.array_equal(one[0], two[0])


def test_a_wait_before_a_move_keeps_the_robot_in_its_cell():
    plan = Plan.from_paths([[(0, 0), (1, 0)]])
    result = simulate(plan, "adg", parse_delay_model("events=bernoulli:1:2-2"))
    (move,) = result.trace.moves[0]
    assert (move.start, move.end) == (2.0, 3.0) and result.metrics.makespan == 3.0


# ---- issue 13: one language, one unit, both commands ------------------------------------

def test_a_stall_lasts_the_same_number_of_nominal_moves_in_the_simulator_and_the_virtual_fleet():
    """Today's virtual fleet took stall=P:S in seconds and the simulator had no such term."""
    spec = "stall=1:2"
    plan = Plan.from_paths([[(0, 0), (1, 0)]])
    assert simulate(plan, "adg", parse_delay_model(spec)).metrics.makespan == pytest.approx(3.0)
    speed = 0.5  # a nominal move is 1 / speed = 2 s
    nav = VirtualNavigator(Pose(0, 0, 0), speed=speed, rng=random.Random(1),
                           model=FleetDelays(parse_delay_model(spec), nominal_s=1 / speed), clock=lambda: 0.0)
    nav.start_drive(1.0, 0.0, 0.0)
    assert nav.seconds_to_change() == pytest.approx(3.0 / speed)


def test_a_paired_virtual_robot_meets_the_fates_the_simulator_draws_for_its_moves():
    """`fleetctl virtual-fleet --paired`: robot i's k-th drive has the fate the simulator draws for
    agent i's k-th move (same model and seed), in seconds; past the plan's moves, its own draws.
    Unpaired, the fates differ (the negative)."""
    from fleet_common.delays import simulator_fates
    from fleet_common.execution.actions import ActionTable

    plan = Plan.from_paths([[(0, 0), (1, 0), (2, 0), (3, 0)], [(3, 2), (2, 2), (2, 2), (1, 2)]])
    table = ActionTable.from_plan(plan)
    model = parse_delay_model("events=bernoulli:0.5:1-5,slow=0.2:1.5")
    sim = simulator_fates(model, table.agent, plan.num_agents, 11, 1.0)
    moves = [int(table.first[i + 1] - table.first[i]) for i in range(plan.num_agents)]
    assert moves == [3, 2]
    fleet = FleetDelays(model, nominal_s=2.0, seed=11, num_robots=2)
    for paired, same in ((fleet.paired_with(moves), True), (fleet, False)):
        drawn = []
        for i in range(2):
            robot, rng = paired.for_robot(i), random.Random(i)
            for k in range(moves[i]):
                f, a = robot.draw(rng), table.first[i] + k
                drawn.append(f.start_delay == pytest.approx(2.0 * sim.wait[a]) and
                             f.slowdown == pytest.approx(sim.slowdown[a]))
            robot.draw(rng)  # a drive past the plan's moves: its own draw, no error
        assert all(drawn) if same else not all(drawn)


def test_simulate_and_virtual_fleet_take_the_same_specs_and_refuse_bad_ones_alike(shared_data, tmp_path):
    solution = shared_data / "solutions" / "cbs_makespan-soc-pareto.txt"
    spec = "delay=0.5,slow=0.1:2,stall=0.05:3,dropout=0.01:10,factor=0.9-1.1,btpg"
    ran = fleetctl("simulate", solution, "--delay-model", spec)
    assert ran.returncode == 0, ran.stderr
    port, feedback = free_ports(2)
    robots = tmp_path / "robots.txt"
    robots.write_text("1 10.0.0.1 {} turtlebot tb1 red\n".format(port))
    fleet = subprocess.Popen([sys.executable, "-m", "fleetctl", "virtual-fleet", "--definitions", str(robots),
                              "--no-curve", "--feedback-base", str(feedback), "--delay-model", spec],
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        assert fleet.stdout.readline().startswith("virtual fleet: 1 robots")
        fleet.send_signal(signal.SIGINT)
        assert fleet.wait(timeout=10) == 0
    finally:
        if fleet.poll() is None:
            fleet.kill()
        fleet.communicate(timeout=10)
    bad = "stall=0.05"
    refusals = [fleetctl("simulate", solution, "--delay-model", bad),
                fleetctl("virtual-fleet", "--definitions", robots, "--no-curve", "--delay-model", bad)]
    assert [p.returncode for p in refusals] == [2, 2]
    assert refusals[0].stderr == refusals[1].stderr == (
        "delay model 'stall=0.05': stall=0.05: expected stall=P:S with P a probability 0..1 and moves >= 0\n")
