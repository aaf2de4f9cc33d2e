"""Messages <-> bytes: one compact JSON object per ZeroMQ frame.

    {"t":"drive","v":1,"id":7,"x":3.0,"y":4.0,"time":2.5}

Why JSON: both ends have it in the standard library (the robots' Python 3.8
needs no extra package, unlike msgpack), a frame can be read in a packet dump
or typed by hand while debugging, and the messages are a few dozen bytes sent
tens of times a second per robot, where encoding cost does not matter.
`t` is the message type, `v` the protocol version, the rest are the record's
fields (a `Pose` is `[x, y, theta]`). Decoding is strict and total: any bytes
give a message or `MalformedFrameError` (a `RemoteProtocolError`: the bytes
come from the peer), or `VersionMismatchError` for a hello of another version:
frames
beyond the limits of `fleet_common.limits` (size, nesting, number length,
text length, list length), unknown types or fields, missing fields, wrong
types and non-finite numbers. Whether a number makes sense (a drive off the
map, a time of 1e300) is the robot's to judge (`command_check`), so that it can
answer `Failed` instead of dropping the connection. Encoding cuts our own text
fields to the limit, so that the peer never refuses a frame of ours. A `Bye` of any version
decodes (its layout is frozen); a `Hello` or `Welcome` of another version
raises `VersionMismatchError`, so both ends can say clearly what is wrong.
"""
from __future__ import annotations

import dataclasses
import json
import math
from typing import Any, Dict, List, Optional, Tuple

from ..limits import MAX_WIRE_LIST, MAX_WIRE_TEXT, DecodeError, excerpt, loads_frame
from .errors import MalformedFrameError, VersionMismatchError
from .messages import MESSAGE_TYPES, PROTOCOL_VERSION, Message, Pose, PoseFeedback

__all__ = ["encode", "decode"]

_MAX_ID = 2 ** 63 - 1


def _field_kinds(cls: type) -> List[Tuple[str, str]]:
    """(name, kind) of a record's fields; kinds are the few the protocol uses."""
    kinds = {"int": "int", "float": "float", "str": "str", "bool": "bool", "Pose": "pose",
             "Optional[int]": "opt_int", "Tuple[str, ...]": "strs"}
    # annotations are strings (postponed); the spelling in messages.py is the schema
    return [(f.name, kinds[str(f.type)]) for f in dataclasses.fields(cls)
            if f.name != "version"]


_SCHEMA: Dict[str, List[Tuple[str, str]]] = {t: _field_kinds(c) for t, c in MESSAGE_TYPES.items()}


def encode(message: Message, version: int = PROTOCOL_VERSION) -> bytes:
    """The frame for `message` (our own records, so only values are checked)."""
    frame: Dict[str, Any] = {"t": message.TYPE, "v": version}
    for name, kind in _SCHEMA[message.TYPE]:
        value = getattr(message, name)
        if kind == "pose":
            value = [value.x, value.y, value.theta]
        elif kind == "strs":
            value = [v[:MAX_WIRE_TEXT] for v in value[:MAX_WIRE_LIST]]
        elif kind == "str":
            value = value[:MAX_WIRE_TEXT]
        frame[name] = value
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
    values = {}
    for name, field_kind in _SCHEMA[kind]:
        if name not in frame:
            raise MalformedFrameError("{} message lacks field {!r}".format(kind, name))
        values[name] = _check(kind, name, field_kind, frame.pop(name))
    if frame:
        raise MalformedFrameError("{} message has unknown field(s) {}".format(
            kind, excerpt(", ".join(sorted(frame)), 80)))
    if kind in ("hello", "welcome"):
        values["version"] = their
    return MESSAGE_TYPES[kind](**values)


#: A pose feedback frame this small is read by the fast path below: every robot sends ten a
#: second, so a manager of 300 robots reads 3,000 a second, and the general path costs 5x.
_FAST_BYTES = 512
_POSE_KEYS = frozenset(("t", "v", "robot_id", "seq", "pose", "current", "faults"))


def _fast_pose(data: bytes, version: int) -> Optional[PoseFeedback]:
    """The pose in a small, well-formed pose frame; None for anything else (the general path
    then says what is wrong). Safe with the plain JSON parser: in 512 bytes a number has at most
    some 500 digits and the nesting is far from Python's recursion limit, and every value is
    checked here as the general path would (finite numbers, integers in range, no extra keys)."""
    try:
        pairs = json.loads(data, object_pairs_hook=list)  # a key twice is refused, as in general
    except (ValueError, RecursionError):
        return None
    if type(pairs) is not list or len(pairs) != len(_POSE_KEYS):
        return None
    f = dict(pairs) if all(type(p) is tuple for p in pairs) else {}
    if f.keys() != _POSE_KEYS or f["v"] != version:
        return None
    rid, seq, pose, current, faults = f["robot_id"], f["seq"], f["pose"], f["current"], f["faults"]
    try:
        return _checked_pose(rid, seq, pose, current, faults)
    except OverflowError:  # an integer too large for a float: the general path refuses it
        return None


def _checked_pose(rid: Any, seq: Any, pose: Any, current: Any, faults: Any) -> Optional[PoseFeedback]:
    if not (type(rid) is int and 0 <= rid <= _MAX_ID and type(seq) is int and 0 <= seq <= _MAX_ID
            and (current is None or (type(current) is int and 0 <= current <= _MAX_ID))
            and type(pose) is list and len(pose) == 3
            and all(type(v) in (int, float) and math.isfinite(v) for v in pose)
            and type(faults) is list and len(faults) <= MAX_WIRE_LIST
            and all(type(x) is str and len(x) <= MAX_WIRE_TEXT for x in faults)):
        return None
    return PoseFeedback(rid, seq, Pose(float(pose[0]), float(pose[1]), float(pose[2])), current,
                        tuple(faults))


def _is_int(value: Any) -> bool:
    return isinstance(value, int) and not isinstance(value, bool)


def _is_number(value: Any) -> bool:
    return (isinstance(value, (int, float)) and not isinstance(value, bool)
            and math.isfinite(value))


def _check(kind: str, name: str, field_kind: str, value: Any) -> Any:
    """`value` as the record wants it, or MalformedFrameError naming what was expected."""
    if field_kind == "int" or (field_kind == "opt_int" and value is not None):
        if _is_int(value) and 0 <= value <= _MAX_ID:
            return value
        expected = "a non-negative integer" + (" or null" if field_kind == "opt_int" else "")
    elif field_kind == "opt_int":
        return None
    elif field_kind == "float":
        if _is_number(value):
            return float(value)
        expected = "a finite number"
    elif field_kind == "str":
        if isinstance(value, str) and len(value) <= MAX_WIRE_TEXT:
            return value
        expected = "a string of at most {} characters".format(MAX_WIRE_TEXT)
    elif field_kind == "bool":
        if isinstance(value, bool):
            return value
        expected = "true or false"
    elif field_kind == "strs":
        if (isinstance(value, list) and len(value) <= MAX_WIRE_LIST
                and all(isinstance(v, str) and len(v) <= MAX_WIRE_TEXT for v in value)):
            return tuple(value)
        expected = "a list of at most {} strings of at most {} characters".format(
            MAX_WIRE_LIST, MAX_WIRE_TEXT)
    else:  # pose
        if isinstance(value, list) and len(value) == 3 and all(map(_is_number, value)):
            return Pose(float(value[0]), float(value[1]), float(value[2]))
        expected = "[x, y, theta] (three finite numbers)"
    raise MalformedFrameError("field {!r} of a {} message must be {}, got {}".format(
        name, kind, expected, excerpt(value)))
