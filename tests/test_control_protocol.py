"""The console protocol without sockets: a desk (the manager's end) and sessions (consoles) in memory."""
from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from fleet_common.control import (Activity, Answer, ControlProtocolError, Notice, PlanData, RobotState,
                                  RunInfo, RunSetup, State, Waiting, decode, encode)
from fleet_common.control import messages as m
from fleet_common.control.desk import ControlDesk
from fleet_common.control.requests import ACTIONS, check_args
from fleet_common.control.session import ConsoleSession
from fleet_common.schema import SchemaError


def wire(desk: ControlDesk, session: ConsoleSession, peer: bytes, frame: bytes, now: float = 0.0):
    """One console frame through the desk; the desk's replies fed back to that console."""
    intake = desk.receive(peer, frame, now)
    got = [session.receive(data, now) for who, data in intake.out if who == peer]
    return intake, got


def joined(desk: ControlDesk, name: str, peer: bytes) -> ConsoleSession:
    session = ConsoleSession(name, 0.0)
    intake, got = wire(desk, session, peer, session.hello(0.0))
    assert intake.joined == peer and isinstance(got[0], m.Welcome)
    return session


def test_a_request_on_the_current_version_goes_ahead() -> None:
    desk = ControlDesk("s1", 0.0)
    console = joined(desk, "ops", b"A")
    request, frame = console.request("disable", 0.0, robot=3)
    intake, _ = wire(desk, console, b"A", frame)
    assert intake.request == request and intake.args == {"robot": 3}
    answer, asked = console.receive(desk.answer(b"A", request, True)[0][1], 0.0)
    assert answer.ok and asked == request and not console.pending


def test_a_request_on_an_outdated_picture_is_refused_saying_what_changed() -> None:
    desk = ControlDesk("s1", 0.0)
    first, second = joined(desk, "first", b"A"), joined(desk, "second", b"B")
    request, frame = first.request("disable", 0.0, robot=3)
    assert wire(desk, first, b"A", frame)[0].request is not None
    desk.bump("robot 3 disabled", 3)  # the manager carried it out
    stale, frame = second.request("enable", 0.0, robot=3)  # second still saw the old version
    intake, got = wire(desk, second, b"B", frame)
    assert intake.request is None
    answer, asked = got[0]
    assert not answer.ok and asked == stale
    assert "robot 3 disabled" in answer.reason and "look again" in answer.reason
    # the answer carried the new version: the same request again goes ahead
    again, frame = second.request("enable", 0.0, robot=3)
    assert wire(desk, second, b"B", frame)[0].request == again


def test_only_changes_that_concern_a_request_make_it_outdated() -> None:
    desk = ControlDesk("s1", 0.0)
    console = joined(desk, "ops", b"A")
    looked = desk.version
    desk.bump("robot 7 link down", 7)  # telemetry of another robot: no conflict
    desk.bump("plan 2 (reroute)", robots=[5, 6])  # new paths for robots 5 and 6 only
    for action, args in (("disable", {"robot": 3}), ("strategy", {"name": "step"}), ("pause", {})):
        _, frame = console.request(action, 0.0, based_on=looked, **args)
        assert wire(desk, console, b"A", frame)[0].request is not None, action
    _, frame = console.request("enable", 0.0, based_on=looked, robot=6)
    intake, got = wire(desk, console, b"A", frame)
    assert intake.request is None and "plan 2 (reroute)" in got[0][0].reason
    desk.bump("run paused")  # the whole run: every request on an older picture is refused
    _, frame = console.request("disable", 0.0, based_on=looked, robot=3)
    assert wire(desk, console, b"A", frame)[0].request is None
    for n in range(100):  # so many changes since that the desk no longer remembers them all
        desk.bump("robot 9 fault {}".format(n), 9)
    _, frame = console.request("disable", 0.0, based_on=looked + 2, robot=3)
    intake, got = wire(desk, console, b"A", frame)
    assert intake.request is None and "older than this manager remembers" in got[0][0].reason


def test_a_consoles_own_changes_do_not_make_its_picture_outdated() -> None:
    desk = ControlDesk("s1", 0.0)
    ops, other = joined(desk, "ops", b"A"), joined(desk, "other", b"B")
    looked = desk.version
    desk.acting = b"A"  # the manager carries out ops' pause
    desk.bump("run paused")
    desk.acting = None
    _, frame = ops.request("start", 0.0, based_on=looked)  # ops knows: it paused the run
    assert wire(desk, ops, b"A", frame)[0].request is not None
    _, frame = other.request("start", 0.0, based_on=looked)  # the other console did not see it
    intake, got = wire(desk, other, b"B", frame)
    assert intake.request is None and "run paused" in got[0][0].reason
    desk.bump("robot 3 failed", 3)  # the manager's own news counts for everybody
    _, frame = ops.request("disable", 0.0, based_on=looked, robot=3)
    assert wire(desk, ops, b"A", frame)[0].request is None


def test_a_console_that_did_not_say_hello_is_refused() -> None:
    desk = ControlDesk("s1", 0.0)
    stranger = ConsoleSession("x", 0.0)
    _, frame = stranger.request("start", 0.0)
    intake = desk.receive(b"Z", frame, 0.0)
    assert intake.request is None and intake.refusal is not None
    assert "hello" in decode(intake.out[0][1], m.MANAGER_MESSAGES).reason


@pytest.mark.parametrize("frame", [
    b"", b"\xff\xfe", b"[" * 60000, b"{}", b'{"t":"request","v":1}', b"null", b"1e999",
    b'{"t":"request","v":1,"id":1,"action":"start","args":{},"based_on":' + b"9" * 5000 + b"}",
    b'{"t":"request","v":1,"id":1,"action":"self-destruct","args":{},"based_on":1}',
    b'{"t":"request","v":2,"id":1,"action":"start","args":{},"based_on":1}',
    b'{"t":"state","v":1}',
    json.dumps({"t": "request", "v": 1, "id": 1, "action": "disable", "args": {"robot": -1},
                "based_on": 1}).encode(),
])
def test_garbage_is_answered_with_an_error_and_changes_nothing(frame: bytes) -> None:
    desk = ControlDesk("s1", 0.0)
    joined(desk, "ops", b"A")
    version, consoles = desk.version, dict(desk.consoles)
    intake = desk.receive(b"A", frame, 1.0)
    assert intake.request is None and intake.joined is None
    assert len(intake.out) == 1
    answer = decode(intake.out[0][1], m.MANAGER_MESSAGES)
    assert isinstance(answer, Answer) and not answer.ok and answer.reason
    assert desk.version == version and desk.consoles.keys() == consoles.keys()


@given(st.binary(max_size=2000))
def test_any_bytes_from_a_console_give_an_answer_never_an_exception(data: bytes) -> None:
    desk = ControlDesk("s1", 0.0)
    intake = desk.receive(b"A", data, 0.0)
    assert intake.request is None or intake.request.action in ACTIONS


@given(st.binary(max_size=2000))
def test_any_bytes_from_a_manager_are_a_message_or_our_error(data: bytes) -> None:
    session = ConsoleSession("ops", 0.0)
    try:
        session.receive(data, 0.0)
    except ControlProtocolError:
        pass


_json = st.recursive(st.none() | st.booleans() | st.integers() | st.floats() | st.text(max_size=5),
                     lambda inner: st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=5), inner, max_size=4),
                     max_leaves=20)


@given(st.sampled_from(sorted(ACTIONS)), _json)
def test_request_arguments_are_checked_or_refused_with_a_reason(action: str, args) -> None:
    try:
        checked = check_args(action, args if isinstance(args, dict) else {"x": args})
    except SchemaError as err:
        assert str(err)
    else:
        assert isinstance(checked, dict)


robot_states = st.builds(
    RobotState, id=st.integers(0, 1000), link=st.sampled_from(m.LINK_STATES), link_reason=st.text(max_size=20),
    x=st.none() | st.floats(-100, 100), y=st.none() | st.floats(-100, 100), theta=st.none() | st.floats(-3.2, 3.2),
    source=st.sampled_from(m.SOURCES), age=st.none() | st.floats(0, 100), stale=st.booleans(),
    faults=st.lists(st.text(max_size=8), max_size=2).map(tuple), out=st.sampled_from([None, "disabled", "failed"]),
    activity=st.none() | st.builds(Activity, kind=st.sampled_from(["turn", "drive"]), index=st.integers(0, 50),
                                   x=st.none() | st.floats(-9, 9), y=st.none() | st.floats(-9, 9),
                                   angle=st.none() | st.floats(-3, 3)),
    done=st.integers(0, 99), total=st.integers(0, 99), step=st.integers(0, 99),
    waiting=st.none() | st.builds(Waiting, on=st.lists(st.integers(0, 9), max_size=3).map(tuple),
                                  cell=st.none() | st.tuples(st.integers(0, 9), st.integers(0, 9)),
                                  reason=st.sampled_from(["cell", "barrier", "link"])),
    behind=st.floats(0, 50), vicon_age=st.none() | st.floats(0, 9), disagree=st.booleans())


@given(st.lists(robot_states, max_size=5), st.integers(0, 10 ** 6))
def test_states_survive_the_wire_unchanged(robots, version: int) -> None:
    run = RunInfo("running", "", "adg", 1, 3.5, 1.4, 1, 2, len(robots), None, 0, None)
    state = State(7, version, run, tuple(robots))
    assert decode(encode(state), m.MANAGER_MESSAGES) == state


def test_the_runs_plan_clock_is_sent_only_once_a_plan_changed_so_that_older_consoles_read_the_rest() -> None:
    """`plan_start` (the steps a run's earlier plans took) is newer than some consoles, whose decoder
    refuses a field it does not know: a run's first plan leaves it out, a later one sends it."""
    first = State(7, 3, RunInfo("running", "", "adg", 1, 3.5, 1.4, 1, 2, 0, None, 0, None), ())
    known_before = {f.name for f in dataclasses.fields(RunInfo)} - {"plan_start", "reroute_scope", "trim", "why_not"}
    assert set(json.loads(encode(first))["run"]) == known_before  # all an older console knows
    assert decode(encode(first), m.MANAGER_MESSAGES) == first
    rerouted = State(8, 4, RunInfo("running", "", "adg", 1, 9.0, 0.2, 2, 2, 0, None, 0, None, plan_start=7.25), ())
    back = decode(encode(rerouted), m.MANAGER_MESSAGES)
    assert back == rerouted and back.run.run_steps == pytest.approx(7.45)
    with pytest.raises(ControlProtocolError, match="plan_start"):  # a wrong value is named
        decode(encode(rerouted).replace(b'"plan_start":7.25', b'"plan_start":-1'), m.MANAGER_MESSAGES)
    # the reroute's scope likewise: sent only when it is not the default (held)
    every = State(9, 5, RunInfo("running", "", "adg", 1, 9.0, 0.2, 2, 2, 0, None, 0, None, reroute="auto",
                                reroute_scope="all"), ())
    assert json.loads(encode(every))["run"]["reroute_scope"] == "all"
    assert decode(encode(every), m.MANAGER_MESSAGES) == every
    # and trim: sent only when on
    trimmed = State(10, 6, RunInfo("running", "", "adg", 1, 9.0, 0.2, 2, 2, 0, None, 0, None, trim=True), ())
    assert json.loads(encode(trimmed))["run"]["trim"] is True
    assert decode(encode(trimmed), m.MANAGER_MESSAGES) == trimmed
    with pytest.raises(ControlProtocolError, match="trim"):  # a wrong value is named
        decode(encode(trimmed).replace(b'"trim":true', b'"trim":"yes"'), m.MANAGER_MESSAGES)


def test_why_a_run_action_is_refused_comes_with_the_state_one_line_each_and_a_bad_reason_is_named() -> None:
    """The State says why the manager would refuse each run action it does not allow: a reason as
    long as the manager sends (one line, cut to WHY_NOT_CHARS) comes through unchanged; longer,
    or of the wrong type, the State is refused naming the field."""
    from fleet_common.limits import one_line

    down = "not connected: robots " + ", ".join(map(str, range(1, 301))) + " (silent for 3.5 s)"
    reason = one_line(down, m.WHY_NOT_CHARS)
    assert len(reason) == m.WHY_NOT_CHARS and reason.endswith("300 (silent for 3.5 s)")
    run = RunInfo("waiting", "", "adg", 1, 0.0, 0.0, 1, 0, 300, None, 0, None, allowed=("to_starts",),
                  why_not={"start": reason, "halt": "nothing is moving (the run is waiting)"})
    state = State(7, 3, run, ())
    assert decode(encode(state), m.MANAGER_MESSAGES) == state
    frame = json.loads(encode(state))
    for bad, named in (({"start": reason + "!"}, "run.why_not.start"), (["start"], "run.why_not"),
                       ({"start": 5}, "run.why_not.start"), ({"x" * 41: "no"}, "run.why_not")):
        frame["run"]["why_not"] = bad
        with pytest.raises(ControlProtocolError, match="field '{}' of a state message".format(named)):
            decode(json.dumps(frame).encode(), m.MANAGER_MESSAGES)
    frame["run"]["why_not"] = {str(k): "no" for k in range(51)}  # more reasons than there are actions
    with pytest.raises(ControlProtocolError, match="must be an object of at most 50 keys"):
        decode(json.dumps(frame).encode(), m.MANAGER_MESSAGES)


def test_a_scene_carries_a_large_plan_compactly() -> None:
    positions = np.random.default_rng(1).integers(0, 500, size=(300, 1500, 2), dtype=np.int32)
    scene = RunSetup("brc202d", ("..@",), (m.RobotInfo(1, "red", "tb1"),), PlanData(4, (1,), positions),
                  ("adg", "step"), 2.5)
    frame = encode(scene)
    assert len(frame) < positions.nbytes * 1.4  # base64 of the cells, not JSON lists
    assert decode(frame, m.MANAGER_MESSAGES, 10 ** 9) == scene
    tampered = frame.replace(b'"shape":[300,1500,2]', b'"shape":[301,1500,2]')
    with pytest.raises(ControlProtocolError, match="hold 301 steps"):
        decode(tampered, m.MANAGER_MESSAGES, 10 ** 9)


def test_events_are_kept_once_each_and_a_new_manager_resets_the_session() -> None:
    session = ConsoleSession("ops", 0.0)
    session.receive(encode(m.Welcome("one", 5)), 0.0)
    for seq in (1, 2, 2, 3):
        session.receive(encode(Notice(seq, 1.0, "fault", 2, "robot 2 reports bumper")), 0.0)
    assert [e.seq for e in session.notices] == [1, 2, 3] and session.version == 5
    session.receive(encode(m.Welcome("two", 1)), 1.0)  # the manager restarted
    assert session.session == "two" and session.version == 1 and session.state is None


def test_heartbeats_both_ways_and_a_silent_console_is_forgotten() -> None:
    desk = ControlDesk("s1", 0.0)
    console = joined(desk, "ops", b"A")
    assert desk.tick(0.5) == []
    beats = desk.tick(1.2)
    assert [p for p, _ in beats] == [b"A"] and isinstance(decode(beats[0][1], m.MANAGER_MESSAGES), m.Heartbeat)
    assert console.heartbeat(1.2) is not None and console.heartbeat(1.3) is None
    desk.tick(10.0)
    assert not desk.consoles
    assert console.lost(10.0)
