"""Hostile peers over real sockets: no single frame, peer or failing handler brings a part down.

Robot side: `fleetctl virtual-fleet` as a process; a client holding the manager key (a
buggy or compromised manager: the worst a robot can meet) sends the frames that used to
kill it, then a legitimate manager drives a robot. Manager side: a fake robot (a ROUTER
bound here) welcomes a RobotLink and then sends it the same frames; the link set keeps
polling and the link drives again after it reconnects. And each refusal is in the log,
once, not once per frame.
"""
from __future__ import annotations

import logging
import secrets
import signal
import subprocess
import threading
import time
from pathlib import Path
from typing import Callable, Dict, Iterator, List, Optional

import pytest
import zmq
from zmq.utils.monitor import recv_monitor_message

from fleet_common.robots import RobotDefinition
from fleet_common.transport.curve_keys import load_manager_keys, make_keys
from fleet_common.transport.links import LinkSet
from fleet_common.transport.pose_feedback import NotThisRobotsPose, read_pose
from fleet_common.transport.robot_link import LinkEvent, LinkUp, RobotLink, RobotReply
from fleet_common.wire import (Accepted, Bye, Completed, Connection, DriveToPosition, Failed,
                               Heartbeat, Hello, PoseFeedback, Pose, RemoteProtocolError, Role,
                               Welcome)
from fleet_common.wire.codec import encode
from virtual_fleet.fleet import FleetThread, VirtualFleet
from helpers import fleetctl, free_port_block, free_ports, virtual_fleet_process

REPO = Path(__file__).resolve().parents[1]

BIG_X = b'{"t":"drive","v":2,"id":5,"x":' + b"1" * 400 + b',"y":0,"time":0}'
HOSTILE: Dict[str, bytes] = {
    "a 400-digit x": BIG_X,
    "30,000 nested [": b"[" * 30000,
    "an id beyond int64": b'{"t":"stop","v":2,"id":' + b"9" * 30 + b"}",
    "x = 1e400": b'{"t":"drive","v":2,"id":5,"x":1e400,"y":0,"time":0}',
    "NaN": b'{"t":"turn","v":2,"id":5,"angle":NaN}',
    "not UTF-8": b"\xff\xfe\xfd",
    "an empty frame": b"",
    "a key twice": b'{"t":"stop","v":2,"id":5,"id":6}',
    "a 60 KB reason": b'{"t":"bye","v":2,"reason":"' + b"r" * 60000 + b'","code":"x"}',
    "80 KB, beyond the frame limit": b"[" + b"1," * 40000 + b"1]",
}


def collect(links: LinkSet, until: Callable[[List[LinkEvent]], bool], timeout: float = 10.0,
            also: Callable[[], None] = lambda: None) -> List[LinkEvent]:
    events: List[LinkEvent] = []
    deadline = time.monotonic() + timeout
    while not until(events):
        assert time.monotonic() < deadline, [e for e in events if not isinstance(e, PoseFeedback)]
        events += links.poll(0.02)
        also()
    return events


def replies(events: List[LinkEvent]) -> list:
    return [e.reply for e in events if isinstance(e, RobotReply)]


# ---- the robot side: a virtual fleet process -----------------------------------------------

@pytest.fixture
def fleet_process(tmp_path: Path) -> Iterator[tuple]:
    command, feedback = free_ports(2)
    robot = RobotDefinition(1, "127.0.0.1", command, "u", "v1", "red")
    (tmp_path / "robots.txt").write_text("1 127.0.0.1 {} u v1 red\n".format(command))
    make_keys(tmp_path / "keys")
    with virtual_fleet_process(tmp_path / "robots.txt", tmp_path / "keys", feedback, "info") as proc:
        assert proc.stdout.readline().startswith("virtual fleet: 1 robots")
        yield proc, robot, tmp_path / "keys"


def stop(proc: subprocess.Popen) -> str:
    """Ctrl-C the fleet; its log."""
    proc.send_signal(signal.SIGINT)
    assert proc.wait(timeout=10) == 0
    return proc.stderr.read()


def hostile_client(context: zmq.Context, robot: RobotDefinition, keys: Path,
                   hello: bool) -> zmq.Socket:
    mk = load_manager_keys(keys)
    sock = context.socket(zmq.DEALER)
    sock.linger = 0
    sock.curve_secretkey, sock.curve_publickey, sock.curve_serverkey = (
        mk.secret, mk.public, mk.robot_public)
    sock.connect("tcp://127.0.0.1:{}".format(robot.command_port))
    if hello:
        sock.send(Connection(Role.MANAGER, robot.id).send(Hello(robot.id, "evil")))
        assert sock.poll(5000), "no welcome"
        sock.recv()
    return sock


def the_manager_still_drives(context: zmq.Context, robot: RobotDefinition, keys: Path) -> None:
    links = LinkSet([RobotLink(context, robot, secrets.token_hex(4),
                               keys=load_manager_keys(keys))])
    try:
        cid = links[robot.id].turn(0.5)
        events = collect(links, lambda ev: Completed(cid) in replies(ev))
        assert replies(events) == [Accepted(cid), Completed(cid)]
    finally:
        links.close()


def test_no_frame_kills_the_virtual_fleet_and_the_manager_drives_right_after(fleet_process) -> None:
    proc, robot, keys = fleet_process
    context = zmq.Context()
    try:
        for name, frame in HOSTILE.items():
            for hello in (False, True):
                sock = hostile_client(context, robot, keys, hello)
                sock.send(frame)
                sock.poll(300)  # a bye, or nothing (libzmq drops a peer sending 80 KB)
                sock.close()
                assert proc.poll() is None, "the fleet died of {} (hello: {})".format(name, hello)
            the_manager_still_drives(context, robot, keys)
    finally:
        context.destroy(linger=0)
    log = stop(proc)
    assert "Traceback" not in log
    assert "refused a frame from 127.0.0.1: number of 400 characters" in log


def test_a_flood_of_bad_frames_is_a_few_log_lines(fleet_process) -> None:
    proc, robot, keys = fleet_process
    context = zmq.Context()
    try:
        sock = hostile_client(context, robot, keys, hello=False)
        for _ in range(3000):
            sock.send(BIG_X)
        the_manager_still_drives(context, robot, keys)  # the flood is behind us: all were read
    finally:
        context.destroy(linger=0)
    log = stop(proc).splitlines()
    assert len(log) < 15, log
    assert sum("refused a frame from 127.0.0.1" in line for line in log) == 1


def test_commands_off_the_world_are_refused_and_the_robot_stays_free(fleet_process) -> None:
    proc, robot, keys = fleet_process
    context = zmq.Context()
    links = LinkSet([RobotLink(context, robot, "lab", keys=load_manager_keys(keys))])
    try:
        link = links[robot.id]
        refused = {link.drive_to_position(1e6, 1e6, 0.0): "is off the 13x14 map",
                   link.drive_to_position(-5.0, -5.0, 0.0): "is off the 13x14 map",
                   link.drive_to_position(1.0, 7.0, 1e300): "time 1e+300 s is beyond",
                   link.drive_to_position(3.0, 8.0, 0.0): "one drive goes at most 1.5",
                   link.turn(1e300): "beyond one revolution"}
        ok = link.drive_to_position(1.0, 7.0, 0.0)  # robot 1 starts at (1, 8) in the lab
        events = collect(links, lambda ev: Completed(ok) in replies(ev))
        got = {r.id: r for r in replies(events)}
        for cid, reason in refused.items():
            assert isinstance(got[cid], Failed) and reason in got[cid].reason, got[cid]
        assert [r for r in replies(events) if r.id == ok] == [Accepted(ok), Completed(ok)]
    finally:
        links.close()
        context.destroy(linger=0)
    assert proc.poll() is None
    stop(proc)


class LogLines:
    """A process's stderr read line by line as it comes (a thread), to wait for a line in it."""

    def __init__(self, proc: subprocess.Popen) -> None:
        self.lines: List[str] = []
        self._reader = threading.Thread(target=lambda: self.lines.extend(proc.stderr), daemon=True)
        self._reader.start()

    def wait_for(self, test: Callable[[str], bool], what: str, timeout: float = 10.0) -> None:
        deadline = time.monotonic() + timeout
        while not any(test(line) for line in list(self.lines)):
            assert time.monotonic() < deadline, "no log line {} within {:.0f} s".format(what, timeout)
            time.sleep(0.02)

    def text(self) -> str:
        """Everything, once the process has ended."""
        self._reader.join(10)
        return "".join(self.lines)


def test_clients_without_the_keys_are_logged(fleet_process) -> None:
    proc, robot, keys = fleet_process
    log_lines = LogLines(proc)
    on_port = "on tcp://127.0.0.1:{}; nothing from it is executed".format(robot.command_port)
    # which end notices the missing key first is a race: libzmq reports either
    plain_refused = ["robot 1: refused a client {} {}".format(why, on_port) for why in (
        "without a CURVE key", "that broke off the CURVE handshake (as one without a key does)")]
    context = zmq.Context()
    try:
        plain = context.socket(zmq.DEALER)  # no CURVE at all
        plain.linger = 0
        plain.connect("tcp://127.0.0.1:{}".format(robot.command_port))
        plain.send(b"hello?")
        stranger = context.socket(zmq.DEALER)  # CURVE, but not this robot's public key
        stranger.linger = 0
        public, secret = zmq.curve_keypair()
        stranger.curve_secretkey, stranger.curve_publickey = secret, public
        stranger.curve_serverkey = zmq.curve_keypair()[0]
        attempts = stranger.get_monitor_socket(zmq.EVENT_CONNECTED)
        stranger.connect("tcp://127.0.0.1:{}".format(robot.command_port))
        stranger.send(b"hello?")
        # the stranger is refused and reconnects (libzmq's own retry): let it try a few times
        for _ in range(5):
            assert attempts.poll(5000), "the stranger stopped reconnecting"
            recv_monitor_message(attempts)
        log_lines.wait_for(lambda line: any(r in line for r in plain_refused), "refusing the client without a key")
        log_lines.wait_for(lambda line: "refused a client that does not have this robot's public key" in line,
                           "refusing the client with another key")
        the_manager_still_drives(context, robot, keys)
    finally:
        context.destroy(linger=0)
    proc.send_signal(signal.SIGINT)
    assert proc.wait(timeout=10) == 0
    log = log_lines.text()
    assert any(r in log for r in plain_refused)
    assert "robot 1: refused a client that does not have this robot's public key" in log
    # the stranger keeps reconnecting: one line, the rest counted later
    assert log.count("does not have this robot's public key") == 1


# ---- failing handlers are logged, not fatal ---------------------------------------------------

def test_a_failing_handler_is_logged_and_the_robot_serves_on(caplog) -> None:
    caplog.set_level(logging.INFO)
    command, feedback = free_ports(2)
    robot = RobotDefinition(1, "127.0.0.1", command, "u", "v1", "red")
    context = zmq.Context()
    fleet = VirtualFleet([robot], feedback_base=feedback, time_scale=10.0)
    with FleetThread(fleet):
        endpoint = fleet.endpoints[1]
        real = endpoint.executor.handle
        calls: List[int] = []

        def fails_once(epoch, command):
            calls.append(command.id)
            if len(calls) == 1:
                raise RuntimeError("deliberate failure in the handler")
            return real(epoch, command)

        endpoint.executor.handle = fails_once
        links = LinkSet([RobotLink(context, robot, "lab")])
        try:
            lost = links[1].turn(1.0)
            collect(links, lambda ev: len(calls) >= 1)
            ok = links[1].turn(0.5)
            events = collect(links, lambda ev: Completed(ok) in replies(ev))
            assert lost not in [r.id for r in replies(events)]
        finally:
            links.close()
            context.destroy(linger=0)
    [failure] = [r for r in caplog.records if "failed on a frame from 127.0.0.1" in r.getMessage()]
    assert failure.levelno == logging.ERROR and "deliberate failure" in str(failure.exc_info[1])


def test_a_failing_link_is_logged_and_the_others_go_on(caplog) -> None:
    caplog.set_level(logging.ERROR)
    ports = free_ports(2)
    robots = [RobotDefinition(i, "127.0.0.1", ports[i - 1], "u", "v{}".format(i), "red")
              for i in (1, 2)]
    feedback = free_port_block(2)
    context = zmq.Context()
    with FleetThread(VirtualFleet(robots, feedback_base=feedback, time_scale=10.0)):
        links = LinkSet([RobotLink(context, r, "lab") for r in robots])
        try:
            collect(links, lambda ev: sum(isinstance(e, LinkUp) for e in ev) == 2)
            broken = links[1]
            broken.tick = lambda now: 1 / 0  # type: ignore[assignment]
            cid = links[2].turn(1.0)
            collect(links, lambda ev: Completed(cid) in replies(ev) and any(
                "link failed" in r.getMessage() for r in caplog.records))
        finally:
            links.close()
            context.destroy(linger=0)
    failures = [r for r in caplog.records if "robot 1: link failed ticking" in r.getMessage()]
    assert failures and isinstance(failures[0].exc_info[1], ZeroDivisionError)


# ---- the manager side: a fake robot sends the hostile frames to a RobotLink -----------------

class FakeRobot:
    """A ROUTER bound on 127.0.0.1 that welcomes the manager, answers heartbeats and drives,
    and sends whatever the test tells it to."""

    def __init__(self, context: zmq.Context, robot_id: int, port: int, feedback: int) -> None:
        self.robot_id = robot_id
        self.router = context.socket(zmq.ROUTER)
        self.router.linger = 0
        self.router.bind("tcp://127.0.0.1:{}".format(port))
        self.pub = context.socket(zmq.PUB)
        self.pub.linger = 0
        self.pub.bind("tcp://127.0.0.1:{}".format(feedback))
        self.feedback = feedback
        self.conns: Dict[bytes, Connection] = {}
        self.current: Optional[bytes] = None

    def serve(self) -> None:
        while True:
            try:
                identity, data = self.router.recv_multipart(zmq.NOBLOCK)
            except zmq.Again:
                return
            conn = self.conns.setdefault(identity, Connection(Role.ROBOT, self.robot_id))
            try:
                message = conn.receive(data)
            except RemoteProtocolError:
                self.router.send_multipart([identity, encode(Bye("say hello", "no-session"))])
                del self.conns[identity]
                continue
            if isinstance(message, Hello):
                self.current = identity
                self.send(Welcome(self.robot_id, "fake", self.feedback))
            elif isinstance(message, Heartbeat):
                self.send(Heartbeat())
            elif isinstance(message, DriveToPosition):
                self.send(Accepted(message.id))
                self.send(Completed(message.id))

    def send(self, message: object) -> None:
        assert self.current is not None
        self.router.send_multipart([self.current, self.conns[self.current].send(message)])

    def send_raw(self, data: bytes) -> None:
        assert self.current is not None
        self.router.send_multipart([self.current, data])


def test_no_frame_from_a_robot_brings_the_manager_side_down(caplog) -> None:
    caplog.set_level(logging.INFO)
    port, feedback = free_ports(2)
    context = zmq.Context()
    fake = FakeRobot(context, 4, port, feedback)
    robot = RobotDefinition(4, "127.0.0.1", port, "u", "v4", "red")
    links = LinkSet([RobotLink(context, robot, "lab", retry=0.05)])
    try:
        collect(links, lambda ev: any(isinstance(e, LinkUp) for e in ev), also=fake.serve)
        for name, frame in HOSTILE.items():
            print("sending", name)
            fake.send_raw(frame)
            fake.pub.send(frame)  # and on the pose feedback stream
            cid = links[4].drive_to_position(1.0, 0.0, 0.0)
            events = collect(links, lambda ev: Completed(cid) in replies(ev), also=fake.serve)
            assert Completed(cid) in replies(events), name
        # pose feedback still gets through after all that
        pose = encode(PoseFeedback(4, 0, Pose(1.0, 0.0, 0.0), None))
        collect(links, lambda ev: any(isinstance(e, PoseFeedback) for e in ev),
                also=lambda: (fake.serve(), fake.pub.send(pose)))
    finally:
        links.close()
        context.destroy(linger=0)
    logged = [r.getMessage() for r in caplog.records]
    assert any("robot 4 broke the protocol: number of 400 characters" in m for m in logged)
    # the feedback stream's complaints: the first logged, the rest held back to be counted
    # (which frames reach a new subscriber first is up to PUB/SUB)
    assert len([m for m in logged if "robot 4: bad pose feedback frame: " in m]) == 1
    assert all(len(m) < 1000 and "\n" not in m for m in logged)



def test_a_feedback_frame_is_read_or_refused_with_who_sent_it() -> None:
    """One reader of pose feedback for the manager's links and `deploy`'s net check: a pose of
    this robot, or a refusal that says whether the frame was garbage, another message or
    another robot's pose (net:check then names a port two robots share)."""
    pose = PoseFeedback(4, 7, Pose(1.0, 2.0, 0.5), None)
    assert read_pose(encode(pose), 4) == pose
    with pytest.raises(NotThisRobotsPose) as other:
        read_pose(encode(PoseFeedback(5, 0, Pose(0.0, 0.0, 0.0), None)), 4)
    assert other.value.sender == 5
    with pytest.raises(NotThisRobotsPose) as status:
        read_pose(encode(Completed(3)), 4)
    assert status.value.sender is None and "feedback port sent Completed(id=3)" in str(status.value)
    for frame in HOSTILE.values():
        with pytest.raises(RemoteProtocolError) as bad:
            read_pose(frame, 4)
        assert not isinstance(bad.value, NotThisRobotsPose)

def test_a_fleet_whose_robots_would_start_off_its_map_is_refused(tmp_path: Path) -> None:
    command = free_ports(1)[0]
    (tmp_path / "robots.txt").write_text("1 127.0.0.1 {} u v1 red\n".format(command))
    tunnel = REPO.parent / "shared" / "data" / "mapf-ir" / "maps" / "tunnel.map"
    proc = fleetctl("virtual-fleet", "--definitions", tmp_path / "robots.txt", "--no-curve",
                    "--map", tunnel, timeout=60)
    assert proc.returncode == 2 and "Traceback" not in proc.stderr
    assert proc.stderr.splitlines() == [
        "fleetctl virtual-fleet: robot 1 would start at (1, 8), which is not a free cell of {}; "
        "give --instance with starts on that map".format(tunnel)]
