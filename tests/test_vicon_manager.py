"""Vicon in the manager, end to end on 127.0.0.1, every part a real process:

    truth PUB -> fleetctl vicon simulate (20 % loss, robot 4 occluded after 2 s) -> UDP ->
    fleetctl manager --vicon <- fleetctl virtual-fleet (the robots' own poses)
                     -> console channel -> this test, as a console

The truth comes from a stand-in publisher speaking the virtual fleet's truth frames
(fleet_common.transport.truth_feed) at the robots' start cells, where the virtual robots
stand; robot 2's truth runs away after 1 s, so its own pose (standing still) and Vicon's
disagree, as for a robot whose localization is lost.
"""
from __future__ import annotations

import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import Dict, List

import pytest
import zmq

from fleet_common.control import messages as m
from fleet_common.control.session import ConsoleSession
from fleet_common.lab import lab_instance_path
from fleet_common.robots import parse_robot_definitions
from fleet_common.transport.console_channel import ConsoleClient
from fleet_common.transport.truth_feed import encode_truth
from fleet_common.wire.messages import Pose
from helpers import free_ports
from fleetctl.options import start_poses

DRIFT = 1.0  # cells/s, robot 2's truth after 1 s


class StandInTruth(threading.Thread):
    def __init__(self, port: int, poses: Dict[int, Pose]) -> None:
        super().__init__(daemon=True)
        self.port, self.poses = port, poses
        self.stop = threading.Event()

    def run(self) -> None:
        context = zmq.Context()
        pub = context.socket(zmq.PUB)
        pub.linger = 0
        pub.bind("tcp://127.0.0.1:{}".format(self.port))
        t0 = time.monotonic()
        try:
            while not self.stop.wait(0.02):
                t = time.monotonic() - t0
                for rid, p in self.poses.items():
                    y = p.y + (DRIFT * max(0.0, t - 1.0) if rid == 2 else 0.0)
                    pub.send(encode_truth(rid, Pose(p.x, y, p.theta), time.time()))
        finally:
            pub.close()
            context.term()


def spawn(*args: object) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", "fleetctl", *map(str, args)],
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)


@pytest.mark.slow
def test_manager_reads_vicon_flags_stale_robots_and_a_lost_one(tmp_path: Path) -> None:
    ports = free_ports(9)
    command, (feedback, truth_port, udp, console) = ports[:5], ports[5:]
    defs = tmp_path / "robots.txt"
    defs.write_text("".join("{0} 127.0.0.1 {1} u turtlebot{0} red\n".format(i + 1, p)
                            for i, p in enumerate(command)))
    robots = parse_robot_definitions(defs.read_text())
    truth = StandInTruth(truth_port, start_poses(None, robots))
    truth.start()
    endpoint = "tcp://127.0.0.1:{}".format(console)
    procs = [
        spawn("virtual-fleet", "--definitions", defs, "--no-curve", "--feedback-base", feedback,
              "--log-level", "warning"),
        spawn("vicon", "simulate", "--truth-port", truth_port, "--port", udp, "--loss", "0.2",
              "--occlude", "4:2-1000", "--definitions", defs, "--for", "120"),
        spawn("manager", lab_instance_path(), "--definitions", defs, "--no-curve", "--no-log",
              "--bind", endpoint, "--vicon", udp, "--vicon-bind", "127.0.0.1",
              "--state-rate", "50"),
    ]
    context = zmq.Context()
    client = ConsoleClient(context, endpoint)
    session = ConsoleSession("vicon-test", time.monotonic())
    events: List[m.Event] = []
    state = None
    asked = False
    answers = []
    deadline = time.monotonic() + 60.0
    try:
        while time.monotonic() < deadline:
            now = time.monotonic()
            if not session.connected and session.live.heartbeat_due(now):
                client.send(session.hello(now))
            for frame in client.receive():
                message = session.receive(frame, time.monotonic())
                if isinstance(message, m.Event):
                    events.append(message)
                elif isinstance(message, tuple):
                    answers.append(message[0])
            beat = session.heartbeat(now)
            if beat is not None:
                client.send(beat)
            state = session.state
            if state is not None and not asked:
                client.send(session.request("source", now, source="vicon")[1])
                asked = True
            if state is not None and _settled(state, events):
                break
            time.sleep(0.02)
    finally:
        client.close()
        context.term()
        for proc in procs:
            proc.terminate()
        outputs = [proc.communicate(timeout=20)[0] for proc in procs]
        truth.stop.set()
        truth.join(timeout=10)
    assert state is not None, outputs
    assert [a.ok for a in answers] == [True], answers
    robots_now = {r.id: r for r in state.robots}
    # Vicon is every robot's source; the visible ones are fresh, on their cells
    assert all(r.source == "vicon" for r in state.robots)
    for rid in (1, 3, 5):
        r = robots_now[rid]
        assert not r.stale and r.vicon_age is not None and r.vicon_age < 1.0
        assert not r.disagree
    # robot 4, occluded after 2 s, is flagged stale; robot 2 is reported lost
    assert robots_now[4].stale and robots_now[4].vicon_age > 1.0
    assert robots_now[2].disagree
    texts = [(e.kind, e.robot, e.text) for e in events if e.kind == "vicon"]
    assert any(robot == 2 and "disagree" in text for _, robot, text in texts), texts
    assert any(robot == 4 and "does not see it" in text for _, robot, text in texts), texts
    assert not any(robot in (1, 3, 5) for _, robot, _ in texts), texts
    assert "Vicon on UDP 127.0.0.1:{}".format(udp) in outputs[2]


def _settled(state: m.State, events: List[m.Event]) -> bool:
    robots = {r.id: r for r in state.robots}
    return (all(r.source == "vicon" for r in state.robots)
            and all(not robots[i].stale for i in (1, 3, 5)) and robots[4].stale
            and robots[2].disagree
            and any(e.kind == "vicon" and e.robot == 4 for e in events))
