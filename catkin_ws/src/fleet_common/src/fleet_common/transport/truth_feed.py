"""The virtual fleet's ground truth on the wire: where each virtual robot really is.

`fleetctl virtual-fleet --truth-port PORT` publishes, on a ZeroMQ PUB at
tcp://127.0.0.1:PORT, one JSON frame per robot pose (base-grid cells, radians,
wall time), 50 times a second per robot:

    {"t":"truth","robot_id":1,"time":1700000000.25,"x":3.0,"y":4.5,"theta":1.57}

`encode_truth`/`parse_truth` are that frame (parse is total: a frame or a
`RemoteProtocolError`); `TruthSubscriber` reads the socket for the simulated
Vicon Tracker and answers `poses(now)` (Vicon name -> true pose), leaving out
a robot not heard of for `max_age` seconds (a fleet that stopped is not seen).
"""
from __future__ import annotations

import json
import math
from dataclasses import dataclass
from typing import Dict, Mapping, Optional, Tuple

import zmq

from ..wire.errors import RemoteProtocolError
from ..wire.messages import Pose

__all__ = ["TruthFrame", "parse_truth", "encode_truth", "TruthSubscriber", "MAX_DRAIN"]

#: Frames read from the truth socket in one `poses` call at most (50 Hz x 300 robots).
MAX_DRAIN = 20000


@dataclass(frozen=True)
class TruthFrame:
    robot_id: int
    time: float
    pose: Pose


def _finite(frame: Mapping[str, object], key: str) -> float:
    value = frame.get(key)
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise RemoteProtocolError("truth frame needs a finite number {!r}, got {!r}".format(
            key, value))
    return float(value)


def parse_truth(data: bytes) -> TruthFrame:
    """The truth frame in `data`; RemoteProtocolError if it is not one."""
    try:
        frame = json.loads(data.decode("utf-8"))
    except (UnicodeDecodeError, ValueError, RecursionError) as err:
        raise RemoteProtocolError("truth frame is not JSON text: {}".format(err)) from None
    if not isinstance(frame, dict) or frame.get("t") != "truth":
        raise RemoteProtocolError("not a truth frame (expected a JSON object with \"t\":"
                                  "\"truth\")")
    robot_id = frame.get("robot_id")
    if isinstance(robot_id, bool) or not isinstance(robot_id, int) or robot_id < 0:
        raise RemoteProtocolError("truth frame needs a robot_id >= 0, got {!r}".format(robot_id))
    return TruthFrame(robot_id, _finite(frame, "time"),
                      Pose(_finite(frame, "x"), _finite(frame, "y"), _finite(frame, "theta")))


def encode_truth(robot_id: int, pose: Pose, when: float) -> bytes:
    """The frame the virtual fleet publishes (the tests' stand-in fleet sends it too)."""
    return json.dumps({"t": "truth", "robot_id": robot_id, "time": when, "x": pose.x,
                       "y": pose.y, "theta": pose.theta}, separators=(",", ":")).encode()


class TruthSubscriber:
    """Subscribes to the virtual fleet's truth socket; see the module's docstring."""

    def __init__(self, port: int, names: Mapping[int, str], host: str = "127.0.0.1",
                 max_age: float = 1.0, context: Optional[zmq.Context] = None) -> None:
        self.names = dict(names)
        self.max_age = max_age
        self.context = context or zmq.Context.instance()
        self.socket = self.context.socket(zmq.SUB)
        self.socket.linger = 0
        self.socket.setsockopt(zmq.RCVHWM, MAX_DRAIN)
        self.socket.setsockopt(zmq.SUBSCRIBE, b"")
        self.socket.connect("tcp://{}:{}".format(host, port))
        self.last: Dict[int, Tuple[float, Pose]] = {}  # robot id -> (received, pose)
        self.frames = 0
        self.bad: Dict[str, int] = {}  # "frame" (undecodable), "robot" (not defined)

    def poses(self, now: float) -> Dict[str, Pose]:
        for _ in range(MAX_DRAIN):
            try:
                data = self.socket.recv(zmq.NOBLOCK)
            except zmq.Again:
                break
            self.frames += 1
            try:
                truth = parse_truth(data)
            except RemoteProtocolError:
                self.bad["frame"] = self.bad.get("frame", 0) + 1
                continue
            if truth.robot_id not in self.names:
                self.bad["robot"] = self.bad.get("robot", 0) + 1
                continue
            self.last[truth.robot_id] = (now, truth.pose)
        return {self.names[rid]: pose for rid, (when, pose) in self.last.items()
                if now - when <= self.max_age}

    def close(self) -> None:
        self.socket.close(linger=0)
