"""Console-channel messages <-> bytes: one JSON object per ZeroMQ frame, checked on the way in.

    {"t":"request","v":1,"id":4,"action":"disable","args":{"robot":3},"based_on":17}

Decoding is total: any bytes become a message or a `ControlProtocolError`
saying what was wrong (too large, not JSON, nested too deep, an unknown type,
a field of the wrong shape), never another exception. Size, depth and number
lengths are checked before or while JSON is parsed (`fleet_common.limits`,
with the console channel's own frame sizes below); ranges by the schema
(`schema.py`). Which messages each end may receive
is decided by the caller: `decode(data, CONSOLE_MESSAGES)` on the manager.
"""
from __future__ import annotations

import dataclasses
import json
from typing import Any, Dict, Sequence, Type

import numpy as np

from ..errors import FleetError
from ..limits import DecodeError, loads_frame
from . import messages as m
from .columns import robots_from_columns, robots_to_columns
from .schema import (AnyObj, Bool, Cell, Checker, Int, ListOf, Num, Obj, Opt, Positions, SchemaError,
                     Str, short)

__all__ = ["ControlProtocolError", "encode", "decode", "MAX_REQUEST_BYTES", "MAX_MANAGER_BYTES"]

#: Largest frame a manager reads from a console (a plan's text may be sent with `load`).
MAX_REQUEST_BYTES = 32 * 1024 * 1024
#: Largest frame a console reads from a manager (a scene carries a whole plan).
MAX_MANAGER_BYTES = 256 * 1024 * 1024
#: Deepest nesting of any legitimate message (a plan's positions: 5 levels).
MAX_DEPTH = 12
_ID = Int(0, 2 ** 53)
_NAME = Str(200)
_TEXT = Str(2000)
_ROBOT = Int(0, 2 ** 31)
_TIME = Num(0.0, 1e9)
_COORD = Num(-1e6, 1e6)


class ControlProtocolError(FleetError):
    """A console-channel frame that is not a valid message (from the named peer)."""


class _RobotColumns(Checker):
    what = "the robots as columns"

    def __call__(self, value: Any, path: str) -> Any:
        return robots_from_columns(value, path or "robots")


_PLAN = Obj({"id": _ID, "robots": ListOf(_ROBOT), "positions": Positions(),
             "name": _NAME}, optional={"name": ""})
_WAITING = Obj({"on": ListOf(_ROBOT), "cell": Opt(Cell()), "reason": Str(40)})
_ACTIVITY = Obj({"kind": Str(20), "index": Opt(Int(0, 2 ** 31)), "x": Opt(_COORD), "y": Opt(_COORD),
                 "angle": Opt(Num(-10.0, 10.0))}, optional={"x": None, "y": None, "angle": None})
_RUN = Obj({
    "state": Str(choices=m.RUN_STATES), "reason": _TEXT, "strategy": _NAME, "lookahead": Int(1, 1000),
    "clock": _TIME, "plan_time": Num(0.0, 1e9), "plan_id": _ID, "arrived": Int(), "robots": Int(),
    "min_distance": Opt(Num(0.0, 1e9)), "collisions": Int(), "proposal": Opt(_ID),
    "replanning": Bool()}, optional={"replanning": False})

#: Fields of each message type (the frame's "t" and "v" aside).
SCHEMAS: Dict[str, Checker] = {
    "hello": Obj({"name": _NAME}),
    "request": Obj({"id": _ID, "action": Str(choices=m.ACTIONS), "args": AnyObj(),
                    "based_on": _ID}),
    "heartbeat": Obj({}),
    "bye": Obj({"reason": _TEXT}),
    "welcome": Obj({"session": _NAME, "version": _ID}),
    "scene": Obj({"map_name": _NAME, "rows": ListOf(Str(100000), 100000),
                  "robots": ListOf(Obj({"id": _ROBOT, "colour": _NAME, "vicon_name": _NAME}), 100000),
                  "plan": _PLAN, "strategies": ListOf(_NAME, 50), "step_time": Num(0.001, 1e6)}),
    "state": Obj({"seq": _ID, "version": _ID, "run": _RUN, "robots": _RobotColumns()}),
    "answer": Obj({"id": _ID, "ok": Bool(), "reason": _TEXT, "version": _ID}),
    "event": Obj({"seq": _ID, "time": _TIME, "kind": Str(40), "robot": Opt(_ROBOT), "text": _TEXT}),
    "proposal": Obj({"id": _ID, "plan": _PLAN, "message": _TEXT, "soc": Int(0, 2 ** 53),
                     "makespan": Int(0, 2 ** 31), "unreachable": ListOf(_ROBOT)},
                    optional={"unreachable": ()}),
}

#: Nested records: (message type or record, field) -> the dataclass its dict becomes.
_NESTED: Dict[str, Dict[str, Any]] = {
    "scene": {"plan": m.PlanData, "robots": m.RobotInfo},
    "proposal": {"plan": m.PlanData},
    "state": {"run": m.RunInfo},
}

_TYPES: Dict[str, Type] = {cls.TYPE: cls for cls in m.CONSOLE_MESSAGES + m.MANAGER_MESSAGES}


def encode(message: Any) -> bytes:
    """The frame for one of our messages."""
    frame: Dict[str, Any] = {"t": message.TYPE, "v": m.PROTOCOL_VERSION}
    if isinstance(message, m.State):  # robots as columns (columns.py)
        frame.update(seq=message.seq, version=message.version, run=_plain(message.run),
                     robots=robots_to_columns(message.robots))
        return json.dumps(frame, separators=(",", ":"), allow_nan=False).encode("utf-8")
    frame.update(_plain(message))
    return json.dumps(frame, separators=(",", ":"), allow_nan=False).encode("utf-8")


def _plain(value: Any) -> Any:
    if dataclasses.is_dataclass(value):
        return {f.name: _plain(getattr(value, f.name)) for f in dataclasses.fields(value)}
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    if isinstance(value, dict):
        return {k: _plain(v) for k, v in value.items()}
    if isinstance(value, np.ndarray):
        return Positions.encode(value)
    return value


def decode(data: bytes, accept: Sequence[Type], max_bytes: int = MAX_REQUEST_BYTES) -> Any:
    """The message in `data` if it is one of the types in `accept`; else ControlProtocolError."""
    frame = _load(data, max_bytes)
    kind, version = frame.pop("t", None), frame.pop("v", None)
    cls = _TYPES.get(kind) if isinstance(kind, str) else None
    if cls is None or cls not in accept:
        raise ControlProtocolError("unexpected message type {}; expected one of {}".format(
            short(kind), ", ".join(c.TYPE for c in accept)))
    if version != m.PROTOCOL_VERSION:
        raise ControlProtocolError("{} message of console protocol version {}; this end speaks {}".format(
            kind, short(version), m.PROTOCOL_VERSION))
    try:
        fields = SCHEMAS[kind](frame, "")
    except SchemaError as err:
        raise ControlProtocolError("{} message: {}".format(kind, err)) from None
    return _build(cls, fields, kind)


def _build(cls: Type, fields: Dict[str, Any], where: str) -> Any:
    nested = _NESTED.get(where, {})
    values = {}
    for name, value in fields.items():
        target = nested.get(name)
        if target is None:
            values[name] = value
        elif isinstance(value, tuple):
            values[name] = tuple(_record(target, v) for v in value)
        else:
            values[name] = _record(target, value)
    return cls(**values)


def _record(cls: Type, value: Any) -> Any:
    return None if value is None else _build(cls, value, "")


def _load(data: bytes, max_bytes: int) -> Dict[str, Any]:
    try:
        frame = loads_frame(data, max_bytes=max_bytes, max_depth=MAX_DEPTH)
    except DecodeError as err:
        raise ControlProtocolError(str(err)) from None
    if not isinstance(frame, dict):
        raise ControlProtocolError("frame is not a JSON object")
    return frame
