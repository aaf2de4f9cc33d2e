"""A console that floods the manager, and what it costs (for tests and bench/floods.py).

`flood(port, ...)` connects two consoles to a running manager on 127.0.0.1:
a watcher that only listens (and says it is alive), and a flooder that sends
`garbage` frames that are no console message, says hello, then sends
`refused` requests the manager refuses ("disable 99999"). Both are plain
DEALER sockets that count the frames they receive, so the States each gets
per second are counted exactly. The figures: how long the manager took to
answer everything, the States per console per second meanwhile, and how
much its log and its run log grew.
"""
from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path
from typing import List, Optional

import zmq

from fleet_common.control import codec
from fleet_common.control import messages as m
from fleet_common.limits import MAX_MANAGER_BYTES


@dataclass
class Flood:
    seconds: float                 # from the first frame sent to the last answer received
    answers: int                   # answers the flooder got (one per frame)
    states_watcher: int            # States each console got in that time
    states_flooder: int
    log_lines: int                 # lines the manager's log grew by
    log_bytes: int
    run_log_bytes: int             # bytes its events.jsonl grew by

    def per_second(self, states: int) -> float:
        return states / self.seconds if self.seconds > 0 else float("inf")

    def lines(self) -> List[str]:
        return ["{:,} frames answered in {:.2f} s".format(self.answers, self.seconds),
                "States per second: watcher {:.1f}, flooder {:.1f}".format(
                    self.per_second(self.states_watcher), self.per_second(self.states_flooder)),
                "manager log: +{} lines ({:,} bytes)".format(self.log_lines, self.log_bytes),
                "run log: +{:,} bytes".format(self.run_log_bytes)]


class _Console:
    """A raw console socket that counts States and keeps itself known to the manager."""

    def __init__(self, context: zmq.Context, port: int, name: str) -> None:
        self.sock = context.socket(zmq.DEALER)
        self.sock.linger = 0
        self.sock.setsockopt(zmq.SNDHWM, 0)  # queue what the manager cannot take yet: all of it goes
        self.sock.connect("tcp://127.0.0.1:{}".format(port))
        self.states = 0
        self.answers = 0
        self.version = 0
        self.marker = False  # the answer to the last request came
        self.sock.send(codec.encode(m.Hello(name)))
        self._beat = time.monotonic()

    def pump(self, counting: bool) -> None:
        while True:
            try:
                data = self.sock.recv(zmq.NOBLOCK)
            except zmq.Again:
                break
            if data.startswith(b'{"t":"state"'):
                self.states += counting
            elif data.startswith(b'{"t":"answer"'):
                self.answers += 1
                self.marker |= data.startswith(b'{"t":"answer","v":1,"id":%d,' % _MARKER)
            elif data.startswith(b'{"t":"welcome"'):
                self.version = codec.decode(data, m.MANAGER_MESSAGES, MAX_MANAGER_BYTES).version
        now = time.monotonic()
        if now - self._beat >= 0.5:
            self._beat = now
            self.sock.send(codec.encode(m.Heartbeat()))


_MARKER = 2 ** 40  # the id of the request that ends the flood: answered once all before it are


def _size(path: Path) -> int:
    try:
        return path.stat().st_size
    except OSError:
        return 0


def flood(port: int, manager_log: Path, events: Optional[Path], garbage: int = 10_000,
          refused: int = 10_000, timeout: float = 120.0) -> Flood:
    context = zmq.Context()
    try:
        watcher = _Console(context, port, "watcher")
        deadline = time.monotonic() + timeout
        while watcher.version == 0:  # welcomed
            assert time.monotonic() < deadline, "the manager never welcomed the watcher"
            watcher.pump(False)
            time.sleep(0.01)
        text = manager_log.read_bytes()
        lines0, bytes0 = text.count(b"\n"), len(text)
        run0 = _size(events) if events is not None else 0
        flooder = _Console(context, port, "flooder")
        began = time.monotonic()
        for i in range(garbage):
            flooder.sock.send(b"\xff garbage %d" % i)
            if i % 100 == 0:
                flooder.pump(True)
                watcher.pump(True)
        while flooder.version == 0:
            assert time.monotonic() < deadline, "the manager never welcomed the flooder"
            flooder.pump(True)
            watcher.pump(True)
            time.sleep(0.001)
        for i in range(refused):
            flooder.sock.send(codec.encode(m.Request(i + 1, "disable", {"robot": 99999}, flooder.version)))
            if i % 100 == 0:
                flooder.pump(True)
                watcher.pump(True)
        asked = 0.0
        while not flooder.marker:  # (asked again if its answer was dropped from a full queue)
            assert time.monotonic() < deadline, "the manager did not get through the flood in {:g} s".format(timeout)
            if time.monotonic() - asked > 2.0:
                asked = time.monotonic()
                flooder.sock.send(codec.encode(m.Request(_MARKER, "disable", {"robot": 99999}, flooder.version)))
            flooder.pump(True)
            watcher.pump(True)
            time.sleep(0.001)
        last = time.monotonic()
        text = manager_log.read_bytes()
        return Flood(last - began, flooder.answers, watcher.states, flooder.states,
                     text.count(b"\n") - lines0, len(text) - bytes0,
                     (_size(events) - run0) if events is not None else 0)
    finally:
        context.destroy(linger=0)
