"""The virtual fleet's ground truth on ZeroMQ: where each virtual robot really is.

A virtual robot's own pose feedback is what it believes (it may be made to
drift); the truth stream says where it is, for the Vicon simulator (which
streams what cameras would see) and for tests. PUB on tcp://127.0.0.1:PORT,
one JSON frame per robot and tick:

    {"t":"truth","robot_id":1,"time":1732331000.25,"x":3.0,"y":4.5,"theta":1.57}

(`time` is wall-clock `time.time()`, base-grid cells and radians.)
`TruthSubscriber` reads it for the simulated Vicon Tracker: `poses(now)` is
every robot's latest true pose by Vicon name, leaving out a robot not heard
of for `max_age` seconds (a fleet that stopped is not seen).
"""
from __future__ import annotations

import json
import math
from typing import Any, Dict, Mapping, Optional, Sequence, Tuple, Union

import zmq

from ..errors import FleetError
from ..wire.messages import Pose

__all__ = ["TruthPublisher", "TruthSubscriber", "subscribe_truth", "decode_truth"]

#: Frames read in one `TruthSubscriber.poses` call at most (a tick of 300 robots, many times).
_MAX_DRAIN = 20000


class TruthPublisher:
    def __init__(self, context: zmq.Context, port: int, host: str = "127.0.0.1") -> None:
        self.socket = context.socket(zmq.PUB)
        self.socket.linger = 0
        self.socket.setsockopt(zmq.SNDHWM, 10000)
        try:
            self.socket.bind("tcp://{}:{}".format(host, port))
        except zmq.ZMQError as err:
            self.socket.close(linger=0)
            raise FleetError("cannot publish the ground truth on {}:{}: {}".format(
                host, port, err.strerror)) from err

    def publish(self, robot_id: int, time: float, x: float, y: float, theta: float) -> None:
        frame = {"t": "truth", "robot_id": robot_id, "time": round(time, 4), "x": round(x, 4),
                 "y": round(y, 4), "theta": round(theta, 4)}
        try:
            self.socket.send(json.dumps(frame, separators=(",", ":")).encode("ascii"), zmq.NOBLOCK)
        except zmq.Again:
            pass  # no room: the next tick's truth supersedes this one

    def close(self) -> None:
        self.socket.close(linger=0)


def subscribe_truth(context: zmq.Context, endpoint: str) -> zmq.Socket:
    sock = context.socket(zmq.SUB)
    sock.linger = 0
    sock.setsockopt(zmq.SUBSCRIBE, b"")
    sock.setsockopt(zmq.MAXMSGSIZE, 4096)
    sock.connect(endpoint)
    return sock


def decode_truth(data: bytes) -> Optional[Dict[str, Any]]:
    """The truth frame in `data`, or None if it is not one (never raises)."""
    if len(data) > 4096:
        return None
    try:
        frame = json.loads(data.decode("ascii"))
    except (ValueError, UnicodeDecodeError, RecursionError):
        return None
    if not isinstance(frame, dict) or frame.get("t") != "truth":
        return None
    rid = frame.get("robot_id")
    values = [frame.get(k) for k in ("time", "x", "y", "theta")]
    if not (isinstance(rid, int) and not isinstance(rid, bool) and all(
            isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)
            for v in values)):
        return None
    return frame


class TruthSubscriber:
    """The truth stream by Vicon name (`names`: robot id -> vicon_name); see the docstring.
    `port` may name several ports: a fleet served by several processes (`virtual-fleet
    --robots`) publishes one stream each, and one SUB socket reads them all."""

    def __init__(self, context: zmq.Context, port: Union[int, Sequence[int]], names: Mapping[int, str],
                 host: str = "127.0.0.1", max_age: float = 1.0) -> None:
        self.names = dict(names)
        self.max_age = max_age
        ports = [port] if isinstance(port, int) else list(port)
        self.socket = subscribe_truth(context, "tcp://{}:{}".format(host, ports[0]))
        for more in ports[1:]:
            self.socket.connect("tcp://{}:{}".format(host, more))
        self.last: Dict[int, Tuple[float, Pose]] = {}  # robot id -> (received, pose)
        self.frames = 0
        self.bad: Dict[str, int] = {}  # "frame" (not a truth frame), "robot" (not defined)

    def poses(self, now: float) -> Dict[str, Pose]:
        for _ in range(_MAX_DRAIN):
            try:
                data = self.socket.recv(zmq.NOBLOCK)
            except zmq.Again:
                break
            self.frames += 1
            frame = decode_truth(data)
            if frame is None or frame["robot_id"] not in self.names:
                cause = "frame" if frame is None else "robot"
                self.bad[cause] = self.bad.get(cause, 0) + 1
                continue
            self.last[frame["robot_id"]] = (now, Pose(float(frame["x"]), float(frame["y"]),
                                                      float(frame["theta"])))
        return {self.names[rid]: pose for rid, (when, pose) in self.last.items()
                if now - when <= self.max_age}

    def close(self) -> None:
        self.socket.close(linger=0)
