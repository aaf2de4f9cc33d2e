"""Vicon end to end on 127.0.0.1: a fleet's truth socket -> `fleetctl vicon simulate` (20 %
packet loss, one robot occluded) -> UDP -> the manager's ViconProvider, polled as the manager
polls it, and the disagreement detector fed with a robot whose reported pose drifts.

The fleet here is a stand-in publishing the virtual fleet's truth stream
(fleet_common.transport.truth_stream) along a scripted path, so that each pose
can be checked; tests/test_vicon_manager.py runs the real fleet and manager.
"""
from __future__ import annotations

import subprocess
import sys
import threading
import time
from typing import Dict, List, Set

import pytest
import zmq

from fleet_common.lab import lab_transforms
from fleet_common.robots import read_robot_definitions
from fleet_common.transport.truth_stream import TruthPublisher
from fleet_common.vicon.base_grid import vicon_to_base
from fleet_common.wire.messages import Pose
from fleet_manager.pose_disagreement import DisagreementDetector, DisagreementEvent
from fleet_manager.vicon_provider import ViconProvider
from helpers import free_port

SPEED = 0.3  # cells/s, along x
DRIFT = 1.0  # cells/s: how fast robot 2's own pose runs away from the truth
OCCLUDED_FROM = 1.0  # s after the simulator starts, robot 4 is hidden


def true_pose(robot_id: int, t: float) -> Pose:
    return Pose(1.0 + SPEED * t, 1.0 + 2.0 * robot_id, 0.0)


def reported_pose(robot_id: int, t: float) -> Pose:
    """What the robot says: the truth, except robot 2, which is lost after 1 s."""
    truth = true_pose(robot_id, t)
    drift = DRIFT * max(0.0, t - 1.0) if robot_id == 2 else 0.0
    return Pose(truth.x, truth.y + drift, truth.theta)


class StandInFleet(threading.Thread):
    """Publishes each robot's true pose at 50 Hz, as `fleetctl virtual-fleet --truth-port`."""

    def __init__(self, port: int, ids: List[int]) -> None:
        super().__init__(daemon=True)
        self.port, self.ids = port, ids
        self.stop = threading.Event()
        self.t0 = time.monotonic()

    def run(self) -> None:
        context = zmq.Context()
        pub = TruthPublisher(context, self.port)
        try:
            while not self.stop.wait(0.02):
                t = time.monotonic() - self.t0
                for rid in self.ids:
                    p = true_pose(rid, t)
                    pub.publish(rid, time.time(), p.x, p.y, p.theta)
        finally:
            pub.close()
            context.term()


@pytest.mark.slow
def test_vicon_path_end_to_end_with_loss_occlusion_and_a_lost_robot() -> None:
    robots = read_robot_definitions()
    ids = [r.id for r in robots]
    truth_port, udp_port = free_port(), free_port()
    provider = ViconProvider(robots, vicon_to_base(lab_transforms()), port=udp_port,
                             bind="127.0.0.1", stale_after=0.3)
    fleet = StandInFleet(truth_port, ids)
    fleet.start()
    sim = subprocess.Popen(
        [sys.executable, "-m", "fleetctl", "vicon", "simulate", "--truth-port", str(truth_port),
         "--port", str(udp_port), "--loss", "0.2", "--noise", "1", "--occlude",
         "4:{}-1000".format(OCCLUDED_FROM), "--for", "60"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    detector = DisagreementDetector(threshold=0.5, hold=0.2)
    events: List[DisagreementEvent] = []
    frames: Dict[int, Set[int]] = {rid: set() for rid in ids}
    worst_error = 0.0
    seen_fresh_4 = False
    poller = zmq.Poller()
    poller.register(provider, zmq.POLLIN)
    deadline = time.monotonic() + 20.0
    try:
        while time.monotonic() < deadline:
            if poller.poll(50):
                now = time.monotonic()
                t = now - fleet.t0
                for fix in provider.handle_readable(now):
                    frames[fix.robot_id].add(fix.frame)
                    truth = true_pose(fix.robot_id, t)
                    # on its row, and never ahead of where the robot is now (it lags a little)
                    worst_error = max(worst_error, abs(fix.pose.y - truth.y),
                                      fix.pose.x - truth.x)
                    seen_fresh_4 |= fix.robot_id == 4
                    event = detector.update(fix.robot_id, reported_pose(fix.robot_id, t), now,
                                            fix.pose, now, now)
                    if event is not None:
                        events.append(event)
            poses = provider.poses()
            others_fresh = all(rid in poses and not poses[rid].stale for rid in ids if rid != 4)
            done = (min(len(frames[r]) for r in ids if r != 4) >= 150 and 4 in poses
                    and poses[4].stale and others_fresh and events)
            if done:
                break
    finally:
        sim.terminate()
        out, err = sim.communicate(timeout=10)
        fleet.stop.set()
        fleet.join(timeout=10)
        provider.close()
    assert "simulated Tracker: 5 robots, the virtual fleet's truth" in out, err
    # positions keep coming for every visible robot despite 20 % loss, where the robots are
    assert all(len(frames[r]) >= 150 for r in ids if r != 4), {r: len(f) for r, f in frames.items()}
    assert worst_error < 0.05
    c = provider.counters
    assert c.frames_lost > 0 and c.rejected == {} and c.dropped == {}
    # the occluded robot was seen, then flagged stale once not seen for the stale time
    assert seen_fresh_4 and poses[4].stale and poses[4].age > 0.3
    assert others_fresh
    # the robot whose own pose drifted is reported, and only it
    assert [(e.robot_id, e.disagree) for e in events] == [(2, True)]
    assert events[0].distance > 0.5
