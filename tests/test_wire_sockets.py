"""The robot protocol over real ZeroMQ TCP sockets on 127.0.0.1: keys, restarts, reconnects.

A virtual robot (the same RobotEndpoint the ROS runner uses) runs in a background
thread; the manager side is fleet_manager's RobotLink, polled here.
"""
from __future__ import annotations

import logging
import time
from pathlib import Path
from typing import Callable, Iterator, List

import pytest
import zmq

from fleet_common.robots import RobotDefinition
from fleet_common.wire import (Accepted, Completed, Connection, Failed, Hello, PoseFeedback, Role,
                               VersionMismatchError)
from fleet_common.transport.curve_keys import (ManagerKeys, load_manager_keys, load_robot_keys,
                                          make_keys)
from fleet_common.transport.links import LinkSet
from fleet_common.transport.robot_link import LinkDown, LinkEvent, LinkUp, RobotLink, RobotReply
from virtual_fleet.fleet import FleetThread, VirtualFleet
from helpers import free_port_block, free_ports




@pytest.fixture
def keys(tmp_path: Path) -> Path:
    make_keys(tmp_path / "keys")
    return tmp_path / "keys"


@pytest.fixture
def robot() -> RobotDefinition:
    command, _ = free_ports(2)
    return RobotDefinition(7, "127.0.0.1", command, "u", "v7", "red")


@pytest.fixture
def fleet(robot: RobotDefinition, keys: Path) -> Iterator[VirtualFleet]:
    feedback = free_port_block(1)
    with FleetThread(VirtualFleet([robot], keys=load_robot_keys(keys), feedback_base=feedback,
                                  time_scale=4.0)) as running:
        yield running


@pytest.fixture
def context() -> Iterator[zmq.Context]:
    ctx = zmq.Context()
    yield ctx
    ctx.destroy(linger=0)


def collect(links: LinkSet, until: Callable[[List[LinkEvent]], bool], timeout: float = 8.0,
            act: Callable[[List[LinkEvent]], None] = lambda events: None) -> List[LinkEvent]:
    events: List[LinkEvent] = []
    deadline = time.monotonic() + timeout
    while not until(events):
        if time.monotonic() > deadline:
            raise AssertionError("timed out; events so far: {}".format(
                [e for e in events if not isinstance(e, PoseFeedback)]))
        events += links.poll(0.05)
        act(events)
    return events


def replies(events: List[LinkEvent]) -> list:
    return [e.reply for e in events if isinstance(e, RobotReply)]


def test_the_manager_key_drives_the_robot_and_hears_its_pose(fleet, robot, keys, context) -> None:
    links = LinkSet([RobotLink(context, robot, "epoch", keys=load_manager_keys(keys))])
    cid = links[7].drive_to_position(1.0, 1.0, 0.0)
    events = collect(links, lambda ev: Completed(cid) in replies(ev)
                     and any(isinstance(e, PoseFeedback) for e in ev))
    assert replies(events)[:2] == [Accepted(cid), Completed(cid)]
    assert any(isinstance(e, LinkUp) and not e.restarted for e in events)
    last = [e for e in events if isinstance(e, PoseFeedback)][-1]
    assert last.robot_id == 7
    links.close()
    assert fleet.endpoints[7].executor.executed == 1


def test_a_client_with_another_key_gets_nothing_executed(fleet, robot, keys, tmp_path, context,
                                                         caplog) -> None:
    caplog.set_level(logging.WARNING)
    make_keys(tmp_path / "intruder")
    intruder = load_manager_keys(tmp_path / "intruder")
    # it knows the robots' public key, but has its own key pair, not the lab manager's
    stolen = ManagerKeys(intruder.public, intruder.secret, load_manager_keys(keys).robot_public)
    links = LinkSet([RobotLink(context, robot, "evil", keys=stolen)])
    links[7].drive_to_position(1.0, 0.0, 0.0)
    links[7].stop()
    events: List[LinkEvent] = []
    deadline = time.monotonic() + 1.5
    while time.monotonic() < deadline:
        events += links.poll(0.05)
    links.close()
    assert [e for e in events if not isinstance(e, LinkDown)] == []
    assert links[7].state != "up"
    assert fleet.endpoints[7].executor.executed == 0
    assert fleet.zap.refused >= 1
    refused = [r.getMessage() for r in caplog.records if "refused a connection" in r.getMessage()]
    assert refused and "robot 7: refused a connection from 127.0.0.1 with key {}".format(
        intruder.public.decode()) in refused[0]
    # and without any CURVE key at all, nothing either
    plain = context.socket(zmq.DEALER)
    plain.linger = 0
    plain.connect("tcp://127.0.0.1:{}".format(robot.command_port))
    conn = Connection(Role.MANAGER, 7)
    plain.send(conn.send(Hello(7, "plain")))
    assert plain.poll(500) == 0
    assert fleet.endpoints[7].executor.executed == 0


def test_the_link_comes_back_by_itself_after_the_robot_restarts(fleet, robot, keys, context) -> None:
    links = LinkSet([RobotLink(context, robot, "epoch", keys=load_manager_keys(keys))])
    long_drive = links[7].drive_to_position(1.0, 0.0, 30.0)
    collect(links, lambda ev: Accepted(long_drive) in replies(ev))
    old_session, old_stream = links[7].session, links[7].feedback
    fleet.call_soon(lambda: fleet.drop_out(7, 0.5))  # a power cut, back 0.5 s later
    events = collect(links, lambda ev: any(isinstance(e, LinkUp) for e in ev))
    up = [e for e in events if isinstance(e, LinkUp)][0]
    assert up.restarted and up.session != old_session
    # its poses are read afresh: none the old process left on the way is taken for the new one's
    assert links[7].feedback is not None and links[7].feedback is not old_stream
    # the drive's fate is unknown: reported failed, not silently lost or resent
    [failed] = [r for r in replies(events) if isinstance(r, Failed)]
    assert failed.id == long_drive and "restarted" in failed.reason
    after = links[7].turn(1.0)
    events = collect(links, lambda ev: Completed(after) in replies(ev))
    assert replies(events) == [Accepted(after), Completed(after)]
    links.close()


def test_a_command_resent_after_a_reconnect_runs_once(fleet, robot, keys, context) -> None:
    links = LinkSet([RobotLink(context, robot, "epoch", keys=load_manager_keys(keys))])
    cid = links[7].drive_to_position(1.0, 0.0, 2.0)  # 0.5 s at time x4
    collect(links, lambda ev: Accepted(cid) in replies(ev))
    links[7].reconnect("test: connection lost")
    events = collect(links, lambda ev: Completed(cid) in replies(ev))
    assert [e for e in events if isinstance(e, LinkUp)] == [
        LinkUp(7, links[7].session, restarted=False)]
    assert replies(events) == [Accepted(cid, duplicate=True), Completed(cid)]
    assert fleet.endpoints[7].executor.executed == 1
    links.close()


def test_a_manager_of_another_protocol_version_is_told_why(fleet, robot, keys, context,
                                                           caplog) -> None:
    caplog.set_level(logging.ERROR)
    mk = load_manager_keys(keys)
    sock = context.socket(zmq.DEALER)
    sock.linger = 0
    sock.curve_secretkey, sock.curve_publickey, sock.curve_serverkey = mk.secret, mk.public, mk.robot_public
    sock.connect("tcp://127.0.0.1:{}".format(robot.command_port))
    newer = Connection(Role.MANAGER, 7, version=3)
    sock.send(newer.send(Hello(7, "epoch", version=3)))
    assert sock.poll(5000)
    with pytest.raises(VersionMismatchError) as err:
        newer.receive(sock.recv())
    text = "the manager speaks version 3, robot 7 speaks version 2"
    assert text in str(err.value)
    assert any(text in r.getMessage() for r in caplog.records)  # the robot's log says it too


def test_a_link_to_the_wrong_robot_gives_up_and_says_why(fleet, robot, keys, context) -> None:
    # robot 8's link pointed at robot 7's port: the definitions disagree; retrying cannot help
    wrong = RobotDefinition(8, "127.0.0.1", robot.command_port, "u", "v8", "red")
    links = LinkSet([RobotLink(context, wrong, "epoch", keys=load_manager_keys(keys))])
    links[8].turn(1.0)
    events = collect(links, lambda ev: any(isinstance(e, LinkDown) for e in ev))
    [down] = [e for e in events if isinstance(e, LinkDown)]
    assert down.fatal and links[8].state == "failed"
    assert "hello names robot 8, but this connection is to robot 7" in down.reason
    assert fleet.endpoints[7].executor.executed == 0
    links.close()
