"""Live runs for tests: a virtual fleet, a manager and scripted consoles, as real processes on 127.0.0.1.

- `fleet_definitions(folder, n)`: robot_definitions.txt for n robots on 127.0.0.1, on
  command ports that are free now, and a free block of feedback ports;
- `Proc`: a command in its own process group, output to a log file, waited on by the
  lines it prints, stopped by its group id (SIGINT, then SIGKILL) whatever happens;
- `start_fleet` / `start_manager`: `fleetctl virtual-fleet` and `fleetctl manager`;
- `ScriptedConsole`: the console protocol over a real socket, no window: what a
  console sees (`state`, `scene`, `events`) and asks (`ask`).
"""
from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import Any, Callable, Dict, List, Optional, Sequence, Tuple

import zmq

from fleet_common.control import Answer
from fleet_common.lifetime import die_with_parent
from fleet_common.control.session import ConsoleSession
from fleet_common.transport.console_channel import ConsoleClient
from fleet_common.transport.curve_keys import load_console_keys
from helpers import free_port_block

COLOURS = ("red", "green", "blue", "orange", "magenta", "cyan", "brown", "purple")


def fleet_definitions(folder: Path, n: int) -> Tuple[Path, int, int]:
    """(definitions file, feedback base port, a free port for the console channel)."""
    block = free_port_block(2 * n + 1)
    lines = ["{} 127.0.0.1 {} tester tb{} {}\n".format(i + 1, block + i, i + 1, COLOURS[i % len(COLOURS)])
             for i in range(n)]
    path = folder / "robots.txt"
    path.write_text("".join(lines))
    return path, block + n, block + 2 * n


class Proc:
    """A process in its own group; `log` collects stdout and stderr."""

    def __init__(self, args: Sequence[str], log: Path, env: Optional[dict] = None) -> None:
        self.args = list(args)
        self.log = log
        self._out = open(log, "ab")
        self.popen = subprocess.Popen(self.args, stdout=self._out, stderr=subprocess.STDOUT,
                                      stdin=subprocess.DEVNULL, start_new_session=True, env=env,
                                      preexec_fn=die_with_parent)

    def text(self) -> str:
        return self.log.read_text(encoding="utf-8", errors="replace")

    def wait_line(self, pattern: str, timeout: float = 30.0) -> str:
        """The first output line matching `pattern`; AssertionError with the log if none in time."""
        deadline = time.monotonic() + timeout
        rx = re.compile(pattern)
        while time.monotonic() < deadline:
            for line in self.text().splitlines():
                if rx.search(line):
                    return line
            if self.popen.poll() is not None:
                break
            time.sleep(0.05)
        raise AssertionError("no line /{}/ in {:g} s (exit {}); output:\n{}".format(
            pattern, timeout, self.popen.poll(), self.text()[-4000:]))

    def wait(self, timeout: float) -> int:
        try:
            return self.popen.wait(timeout)
        except subprocess.TimeoutExpired:
            raise AssertionError("still running after {:g} s; output:\n{}".format(
                timeout, self.text()[-4000:])) from None

    def tail(self, lines: int = 40) -> str:
        return "\n".join(self.text().splitlines()[-lines:])

    def kill(self) -> None:
        """SIGKILL to the whole group, as a power cut: no goodbye."""
        self._signal(signal.SIGKILL)
        self.popen.wait(10)

    def stop(self, grace: float = 10.0) -> None:
        """SIGINT to the group, then SIGKILL; returns once every process of the group is gone
        (roslaunch's nodes outlive their leader for a moment), and every process started under
        it: roslaunch puts each node in a session of its own, out of the group's reach, and a
        node that hangs in its shutdown would outlive the test once roslaunch is killed."""
        group = self.popen.pid  # start_new_session: the group id is the leader's pid
        below = _descendants(group)
        for sig, wait in ((signal.SIGINT, grace), (signal.SIGKILL, 5.0)):
            if not _group_alive(group):
                break
            self._signal(sig)
            deadline = time.monotonic() + wait
            while time.monotonic() < deadline and (self.popen.poll() is None or _group_alive(group)):
                time.sleep(0.05)
        if self.popen.poll() is None:
            self.popen.wait(5)
        for pid, started in below:
            if _started(pid) == started:  # still that process, not a new one with its pid
                try:
                    os.kill(pid, signal.SIGKILL)
                except ProcessLookupError:
                    pass
        self._out.close()

    def _signal(self, sig: int) -> None:
        try:
            os.killpg(self.popen.pid, sig)
        except ProcessLookupError:
            pass


def _started(pid: int) -> Optional[str]:
    """The start time of process `pid` (None if it is gone): with the pid, names one process."""
    try:
        stat = Path("/proc/{}/stat".format(pid)).read_text()
    except OSError:
        return None
    return stat.rsplit(")", 1)[1].split()[19]


def _descendants(pid: int) -> List[Tuple[int, str]]:
    """(pid, start time) of every process below `pid`, children first."""
    parents: Dict[int, List[int]] = {}
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                fields = (entry / "stat").read_text().rsplit(")", 1)[1].split()
            except OSError:
                continue
            parents.setdefault(int(fields[1]), []).append(int(entry.name))
    found: List[Tuple[int, str]] = []
    todo = list(parents.get(pid, []))
    while todo:
        child = todo.pop(0)
        started = _started(child)
        if started is not None:
            found.append((child, started))
        todo.extend(parents.get(child, []))
    return found


def _group_alive(group: int) -> bool:
    try:
        os.killpg(group, 0)
    except ProcessLookupError:
        return False
    return True


def fleetctl_args(*args: object) -> List[str]:
    return [sys.executable, "-m", "fleetctl", *map(str, args)]


def start_fleet(folder: Path, definitions: Path, feedback: int, *extra: object,
                name: str = "fleet") -> Proc:
    proc = Proc(fleetctl_args("virtual-fleet", "--definitions", definitions, "--no-curve",
                              "--feedback-base", feedback, "--log-level", "warning", *extra),
                folder / "{}.log".format(name))
    proc.wait_line(r"^virtual fleet: ")
    return proc


def start_manager(folder: Path, plan: object, definitions: Path, bind_port: int, *extra: object,
                  name: str = "manager") -> Proc:
    return Proc(fleetctl_args("manager", plan, "--definitions", definitions, "--no-curve",
                              "--host", "127.0.0.1", "--bind", "tcp://127.0.0.1:{}".format(bind_port),
                              *extra), folder / "{}.log".format(name))


class ScriptedConsole:
    """A console without a window: the protocol over a real socket, driven by the test.

    A background thread keeps the session alive (frames in, heartbeats out, hello again
    when the manager forgot it), as a console's network thread does; the test reads
    what the console saw and asks through the methods below, under one lock."""

    def __init__(self, port: int, name: str = "test console", keys: Optional[Path] = None) -> None:
        self.context = zmq.Context()
        self.client = ConsoleClient(self.context, "tcp://127.0.0.1:{}".format(port),
                                    keys=None if keys is None else load_console_keys(keys))
        self.session = ConsoleSession(name, time.monotonic())
        self.answers: List[Tuple[Answer, Any]] = []
        self.lock = threading.Lock()
        self._outbox: List[bytes] = [self.session.hello(time.monotonic())]
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._serve, name="scripted-console", daemon=True)
        self._thread.start()

    @property
    def state(self):
        return self.session.state

    def _serve(self) -> None:
        while not self._stop.is_set():
            with self.lock:
                now = time.monotonic()
                for frame in self._outbox:
                    self.client.send(frame)
                self._outbox.clear()
                for frame in self.client.receive():
                    got = self.session.receive(frame, now)
                    if isinstance(got, tuple):
                        self.answers.append(got)
                if not self.session.connected and self.session.live.heartbeat_due(now):
                    self.client.send(self.session.hello(now))
                beat = self.session.heartbeat(now)
                if beat is not None:
                    self.client.send(beat)
            self.client.socket.poll(20)

    def pump(self, seconds: float = 0.05) -> None:
        """Let `seconds` pass (the thread keeps receiving)."""
        time.sleep(seconds)

    def wait_for(self, what: Callable[["ScriptedConsole"], Any], timeout: float = 30.0,
                 why: str = "") -> Any:
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            with self.lock:
                value = what(self)
            if value:
                return value
            time.sleep(0.02)
        raise AssertionError("console: not seen in {:g} s: {}; last state: {}".format(
            timeout, why or what, self.session.state and self.session.state.run))

    def ask(self, action: str, timeout: float = 10.0, based_on: Optional[int] = None,
            **args: Any) -> Answer:
        """Send a request (based on the newest version seen, or `based_on`); the answer."""
        with self.lock:
            request, frame = self.session.request(action, time.monotonic(), based_on, **args)
            self._outbox.append(frame)
        return self.wait_for(lambda c: next((a for a, r in c.answers if a.id == request.id), None),
                             timeout, "an answer to {}".format(action))

    def close(self) -> None:
        self._stop.set()
        self._thread.join(5)
        self.client.close()
        self.context.term()
