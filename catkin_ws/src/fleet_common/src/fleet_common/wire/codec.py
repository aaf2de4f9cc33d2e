"""Messages <-> bytes: one compact JSON object per ZeroMQ frame.

    {"t":"drive","v":1,"id":7,"x":3.0,"y":4.0,"time":2.5}

Why JSON: both ends have it in the standard library (the robots' Python 3.8
needs no extra package, unlike msgpack), a frame can be read in a packet dump
or typed by hand while debugging, and the messages are a few dozen bytes sent
tens of times a second per robot, where encoding cost does not matter.
`t` is the message type, `v` the protocol version, the rest are the record's
fields (a `Pose` is `[x, y, theta]`), declared in `SCHEMAS` with the checkers of
`fleet_common.schema`, as the console protocol declares its own. Decoding is
strict and total: any bytes give a message or `MalformedFrameError` (a
`RemoteProtocolError`: the bytes come from the peer), or `VersionMismatchError`
for a hello of another version: frames beyond the limits of
`fleet_common.limits` (size, nesting, number length, text length, list
length), unknown types or fields, missing fields, wrong types and non-finite
numbers. Whether a number makes sense (a drive off the
map, a time of 1e300) is the robot's to judge (`command_check`), so that it can
answer `Failed` instead of dropping the connection. Encoding cuts our own text
fields to the limit, so that the peer never refuses a frame of ours. A `Bye` of any version
decodes (its layout is frozen); a `Hello` or `Welcome` of another version
raises `VersionMismatchError`, so both ends can say clearly what is wrong.
"""
from __future__ import annotations

import json
import math
from typing import Any, Dict, Optional, Tuple

from ..limits import MAX_WIRE_LIST, MAX_WIRE_TEXT, DecodeError, excerpt, loads_frame
from ..schema import Bool, Checker, Int, ListOf, Num, Opt, Record, SchemaError, Str
from .errors import MalformedFrameError, VersionMismatchError
from .messages import (MESSAGE_TYPES, PROTOCOL_VERSION, Accepted, Bye, Completed, DriveToPosition, Failed,
                       GetStatus, Heartbeat, Hello, Message, Pose, PoseFeedback, Release, Status, Stop, Turn,
                       Welcome)

__all__ = ["encode", "decode", "SCHEMAS"]

_MAX_ID = 2 ** 63 - 1


class _Pose(Checker):
    """A `Pose` as [x, y, theta]."""

    what = "[x, y, theta] (three finite numbers)"
    plain = False

    def __call__(self, value: Any, path: str) -> Pose:
        if isinstance(value, list) and len(value) == 3 and all(map(_is_number, value)):
            return Pose(float(value[0]), float(value[1]), float(value[2]))
        raise self.fail(value, path)

    def dump(self, value: Pose) -> Any:
        return [value.x, value.y, value.theta]


_ID = Int(0, _MAX_ID, what="a non-negative integer")
_NUM = Num(-math.inf, math.inf, what="a finite number")
_TEXT = Str(MAX_WIRE_TEXT)
_TEXTS = ListOf(_TEXT, MAX_WIRE_LIST, what="a list of at most {} strings of at most {} characters".format(
    MAX_WIRE_LIST, MAX_WIRE_TEXT))
_POSE = _Pose()


class _Point(Checker):
    """A point as [x, y]."""

    what = "[x, y] (two finite numbers)"
    plain = False

    def __call__(self, value: Any, path: str) -> Tuple[float, float]:
        if isinstance(value, list) and len(value) == 2 and all(map(_is_number, value)):
            return float(value[0]), float(value[1])
        raise self.fail(value, path)

    def dump(self, value: Tuple[float, float]) -> Any:
        return [value[0], value[1]]

#: Fields a frame may leave out, and what they then are.
OPTIONAL: Dict[str, Dict[str, Any]] = {"drive": {"hold": None}, "pose": {"ended": None}}
#: Fields of each message type (the frame's "t" and "v" aside; a hello's and a welcome's
#: `version` is the frame's "v").
SCHEMAS: Dict[str, Record] = {cls.TYPE: Record(cls, fields, extra=("version",), optional=OPTIONAL.get(cls.TYPE))
                              for cls, fields in (
    (Hello, {"robot_id": _ID, "epoch": _TEXT}),
    (Welcome, {"robot_id": _ID, "session": _TEXT, "feedback_port": _ID}),
    (Bye, {"reason": _TEXT, "code": _TEXT}),
    (Heartbeat, {}),
    (DriveToPosition, {"id": _ID, "x": _NUM, "y": _NUM, "time": _NUM, "hold": Opt(_Point())}),
    (Turn, {"id": _ID, "angle": _NUM}),
    (Stop, {"id": _ID}),
    (Release, {"id": _ID, "drive": _ID, "x": _NUM, "y": _NUM}),
    (GetStatus, {"id": _ID}),
    (Accepted, {"id": _ID, "duplicate": Bool()}),
    (Completed, {"id": _ID}),
    (Failed, {"id": _ID, "reason": _TEXT}),
    (Status, {"id": _ID, "pose": _POSE, "current": Opt(_ID), "faults": _TEXTS}),
    (PoseFeedback, {"robot_id": _ID, "seq": _ID, "pose": _POSE, "current": Opt(_ID), "faults": _TEXTS,
                    "ended": Opt(_ID)}),
)}
assert set(SCHEMAS) == set(MESSAGE_TYPES)  # every message declared (checked at import, not input)


def encode(message: Message, version: int = PROTOCOL_VERSION) -> bytes:
    """The frame for `message` (our own records, so only values are checked)."""
    frame: Dict[str, Any] = {"t": message.TYPE, "v": version}
    for name, dump in SCHEMAS[message.TYPE].dumps:
        value = getattr(message, name)
        frame[name] = value if dump is None else dump(value)
    # allow_nan=False: a NaN would be sent as a token the peer must refuse
    return json.dumps(frame, separators=(",", ":"), allow_nan=False).encode("utf-8")


def decode(data: bytes, version: int = PROTOCOL_VERSION) -> Message:
    """The message in frame `data`; MalformedFrameError if it is not a valid one."""
    if len(data) <= _FAST_BYTES and data[:10] == b'{"t":"pose':
        pose = _fast_pose(data, version)
        if pose is not None:
            return pose
    try:
        frame = loads_frame(data)
    except DecodeError as err:
        raise MalformedFrameError(str(err)) from None
    if not isinstance(frame, dict):
        raise MalformedFrameError("frame is not a JSON object")
    kind = frame.pop("t", None)
    their = frame.pop("v", None)
    if not isinstance(kind, str) or kind not in MESSAGE_TYPES:
        raise MalformedFrameError("unknown message type {}; known: {}".format(
            excerpt(kind), ", ".join(sorted(MESSAGE_TYPES))))
    if not _is_int(their):
        raise MalformedFrameError("{} message without an integer protocol version 'v'".format(kind))
    if their != version:
        if kind == "bye":  # frozen layout: readable whatever the version
            frame = {k: frame[k] for k in ("reason", "code") if k in frame}
        else:
            raise VersionMismatchError(
                "peer speaks wire protocol version {}, this end speaks {} ({} message)".format(
                    their, version, kind), ours=version, theirs=their)
    try:
        if kind in ("hello", "welcome"):
            return SCHEMAS[kind](frame, "", version=their)
        return SCHEMAS[kind](frame, "")
    except SchemaError as err:
        raise MalformedFrameError(err.in_message(kind)) from None


#: A pose feedback frame this small is read by the fast path below: every robot sends ten a
#: second, so a manager of 300 robots reads 3,000 a second, and the general path costs 5x.
_FAST_BYTES = 512
_POSE_KEYS = frozenset(("t", "v", "robot_id", "seq", "pose", "current", "faults", "ended"))
_OLD_POSE_KEYS = _POSE_KEYS - {"ended"}  # a robot from before `ended` (it is None then)
#: One decoder for every pose (json.loads with a hook builds a new one, scanner and all, per call).
_PAIRS = json.JSONDecoder(object_pairs_hook=list)


def _fast_pose(data: bytes, version: int) -> Optional[PoseFeedback]:
    """The pose in a small, well-formed pose frame; None for anything else (the general path
    then says what is wrong). Safe with the plain JSON parser: in 512 bytes a number has at most
    some 500 digits and the nesting is far from Python's recursion limit, and every value is
    checked here as the general path would (finite numbers, integers in range, no extra keys)."""
    try:
        pairs = _PAIRS.decode(data.decode("utf-8"))  # a key twice is refused, as in general
    except (ValueError, RecursionError):  # UnicodeDecodeError is a ValueError
        return None
    if type(pairs) is not list or len(pairs) not in (len(_POSE_KEYS), len(_OLD_POSE_KEYS)):
        return None
    f = dict(pairs) if all(type(p) is tuple for p in pairs) else {}
    if len(f) != len(pairs) or (f.keys() != _POSE_KEYS and f.keys() != _OLD_POSE_KEYS) or f["v"] != version:
        return None
    rid, seq, pose, current, faults = f["robot_id"], f["seq"], f["pose"], f["current"], f["faults"]
    try:
        return _checked_pose(rid, seq, pose, current, faults, f.get("ended"))
    except OverflowError:  # an integer too large for a float: the general path refuses it
        return None


def _checked_pose(rid: Any, seq: Any, pose: Any, current: Any, faults: Any, ended: Any) -> Optional[PoseFeedback]:
    if not (type(rid) is int and 0 <= rid <= _MAX_ID and type(seq) is int and 0 <= seq <= _MAX_ID
            and (current is None or (type(current) is int and 0 <= current <= _MAX_ID))
            and (ended is None or (type(ended) is int and 0 <= ended <= _MAX_ID))
            and type(pose) is list and len(pose) == 3
            and all(type(v) in (int, float) and math.isfinite(v) for v in pose)
            and type(faults) is list and len(faults) <= MAX_WIRE_LIST
            and all(type(x) is str and len(x) <= MAX_WIRE_TEXT for x in faults)):
        return None
    return PoseFeedback(rid, seq, Pose(float(pose[0]), float(pose[1]), float(pose[2])), current,
                        tuple(faults), ended)


def _is_int(value: Any) -> bool:
    return isinstance(value, int) and not isinstance(value, bool)


def _is_number(value: Any) -> bool:
    return (isinstance(value, (int, float)) and not isinstance(value, bool)
            and math.isfinite(value))
