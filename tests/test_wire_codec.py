"""Wire protocol encoding: every message round-trips; bad frames are refused with reasons."""
from __future__ import annotations

import json

import pytest
from hypothesis import given
from hypothesis import strategies as st

from fleet_common.wire import (PROTOCOL_VERSION, Accepted, Bye, Completed, DriveToPosition,
                               Failed, GetStatus, Heartbeat, Hello, Pose, PoseFeedback,
                               RemoteProtocolError, Status, Stop, Turn, VersionMismatchError,
                               Welcome)
from fleet_common.wire.codec import decode, encode
from fleet_common.wire.messages import MESSAGE_TYPES

ids = st.integers(0, 2 ** 63 - 1)
small = st.integers(0, 2 ** 31)
reals = st.floats(allow_nan=False, allow_infinity=False)
texts = st.text(max_size=40)
poses = st.builds(Pose, reals, reals, reals)
faults = st.lists(texts, max_size=3).map(tuple)

BY_TYPE = {
    "hello": st.builds(Hello, small, texts),
    "welcome": st.builds(Welcome, small, texts, st.integers(1, 65535)),
    "bye": st.builds(Bye, texts, texts),
    "heartbeat": st.just(Heartbeat()),
    "drive": st.builds(DriveToPosition, ids, reals, reals, reals),
    "turn": st.builds(Turn, ids, reals),
    "stop": st.builds(Stop, ids),
    "get_status": st.builds(GetStatus, ids),
    "accepted": st.builds(Accepted, ids, st.booleans()),
    "completed": st.builds(Completed, ids),
    "failed": st.builds(Failed, ids, texts),
    "status": st.builds(Status, ids, poses, st.none() | ids, faults),
    "pose": st.builds(PoseFeedback, small, ids, poses, st.none() | ids, faults),
}
MESSAGES = st.one_of(*BY_TYPE.values())


def test_every_message_type_is_tested() -> None:
    assert set(BY_TYPE) == set(MESSAGE_TYPES)


@pytest.mark.parametrize("kind", sorted(BY_TYPE))
@given(data=st.data())
def test_every_message_round_trips(kind: str, data: st.DataObject) -> None:
    message = data.draw(BY_TYPE[kind])
    frame = encode(message)
    assert decode(frame) == message
    assert type(decode(frame)) is type(message)


@given(MESSAGES)
def test_frames_are_compact_json_naming_type_and_version(message: object) -> None:
    data = encode(message)
    frame = json.loads(data)
    assert list(frame)[:2] == ["t", "v"]
    assert frame["t"] == message.TYPE and frame["v"] == PROTOCOL_VERSION
    assert data == json.dumps(frame, separators=(",", ":")).encode()  # no padding


def test_a_drive_frame_reads_as_documented() -> None:
    assert encode(DriveToPosition(7, 3.0, 4.0, 2.5)) == (
        b'{"t":"drive","v":1,"id":7,"x":3.0,"y":4.0,"time":2.5}')
    # integers are fine where numbers are expected
    assert decode(b'{"t":"drive","v":1,"id":7,"x":3,"y":4,"time":0}') == DriveToPosition(7, 3, 4, 0)


@pytest.mark.parametrize("data, message", [
    (b"\xff", "not JSON text"),
    (b"[1, 2]", "not a JSON object"),
    (b'{"t":"teleport","v":1}', "unknown message type 'teleport'; known: accepted, bye"),
    (b'{"t":"stop"}', "stop message without an integer protocol version"),
    (b'{"t":"drive","v":1,"id":7,"x":3,"y":4}', "drive message lacks field 'time'"),
    (b'{"t":"stop","v":1,"id":7,"urgent":true}', "stop message has unknown field(s) 'urgent'"),
    (b'{"t":"stop","v":1,"id":-1}', "field 'id' of a stop message must be a non-negative integer, got -1"),
    (b'{"t":"stop","v":1,"id":true}', "must be a non-negative integer, got true"),
    (b'{"t":"turn","v":1,"id":1,"angle":"north"}', "field 'angle' of a turn message must be a finite number"),
    (b'{"t":"turn","v":1,"id":1,"angle":NaN}', "must be a finite number, got NaN"),
    (b'{"t":"turn","v":1,"id":1,"angle":1e999}', "must be a finite number, got Infinity"),
    (b'{"t":"status","v":1,"id":1,"pose":[1,2],"current":null,"faults":[]}',
     "field 'pose' of a status message must be [x, y, theta]"),
    (b'{"t":"status","v":1,"id":1,"pose":[1,2,3],"current":null,"faults":"bumper"}',
     "field 'faults' of a status message must be a list of strings"),
    (b'{"t":"accepted","v":1,"id":1,"duplicate":0}', "must be true or false, got 0"),
])
def test_malformed_frames_say_what_is_wrong(data: bytes, message: str) -> None:
    with pytest.raises(RemoteProtocolError) as err:
        decode(data)
    assert message in str(err.value)


def test_other_version_hello_is_a_version_mismatch() -> None:
    data = encode(Hello(3, "e", version=2), version=2)
    with pytest.raises(VersionMismatchError) as err:
        decode(data)
    assert (err.value.ours, err.value.theirs) == (1, 2)
    assert "peer speaks wire protocol version 2, this end speaks 1" in str(err.value)


def test_a_bye_of_any_version_is_readable() -> None:
    # a newer bye may carry more fields; its reason still gets through
    data = b'{"t":"bye","v":7,"reason":"version mismatch","code":"version","extra":1}'
    assert decode(data) == Bye("version mismatch", "version")
