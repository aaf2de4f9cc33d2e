"""Virtual robots: kinematics in scaled time, the delay and fault model, 50 robots over TCP."""
from __future__ import annotations

import itertools
import math
import random
import time
from pathlib import Path
from typing import Iterator, List, Tuple

import pytest
import zmq
from hypothesis import given, settings
from hypothesis import strategies as st

from fleet_common.errors import RobotDefinitionsError
from fleet_common.robots import RobotDefinition
from fleet_common.wire import Completed, Failed, Pose, Status
from fleet_common.wire.command_check import CommandCheck, CommandLimits
from fleet_common.transport.curve_keys import load_manager_keys, load_robot_keys, make_keys
from fleet_common.transport.links import LinkSet
from fleet_common.transport.robot_link import LinkUp, RobotLink, RobotReply
from fleet_common.delays import parse_delay_model
from virtual_fleet.delays import FleetDelays
from virtual_fleet.fleet import FleetThread, VirtualFleet
from virtual_fleet.kinematics import VirtualNavigator
from helpers import free_port_block


class FakeClock:
    def __init__(self) -> None:
        self.t = 100.0

    def __call__(self) -> float:
        return self.t


def near(p: Pose, x: float, y: float, theta: float) -> bool:
    return (abs(p.x - x) < 1e-9 and abs(p.y - y) < 1e-9
            and abs(math.remainder(p.theta - theta, 2 * math.pi)) < 1e-9)


# ---- kinematics ----------------------------------------------------------------------

def test_a_drive_turns_first_then_drives_at_the_set_speed() -> None:
    clock = FakeClock()
    nav = VirtualNavigator(Pose(0, 0, 0), speed=0.5, turn_speed=1.5, clock=clock)
    nav.start_drive(0.0, 2.0, 0.0)      # behind-left: a quarter turn, then 2 cells
    turn = (math.pi / 2) / 1.5
    clock.t += turn / 2
    assert near(nav.pose(), 0, 0, math.pi / 4) and nav.poll() is None
    clock.t += turn / 2 + 2.0           # halfway along
    assert near(nav.pose(), 0, 1, math.pi / 2)
    clock.t += 2.0
    assert nav.poll().ok and near(nav.pose(), 0, 2, math.pi / 2)
    assert nav.poll() is None           # reported once


def test_a_drive_waits_at_its_hold_point_and_a_stall_drawn_later_still_happens_there() -> None:
    clock = FakeClock()
    nav = VirtualNavigator(Pose(0, 0, 0), speed=1.0, turn_speed=1.5, clock=clock)
    nav.stalls = {1: 2.0}               # the first drive halts 2 s halfway (at x = 1)
    nav.start_drive(2.0, 0.0, 0.0, hold=(0.5, 0.0))
    clock.t += 10.0                     # long after it got to its hold point
    assert near(nav.pose(), 0.5, 0, 0) and nav.poll() is None
    nav.release(1.5, 0.0)
    clock.t += 0.5
    assert near(nav.pose(), 1.0, 0, 0)  # on again, up to its stall, drawn at x = 1
    clock.t += 2.0
    assert near(nav.pose(), 1.0, 0, 0)
    clock.t += 0.5
    assert near(nav.pose(), 1.5, 0, 0)  # the new hold point: it waits again
    clock.t += 5.0
    assert near(nav.pose(), 1.5, 0, 0) and nav.poll() is None
    nav.release(0.2, 0.0)               # a hold point never moves back
    clock.t += 1.0
    assert near(nav.pose(), 1.5, 0, 0)
    nav.release(2.0, 0.0)               # the target: nothing holds it
    clock.t += 0.25
    assert near(nav.pose(), 1.75, 0, 0) and nav.poll() is None
    clock.t += 0.3
    assert nav.poll().ok and near(nav.pose(), 2.0, 0, 0)


def test_a_drive_arrives_at_the_asked_time_and_time_scale_speeds_it_up() -> None:
    clock = FakeClock()
    nav = VirtualNavigator(Pose(0, 0, 0), clock=clock, time_scale=10.0)
    nav.start_drive(1.0, 0.0, 8.0)      # 2 s at full speed, asked to take 8
    assert nav.seconds_to_change() == pytest.approx(0.8)
    clock.t += 0.79
    assert nav.poll() is None
    clock.t += 0.02
    assert nav.poll().ok and near(nav.pose(), 1, 0, 0)


def test_turn_goes_the_short_way_to_an_absolute_heading_and_halt_stops_there() -> None:
    clock = FakeClock()
    nav = VirtualNavigator(Pose(3, 3, math.radians(170)), turn_speed=1.0, clock=clock)
    nav.start_turn(math.radians(-170))  # 20 degrees through pi, not 340 back
    clock.t += math.radians(10)
    assert near(nav.pose(), 3, 3, math.pi)
    nav.halt()
    clock.t += 5
    assert near(nav.pose(), 3, 3, math.pi) and nav.poll() is None


def test_slow_and_stalled_moves_take_longer_and_the_seed_repeats_them() -> None:
    def duration(model: FleetDelays, seed: int) -> float:
        clock = FakeClock()
        nav = VirtualNavigator(Pose(0, 0, 0), clock=clock, model=model, rng=random.Random(seed))
        nav.start_drive(2.0, 0.0, 0.0)
        return nav.seconds_to_change()

    # times in nominal moves: 2 s each here (one cell at the default 0.5 cells/s)
    assert duration(FleetDelays(), 1) == pytest.approx(4.0)
    assert duration(seconds("slow=1:2"), 1) == pytest.approx(8.0)
    assert duration(seconds("stall=1:3"), 1) == pytest.approx(10.0)
    waits = [duration(seconds("delay=2"), s) - 4.0 for s in range(20)]
    assert all(0 <= w <= 4 for w in waits) and len(set(waits)) > 1
    assert waits == [duration(seconds("delay=2"), s) - 4.0 for s in range(20)]
    assert duration(seconds("events=bernoulli:1:3-3"), 1) == pytest.approx(4.0 + 6.0)


def test_delays_come_with_moves_not_with_turns_on_the_spot() -> None:
    """The model is per move, as the engine draws it; the manager's turn before a drive must
    not draw a second delay for the same move (that doubled the delays through the manager)."""
    clock = FakeClock()
    nav = VirtualNavigator(Pose(0, 0, 0), clock=clock, model=seconds("events=bernoulli:1:3-3"),
                           rng=random.Random(1), turn_speed=1.0)
    nav.start_turn(math.pi / 2)
    assert nav.seconds_to_change() == pytest.approx(math.pi / 2)  # the turn alone, no delay
    clock.t += 2.0
    nav.start_drive(0.0, 1.0, 0.0)
    assert nav.seconds_to_change() == pytest.approx(6.0 + 2.0)  # 3 moves' delay, then 1 cell


def test_a_stall_holds_the_robot_still_partway() -> None:
    clock = FakeClock()
    model = seconds("stall=1:1.5")
    nav = VirtualNavigator(Pose(0, 0, 0), clock=clock, model=model, rng=random.Random(5))
    nav.start_drive(4.0, 0.0, 0.0)
    seen = []
    for _ in range(110):
        clock.t += 0.1
        seen.append(round(nav.pose().x, 6))
    still = max(len(list(g)) for _, g in itertools.groupby(seen))
    assert still >= 29  # about 3 s without moving
    assert seen[-1] == 4.0


def seconds(spec: str) -> FleetDelays:
    """The model of `spec` for a fleet whose nominal move takes 2 s."""
    return FleetDelays(parse_delay_model(spec), nominal_s=2.0)


# ---- fleets over TCP -----------------------------------------------------------------



@pytest.fixture
def keys(tmp_path: Path) -> Path:
    make_keys(tmp_path / "keys")
    return tmp_path / "keys"


@pytest.fixture
def context() -> Iterator[zmq.Context]:
    ctx = zmq.Context()
    yield ctx
    ctx.destroy(linger=0)


def definitions(n: int) -> Tuple[List[RobotDefinition], int]:
    """n robots on consecutive free command ports, and the base of n free feedback ports."""
    base = free_port_block(2 * n)
    return [RobotDefinition(i + 1, "192.168.2.{}".format(10 + i), base + i, "u", "v{}".format(i), "red")
            for i in range(n)], base + n


def test_fifty_virtual_robots_each_complete_a_command_round_trip(keys: Path, context) -> None:
    robots, feedback = definitions(50)
    fleet = VirtualFleet(robots, keys=load_robot_keys(keys), feedback_base=feedback,
                         time_scale=20.0)
    with FleetThread(fleet):
        # the fleet runs where the definitions say, but on 127.0.0.1
        links = LinkSet([RobotLink(context, r, "epoch", keys=load_manager_keys(keys),
                                   host="127.0.0.1") for r in robots])
        try:
            start = {r.id: fleet.navigators[r.id].pose() for r in robots}
            drives = {r.id: links[r.id].drive_to_position(start[r.id].x + 1, start[r.id].y + 1, 0)
                      for r in robots}
            done = set()
            statuses = {}
            deadline = time.monotonic() + 20
            while len(statuses) < len(robots):
                assert time.monotonic() < deadline, "done: {}, status: {}".format(
                    len(done), len(statuses))
                for ev in links.poll(0.05):
                    if not isinstance(ev, RobotReply):
                        continue
                    if ev.reply == Completed(drives[ev.robot_id]):
                        done.add(ev.robot_id)
                        links[ev.robot_id].get_status()
                    elif isinstance(ev.reply, Status):
                        statuses[ev.robot_id] = ev.reply
        finally:
            links.close()
    assert done == {r.id for r in robots}
    for r in robots:
        pose = statuses[r.id].pose
        assert (pose.x, pose.y) == (start[r.id].x + 1, start[r.id].y + 1)
        assert statuses[r.id].current is None and statuses[r.id].faults == ()
    assert len({fleet.ports[r.id] for r in robots}) == 50


def test_a_robot_that_drops_out_comes_back_restarted(keys: Path, context) -> None:
    [robot], feedback = definitions(1)
    fleet = VirtualFleet([robot], keys=load_robot_keys(keys), feedback_base=feedback,
                         time_scale=4.0, model=FleetDelays(parse_delay_model("dropout=1:2"), nominal_s=1.0),
                         seed=3, check=CommandCheck(limits=CommandLimits(max_step=None)))
    with FleetThread(fleet):
        links = LinkSet([RobotLink(context, robot, "epoch", keys=load_manager_keys(keys),
                                   host="127.0.0.1")])
        try:
            cid = links[robot.id].drive_to_position(5.0, 0.0, 0.0)
            events: list = []
            deadline = time.monotonic() + 10
            while not any(isinstance(e, LinkUp) and e.restarted for e in events):
                assert time.monotonic() < deadline, events
                events += links.poll(0.05)
        finally:
            links.close()
    failed = [e.reply for e in events if isinstance(e, RobotReply) and isinstance(e.reply, Failed)]
    assert [f.id for f in failed] == [cid] and "restarted" in failed[0].reason
    assert fleet.dropouts == 1
    # it came back where it stopped: partway, not at the start or the goal
    assert 0 < fleet.navigators[robot.id].pose().x < 5


def test_robots_sharing_a_command_port_cannot_all_run_on_localhost() -> None:
    robots = [RobotDefinition(1, "10.0.0.1", 10001, "u", "a", "red", line=3),
              RobotDefinition(2, "10.0.0.2", 10001, "u", "b", "red", line=4)]
    with pytest.raises(RobotDefinitionsError) as err:
        VirtualFleet(robots)
    assert str(err.value) == ("robot_definitions.txt:4: robots 1 and 2 both use command port "
                              "10001; on one host (127.0.0.1) every robot needs its own")


def _on_knots(knots: List[Tuple[float, float, float]], t: float) -> Tuple[float, float]:
    """Where a truth path puts a robot at `t`: straight between knots, still after the last."""
    for (t0, x0, y0), (t1, x1, y1) in zip(knots, knots[1:]):
        if t0 <= t <= t1:
            f = (t - t0) / (t1 - t0) if t1 > t0 else 1.0
            return x0 + (x1 - x0) * f, y0 + (y1 - y0) * f
    return knots[-1][1], knots[-1][2]


@given(st.lists(st.tuples(st.sampled_from(["drive", "turn", "halt", "wait"]),
                          st.sampled_from([(1, 0), (0, 1), (-1, 0), (0, -1)]),
                          st.floats(0.05, 3.0)), min_size=1, max_size=12))
@settings(max_examples=60, deadline=None)
def test_the_truth_knots_are_the_exact_path_and_a_robot_at_rest_adds_none(steps) -> None:
    """The ground truth's knots, drained at any moments (the fleet drains them 20 times a
    second), give the robot's true position at every instant, rests included; a robot standing
    still adds no knot (300 of them would otherwise write 6,000 a second)."""
    clock = FakeClock()
    nav = VirtualNavigator(Pose(5, 5, 0), speed=1.0, turn_speed=1.5, clock=clock)
    knots: List[Tuple[float, float, float]] = []
    samples: List[Tuple[float, float, float]] = []  # (fleet second, true x, true y)
    for kind, (dx, dy), seconds in steps:
        clock.t += 0.1  # between two drains
        nav.poll()
        here = nav.true_pose()
        samples.append((nav.now(), here.x, here.y))
        if kind == "drive":
            nav.start_drive(round(here.x) + dx, round(here.y) + dy, 0.0)
        elif kind == "turn":
            nav.start_turn(math.atan2(dy, dx))
        elif kind == "halt":
            nav.halt()
        for _ in range(4):  # drained and sampled along the way
            clock.t += seconds / 4
            nav.poll()
            p = nav.true_pose()
            samples.append((nav.now(), p.x, p.y))
            knots += nav.drain_knots()
    for _ in range(100):  # to the end of the last motion (a few seconds), then at rest
        if nav.poll() is not None or not nav.moving:
            break
        clock.t += 0.5
    knots += nav.drain_knots()
    clock.t += 5.0
    assert nav.drain_knots() == []  # at rest
    for t, x, y in samples:
        kx, ky = _on_knots(knots, t)
        assert math.hypot(kx - x, ky - y) < 1e-6, (t, (x, y), (kx, ky))


def test_the_state_file_holds_a_robot_where_it_came_to_rest_at_once(tmp_path: Path) -> None:
    """A power cut right after a robot stopped starts it again where it stopped: the state file is
    written as soon as a robot comes to rest, not only five times a second (a live session's robot,
    at its goal, started again 0.06 cells short of it: the file was up to 0.2 s of driving old)."""
    from virtual_fleet.truth import STATE_PERIOD, TruthRecorder, load_state
    state = tmp_path / "state.json"
    recorder = TruthRecorder(None, state, wall=lambda: 0.0)
    now, x = 0.0, 0.0
    recorder.tick(lambda: {1: Pose(x, 0.0, 0.0)}, now)  # written at once (the first)
    for _ in range(2):  # driving, ticks 0.05 s apart: the file lags
        now, x = now + 0.05, x + 0.1
        recorder.tick(lambda: {1: Pose(x, 0.0, 0.0)}, now)
    assert load_state(state)[1].x == 0.0
    now += 0.05  # stopped: this tick sees it at rest
    recorder.tick(lambda: {1: Pose(x, 0.0, 0.0)}, now)
    assert now < STATE_PERIOD and load_state(state)[1].x == pytest.approx(x)
