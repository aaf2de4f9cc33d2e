"""Console-channel messages <-> bytes: one JSON object per ZeroMQ frame, checked on the way in.

    {"t":"request","v":1,"id":4,"action":"disable","args":{"robot":3},"based_on":17}

Decoding is total: any bytes become a message or a `ControlProtocolError`
saying what was wrong (too large, not JSON, nested too deep, an unknown type,
a field of the wrong shape), never another exception. Size, depth and number
lengths are checked before or while JSON is parsed (`fleet_common.limits`,
with the console channel's own frame sizes); fields and ranges by
`SCHEMAS`, declared with the checkers of `fleet_common.schema` as the robot
protocol declares its own. Which messages each end may receive
is decided by the caller: `decode(data, CONSOLE_MESSAGES)` on the manager.
"""
from __future__ import annotations

import base64
import binascii
import dataclasses
import json
from typing import Any, Dict, Sequence, Tuple, Type

import numpy as np

from ..errors import FleetError
from ..limits import MAX_REQUEST_BYTES, DecodeError, loads_frame
from ..schema import AnyObj, Bool, Checker, Int, ListOf, MapOf, Num, Opt, Record, SchemaError, Str, short
from . import messages as m
from .columns import robots_from_columns, robots_to_columns
from .requests import ACTIONS

__all__ = ["ControlProtocolError", "encode", "decode", "SCHEMAS"]

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


class PlanCells(Checker):
    """A plan's cells as an int32 array of shape (steps, agents, 2), sent as
    `{"shape": [steps, agents, 2], "b64": <base64 of the little-endian int32 cells>}`.

    JSON lists would be 10x larger and 20x slower to read for a plan of 1,500
    agents and 1,000 steps (1.5 M cells); this is checked in one pass: the
    shape, then the decoded length against it."""

    what = 'an object {"shape": [steps, agents, 2], "b64": base64 of int32 cells}'

    def __init__(self, max_cells: int = 50_000_000) -> None:
        self.max_cells = max_cells

    def __call__(self, value: Any, path: str) -> "np.ndarray":
        if not (isinstance(value, dict) and set(value) == {"shape", "b64"}
                and isinstance(value["b64"], str) and isinstance(value["shape"], list)
                and len(value["shape"]) == 3 and value["shape"][2] == 2
                and all(isinstance(v, int) and not isinstance(v, bool) and 0 <= v <= self.max_cells
                        for v in value["shape"])):
            raise self.fail(value, path)
        steps, agents, _ = value["shape"]
        cells = steps * agents
        if steps < 1 or cells > self.max_cells or len(value["b64"]) != 4 * ((8 * cells + 2) // 3):
            raise SchemaError("must hold {} steps of {} agents, got {} base64 characters".format(
                steps, agents, len(value["b64"])), path)
        try:
            raw = base64.b64decode(value["b64"], validate=True)
        except (ValueError, binascii.Error):
            raise SchemaError("is not valid base64", path) from None
        if len(raw) != cells * 8:
            raise SchemaError("decodes to {} bytes, expected {}".format(len(raw), cells * 8), path)
        return np.frombuffer(raw, dtype="<i4").reshape(steps, agents, 2).astype(np.int32)

    def dump(self, value: Any) -> Any:
        return self.encode(value)

    @staticmethod
    def encode(positions: "np.ndarray") -> Dict[str, Any]:
        arr = np.ascontiguousarray(positions, dtype="<i4")
        return {"shape": list(arr.shape), "b64": base64.b64encode(arr.tobytes()).decode("ascii")}


class _Size(Checker):
    """The robots' size: [diameter, margin, cell], metres."""

    what = "[diameter, margin, cell] in metres (three numbers, the first and last above 0)"
    plain = False

    def __call__(self, value: Any, path: str) -> Tuple[float, float, float]:
        if (isinstance(value, list) and len(value) == 3
                and all(isinstance(v, (int, float)) and not isinstance(v, bool) and 0 <= v < 1000
                        for v in value) and value[0] > 0 and value[2] > 0):
            return float(value[0]), float(value[1]), float(value[2])
        raise self.fail(value, path)

    def dump(self, value: Tuple[float, float, float]) -> Any:
        return list(value)


_SIZE = _Size()
_PLAN = Record(m.PlanData, {"id": _ID, "robots": ListOf(_ROBOT), "positions": PlanCells(),
                            "name": _NAME}, optional={"name": ""})
_RUN = Record(m.RunInfo, {
    "state": Str(choices=m.RUN_STATES), "reason": _TEXT, "strategy": _NAME, "lookahead": Int(1, 1000),
    "clock": _TIME, "plan_time": Num(0.0, 1e9), "plan_id": _ID, "arrived": Int(), "robots": Int(),
    "min_distance": Opt(Num(0.0, 1e9)), "collisions": Int(), "proposal": Opt(_ID),
    "replanning": Bool(), "purpose": Str(choices=m.PURPOSES), "allowed": Opt(ListOf(Str(40), 50)),
    "reroute": Str(40), "plan_start": Num(0.0, 1e9), "reroute_scope": Str(40), "trim": Bool(),
    "why_not": Opt(MapOf(Str(40), Str(m.WHY_NOT_CHARS), 50))},
    optional={"replanning": False, "purpose": "plan", "allowed": None, "reroute": "off", "plan_start": 0.0,
              "reroute_scope": "held", "trim": False, "why_not": None})

#: Fields of each message type (the frame's "t" and "v" aside).
SCHEMAS: Dict[str, Record] = {cls.TYPE: Record(cls, fields, optional) for cls, fields, optional in (
    (m.Hello, {"name": _NAME}, None),
    (m.Request, {"id": _ID, "action": Str(choices=ACTIONS), "args": AnyObj(), "based_on": _ID}, None),
    (m.Heartbeat, {}, None),
    (m.Bye, {"reason": _TEXT}, None),
    (m.Welcome, {"session": _NAME, "version": _ID}, None),
    (m.RunSetup, {"map_name": _NAME, "rows": ListOf(Str(100000), 100000),
               "robots": ListOf(Record(m.RobotInfo, {"id": _ROBOT, "colour": _NAME, "vicon_name": _NAME}),
                                100000),
               "plan": _PLAN, "strategies": ListOf(_NAME, 50), "step_time": Num(0.001, 1e6),
               "robot_size": _SIZE, "orientation": Str(choices=m.ORIENTATIONS)},
     {"robot_size": (0.7, 0.0, 0.7), "orientation": "base"}),
    (m.State, {"seq": _ID, "version": _ID, "run": _RUN, "robots": _RobotColumns()}, None),
    (m.Answer, {"id": _ID, "ok": Bool(), "reason": _TEXT, "version": _ID}, None),
    (m.Notice, {"seq": _ID, "time": _TIME, "kind": Str(40), "robot": Opt(_ROBOT), "text": _TEXT}, None),
    (m.Proposal, {"id": _ID, "plan": _PLAN, "message": _TEXT, "soc": Int(0, 2 ** 53),
                  "makespan": Int(0, 2 ** 31), "unreachable": ListOf(_ROBOT),
                  "kind": Str(choices=m.PROPOSAL_KINDS)}, {"unreachable": (), "kind": "replan"}),
)}
assert set(SCHEMAS) == {cls.TYPE for cls in m.CONSOLE_MESSAGES + m.MANAGER_MESSAGES}  # at import

_TYPES: Dict[str, Type] = {kind: schema.cls for kind, schema in SCHEMAS.items()}


def encode(message: Any) -> bytes:
    """The frame for one of our messages."""
    frame: Dict[str, Any] = {"t": message.TYPE, "v": m.PROTOCOL_VERSION}
    if isinstance(message, m.State):  # robots as columns (columns.py)
        run = _plain(message.run)
        if not run["plan_start"]:
            del run["plan_start"]  # a run's first plan: what a console older than the field reads
        if run["reroute_scope"] == "held":
            del run["reroute_scope"]  # likewise
        if not run["trim"]:
            del run["trim"]  # likewise
        if run["why_not"] is None:
            del run["why_not"]  # likewise
        frame.update(seq=message.seq, version=message.version, run=run,
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
        return PlanCells.encode(value)
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
        return SCHEMAS[kind](frame, "")
    except SchemaError as err:
        raise ControlProtocolError(err.in_message(kind)) from None


def _load(data: bytes, max_bytes: int) -> Dict[str, Any]:
    try:
        frame = loads_frame(data, max_bytes=max_bytes, max_depth=MAX_DEPTH)
    except DecodeError as err:
        raise ControlProtocolError(str(err)) from None
    if not isinstance(frame, dict):
        raise ControlProtocolError("frame is not a JSON object")
    return frame
