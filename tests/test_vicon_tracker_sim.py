"""The simulated Tracker and its truth sources, read back by the real decoder."""
from __future__ import annotations

import json
import math
import statistics
import time
from typing import Dict, List

import pytest
import zmq
from hypothesis import given
from hypothesis import strategies as st

from fleet_common.lab import lab_transforms
from fleet_common.transport.truth_stream import TruthPublisher, TruthSubscriber, decode_truth
from fleet_common.vicon import ViconStream
from fleet_common.vicon.base_grid import to_base, vicon_to_base
from fleet_common.wire.messages import Pose
from helpers import free_port
from virtual_fleet.truth_sources import CircleTruth
from virtual_fleet.vicon_tracker import Occlusion, TrackerSettings, TrackerSimulator

TO_BASE = vicon_to_base(lab_transforms())
TRUTH = {"turtlebot{}".format(i): Pose(1.0 + i, 2.0 + 0.5 * i, 0.3 * i) for i in range(1, 31)}


def simulator(**settings: object) -> TrackerSimulator:
    return TrackerSimulator(TrackerSettings(**settings), TO_BASE.inverse(), seed=4)


def read_back(stream: ViconStream, packets: List[bytes]) -> Dict[str, Pose]:
    return {s.obj.name: to_base(TO_BASE, s.obj) for p in packets for s in stream.receive(p, 0.0)}


@pytest.mark.parametrize("block", [256, 512, 1024])
def test_thirty_robots_come_back_where_they_are(block: int) -> None:
    sim = simulator(block_size=block)
    stream = ViconStream()
    for number in range(1, 4):
        packets = sim.frame(TRUTH, elapsed=number / 100)
        assert len(packets) == math.ceil(30 / ((block - 5) // 75))
        seen = read_back(stream, packets)
        assert set(seen) == set(TRUTH) and stream.sightings["turtlebot1"].frame == number
        for name, pose in seen.items():
            assert (pose.x, pose.y) == pytest.approx((TRUTH[name].x, TRUTH[name].y), abs=1e-9)
            assert math.cos(pose.theta - TRUTH[name].theta) == pytest.approx(1.0)
    assert stream.counters.frames_lost == 0 and stream.counters.rejected == {}


def test_noise_has_the_set_spread() -> None:
    sim = simulator(noise_mm=5.0)
    stream = ViconStream()
    errors = []
    for i in range(40):
        seen = read_back(stream, sim.frame(TRUTH, i / 100))
        errors += [(seen[n].x - TRUTH[n].x) * 700.0 for n in TRUTH]
    assert statistics.pstdev(errors) == pytest.approx(5.0, rel=0.1)


def test_lost_packets_show_as_lost_frames() -> None:
    sim = simulator(loss=0.2, block_size=1024)
    stream = ViconStream()
    for i in range(1000):
        for p in sim.frame({"a": Pose(1, 1, 0)}, i / 100):
            stream.receive(p, 0.0)
    assert sim.counters.lost == pytest.approx(200, abs=40)
    # one packet a frame: every lost packet is a lost frame, except after the last one seen
    assert stream.counters.frames_lost == sim.counters.lost - (1000 - stream.sightings["a"].frame)


def test_an_occluded_robot_is_missing_only_during_its_window() -> None:
    sim = simulator(occlusions=(Occlusion("turtlebot2", 1.0, 2.0),))
    stream = ViconStream()
    assert "turtlebot2" in read_back(stream, sim.frame(TRUTH, 0.99))
    assert "turtlebot2" not in read_back(stream, sim.frame(TRUTH, 1.0))
    assert "turtlebot2" in read_back(stream, sim.frame(TRUTH, 2.0))
    assert sim.counters.hidden == {"turtlebot2": 1}


def test_zeros_for_an_occluded_robot_never_reach_the_reader() -> None:
    sim = simulator(occlusions=(Occlusion("turtlebot2"),), zero_when_occluded=True)
    stream = ViconStream()
    seen = read_back(stream, sim.frame(TRUTH, 0.0))
    assert "turtlebot2" not in seen and len(seen) == 29
    assert stream.counters.dropped == {"zero": 1}


def test_settings_keep_to_what_tracker_can_do() -> None:
    for bad in ({"rate": 150.0}, {"rate": 0.0}, {"block_size": 300}, {"loss": 1.0},
                {"noise_mm": -1.0}):
        with pytest.raises(ValueError):
            TrackerSettings(**bad)


def test_circle_demo_keeps_robots_on_the_circle_facing_along_it() -> None:
    source = CircleTruth(["a", "b", "c"], centre=(6.0, 6.5), radius=4.0, clock=lambda: 0.0)
    for now in (0.0, 7.5, 12.0):
        for pose in source.poses(now).values():
            dx, dy = pose.x - 6.0, pose.y - 6.5
            assert math.hypot(dx, dy) == pytest.approx(4.0)
            assert dx * math.cos(pose.theta) + dy * math.sin(pose.theta) == pytest.approx(0.0, abs=1e-9)


# ---- the virtual fleet's truth stream -----------------------------------------------------

@given(st.binary(max_size=200) | st.dictionaries(
    st.sampled_from(["t", "robot_id", "time", "x", "y", "theta", "z"]),
    st.none() | st.booleans() | st.integers() | st.floats() | st.text(max_size=5)).map(
        lambda d: json.dumps(d).encode()))
def test_any_truth_frame_decodes_or_is_refused(data: bytes) -> None:
    frame = decode_truth(data)
    if frame is not None:
        assert all(math.isfinite(frame[k]) for k in ("time", "x", "y", "theta"))


def test_truth_subscriber_reads_the_fleet_s_truth_by_vicon_name() -> None:
    port = free_port()
    context = zmq.Context()
    pub = TruthPublisher(context, port)
    sub = TruthSubscriber(context, port, {1: "turtlebot1", 2: "turtlebot2"}, max_age=1.0)
    try:
        poses: Dict[str, Pose] = {}
        deadline = time.monotonic() + 5.0
        while "turtlebot2" not in poses and time.monotonic() < deadline:  # the slow joiner
            pub.publish(2, time.time(), 3.0, 4.0, 0.5)
            time.sleep(0.02)
            poses = sub.poses(now=10.0)
        pub.publish(1, time.time(), 1.0, 2.0, 0.0)
        pub.socket.send(b"not json")
        pub.publish(9, time.time(), 0.0, 0.0, 0.0)
        deadline = time.monotonic() + 5.0
        while sub.bad.get("robot", 0) < 1 and time.monotonic() < deadline:
            time.sleep(0.02)
            poses = sub.poses(now=10.5)
        assert poses == {"turtlebot1": Pose(1.0, 2.0, 0.0), "turtlebot2": Pose(3.0, 4.0, 0.5)}
        assert sub.bad == {"frame": 1, "robot": 1}
        # a robot not heard of for max_age is left out: 2 falls silent, 1 goes on
        frames = sub.frames
        pub.publish(1, time.time(), 1.5, 2.0, 0.0)
        deadline = time.monotonic() + 5.0
        while sub.frames == frames and time.monotonic() < deadline:
            time.sleep(0.02)
            poses = sub.poses(now=11.6)
        assert poses == {"turtlebot1": Pose(1.5, 2.0, 0.0)}
    finally:
        sub.close()
        pub.close()
        context.term()


def test_truth_subscriber_reads_a_fleet_served_by_two_processes() -> None:
    """`virtual-fleet --robots` splits a fleet over processes, each publishing its own truth: one
    simulated Tracker (`vicon simulate --truth-port A --truth-port B`) sees every robot."""
    ports = free_port(), free_port()
    context = zmq.Context()
    pubs = [TruthPublisher(context, port) for port in ports]
    sub = TruthSubscriber(context, ports, {1: "turtlebot1", 2: "turtlebot2"}, max_age=1.0)
    try:
        poses: Dict[str, Pose] = {}
        deadline = time.monotonic() + 5.0
        while len(poses) < 2 and time.monotonic() < deadline:  # (each publisher its slow joiner)
            pubs[0].publish(1, time.time(), 1.0, 2.0, 0.0)
            pubs[1].publish(2, time.time(), 3.0, 4.0, 0.5)
            time.sleep(0.02)
            poses = sub.poses(now=10.0)
        assert poses == {"turtlebot1": Pose(1.0, 2.0, 0.0), "turtlebot2": Pose(3.0, 4.0, 0.5)}
    finally:
        sub.close()
        for pub in pubs:
            pub.close()
        context.term()
