"""The per-connection state machine, two ends wired together in memory (no sockets)."""
from __future__ import annotations

import copy
from typing import List, Tuple

import pytest
from hypothesis import given
from hypothesis import strategies as st

from fleet_common.wire import (Accepted, Bye, Completed, Connection, DriveToPosition, Failed,
                               GetStatus, Heartbeat, Hello, LocalProtocolError, Pose,
                               RemoteProtocolError, Role, State, Status, Stop, Turn,
                               VersionMismatchError, Welcome)
from fleet_common.wire.codec import encode

ROBOT = 3


def pair() -> Tuple[Connection, Connection]:
    return Connection(Role.MANAGER, ROBOT), Connection(Role.ROBOT, ROBOT)


def deliver(sender: Connection, receiver: Connection, message: object) -> object:
    return receiver.receive(sender.send(message))


def open_pair() -> Tuple[Connection, Connection]:
    manager, robot = pair()
    deliver(manager, robot, Hello(ROBOT, "epoch-a"))
    deliver(robot, manager, Welcome(ROBOT, "session-1", 9980))
    return manager, robot


def snapshot(conn: Connection) -> dict:
    return copy.deepcopy(vars(conn))


def test_handshake_opens_both_ends_and_tells_each_about_the_other() -> None:
    manager, robot = open_pair()
    assert manager.state is robot.state is State.OPEN
    assert robot.epoch == "epoch-a"
    assert (manager.session, manager.feedback_port) == ("session-1", 9980)


def test_a_command_is_tracked_until_it_settles_on_both_ends() -> None:
    manager, robot = open_pair()
    deliver(manager, robot, DriveToPosition(1, 2.0, 3.0, 1.5))
    assert manager.in_flight == robot.in_flight != {}
    deliver(robot, manager, Accepted(1))
    assert manager.in_flight[1][1].value == "accepted"
    deliver(robot, manager, Completed(1))
    deliver(manager, robot, GetStatus(2))
    deliver(robot, manager, Status(2, Pose(2, 3, 0), None, ()))
    deliver(manager, robot, Turn(3, 1.57))
    deliver(robot, manager, Failed(3, "busy"))  # refused without being accepted
    assert manager.in_flight == robot.in_flight == {}


def test_bye_closes_both_ends_and_nothing_follows() -> None:
    manager, robot = open_pair()
    deliver(robot, manager, Bye("robot shutting down"))
    assert manager.state is robot.state is State.CLOSED
    assert manager.bye == Bye("robot shutting down")
    with pytest.raises(LocalProtocolError, match="while the connection is closed; allowed: nothing"):
        manager.send(Heartbeat())


# (steps to get there, who acts, the illegal message, what the error says)
ILLEGAL = [
    ([], "manager sends", DriveToPosition(1, 0, 0, 0),
     "the manager may not send 'drive' while the connection is start; allowed: bye, hello"),
    ([], "robot receives", Stop(1), "the manager may not send 'stop' while the connection is start"),
    ([], "robot sends", Welcome(ROBOT, "s", 9980), "the robot may not send 'welcome'"),
    (["hello"], "manager sends", Hello(ROBOT, "e"), "may not send 'hello' while the connection is handshake"),
    (["hello"], "manager receives", Accepted(1), "the robot may not send 'accepted' while the connection is handshake"),
    (["hello", "welcome"], "robot sends", Completed(9), "completed for command 9, which is not in flight"),
    (["hello", "welcome", "drive 1"], "manager sends", DriveToPosition(1, 0, 0, 0),
     "command 1 is already in flight on this connection"),
    (["hello", "welcome", "drive 1"], "manager receives", Completed(1),
     "completed for command 1 (drive, sent); expected accepted or failed"),
    (["hello", "welcome", "status 1"], "robot sends", Accepted(1),
     "accepted for command 1 (get_status, sent); expected status"),
    (["hello", "welcome"], "manager receives", Hello(ROBOT, "e"), "the robot may not send 'hello' while the connection is open"),
    (["hello", "welcome", "bye"], "robot receives", Heartbeat(), "while the connection is closed"),
]

SETUP = {
    "hello": ("manager", Hello(ROBOT, "e")),
    "welcome": ("robot", Welcome(ROBOT, "s", 9980)),
    "drive 1": ("manager", DriveToPosition(1, 0.0, 0.0, 0.0)),
    "status 1": ("manager", GetStatus(1)),
    "bye": ("manager", Bye("done")),
}


@pytest.mark.parametrize("steps, how, message, text", ILLEGAL)
def test_an_illegal_message_raises_and_changes_nothing(steps: List[str], how: str,
                                                       message: object, text: str) -> None:
    ends = dict(zip(("manager", "robot"), pair()))
    for step in steps:
        who, m = SETUP[step]
        other = "robot" if who == "manager" else "manager"
        deliver(ends[who], ends[other], m)
    who, verb = how.split()
    conn = ends[who]
    before = snapshot(conn)
    if verb == "sends":
        with pytest.raises(LocalProtocolError) as err:
            conn.send(message)
    else:
        with pytest.raises(RemoteProtocolError) as err:
            conn.receive(encode(message))
    assert text in str(err.value)
    assert snapshot(conn) == before


def test_a_hello_for_another_robot_is_refused_with_a_hint() -> None:
    manager, robot = Connection(Role.MANAGER, 4), Connection(Role.ROBOT, ROBOT)
    with pytest.raises(RemoteProtocolError) as err:
        robot.receive(manager.send(Hello(4, "e")))
    assert err.value.code == "robot-id"
    assert "hello names robot 4, but this connection is to robot 3" in str(err.value)
    assert robot.state is State.START


def test_version_mismatch_is_a_clear_error_on_both_ends() -> None:
    manager = Connection(Role.MANAGER, ROBOT, version=3)
    robot = Connection(Role.ROBOT, ROBOT)
    with pytest.raises(VersionMismatchError) as robot_side:
        robot.receive(manager.send(Hello(ROBOT, "e", version=3)))
    text = "the manager speaks version 3, robot 3 speaks version 2; update the older side"
    assert text in str(robot_side.value)
    assert robot.state is State.START
    # what the transport does with it: a bye, which the older or newer manager can read
    bye = robot.send(Bye(str(robot_side.value), code=robot_side.value.code))
    with pytest.raises(VersionMismatchError) as manager_side:
        manager.receive(bye)
    assert text in str(manager_side.value)
    assert "robot 3 refused the connection" in str(manager_side.value)
    assert manager.state is State.CLOSED


def test_a_manager_refuses_a_welcome_of_another_version() -> None:
    manager = Connection(Role.MANAGER, ROBOT)
    manager.send(Hello(ROBOT, "e"))
    with pytest.raises(VersionMismatchError, match="the manager speaks version 2, robot 3 speaks version 5"):
        manager.receive(encode(Welcome(ROBOT, "s", 9980, version=5), version=5))
    assert manager.state is State.HANDSHAKE


def test_an_end_cannot_send_a_handshake_of_another_version() -> None:
    with pytest.raises(LocalProtocolError, match="this end speaks version 2"):
        Connection(Role.MANAGER, ROBOT).send(Hello(ROBOT, "e", version=1))


# ---- property: both ends always agree ------------------------------------------------

ANY_MESSAGE = st.one_of(
    st.builds(Hello, st.sampled_from([ROBOT, 4]), st.just("e")),
    st.builds(Welcome, st.sampled_from([ROBOT, 4]), st.just("s"), st.just(9980)),
    st.just(Heartbeat()), st.just(Bye("x")),
    st.builds(DriveToPosition, st.integers(0, 3), st.just(1.0), st.just(2.0), st.just(0.0)),
    st.builds(Turn, st.integers(0, 3), st.just(0.5)),
    st.builds(Stop, st.integers(0, 3)), st.builds(GetStatus, st.integers(0, 3)),
    st.builds(Accepted, st.integers(0, 3)), st.builds(Completed, st.integers(0, 3)),
    st.builds(Failed, st.integers(0, 3), st.just("r")),
    st.builds(Status, st.integers(0, 3), st.just(Pose(0, 0, 0)), st.none(), st.just(())),
)


@given(st.lists(st.tuples(st.sampled_from(["manager", "robot"]), ANY_MESSAGE), max_size=30))
def test_a_message_is_received_exactly_when_its_sender_may_send_it(script: list) -> None:
    manager, robot = pair()
    for who, message in script:
        sender, receiver = (manager, robot) if who == "manager" else (robot, manager)
        before = (snapshot(sender), snapshot(receiver))
        may_send = sender.can_send(message)
        try:
            receiver.receive(encode(message))
        except RemoteProtocolError:
            assert not may_send
            assert snapshot(receiver) == before[1]
            with pytest.raises(LocalProtocolError):
                sender.send(message)
            assert snapshot(sender) == before[0]
            continue
        assert may_send
        sender.send(message)
        # both ends hold the same view of the connection
        assert sender.state is receiver.state
        assert sender.in_flight == receiver.in_flight


def test_no_module_of_the_protocol_imports_a_socket_library() -> None:
    """fleet_common.wire is sans-I/O: every one of its modules, not only the package."""
    import subprocess
    import sys

    code = ("import importlib, pkgutil, sys, fleet_common.wire as w\n"
            "for m in pkgutil.iter_modules(w.__path__): importlib.import_module(w.__name__ + '.' + m.name)\n"
            "print(sorted(m for m in ('zmq', 'rospy') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "[]"
