"""Processes a command starts and must stop: each in its own process group, stopped by pid.

Used by the demo (`fleetctl demo`) and by sweeps' wire cells (`evaluation`), which both
start `fleetctl virtual-fleet` and `fleetctl manager`, so it sits below both of them.
`Child.start` runs `fleetctl ARGS` (this Python, `-m fleetctl`) in a new
session, so the terminal's Ctrl-C reaches only the parent, which then stops
its children in the order it chooses; `stop()` sends SIGINT to the child's
process group (the commands close cleanly on it), then SIGTERM, then SIGKILL,
each after a grace period, and waits for it. Never by name: other sessions on
the machine run the same programs.

A child also gets SIGTERM when the parent dies without stopping it (killed
outright: `fleet_common.lifetime`), so no helper outlives a killed demo.

Output goes to a log file, or is read line by line in a thread (`lines`),
with `on_line` called for each, so a chatty child never blocks on a full pipe.
"""
from __future__ import annotations

import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import Callable, Dict, List, Optional, Sequence

from fleet_common.lifetime import die_with_parent

__all__ = ["Child"]


class Child:
    def __init__(self, name: str, process: "subprocess.Popen[str]",
                 on_line: Optional[Callable[[str], None]] = None) -> None:
        self.name = name
        self.process = process
        self.lines: List[str] = []
        self.on_line = on_line
        self._reader: Optional[threading.Thread] = None
        if process.stdout is not None:
            self._reader = threading.Thread(target=self._read, name=name + "-output", daemon=True)
            self._reader.start()

    @classmethod
    def start(cls, name: str, args: Sequence[str], *, log: Optional[Path] = None,
              on_line: Optional[Callable[[str], None]] = None,
              env: Optional[Dict[str, str]] = None) -> "Child":
        """`fleetctl ARGS` in its own session; output to `log`, else read as lines."""
        return cls.spawn(name, [sys.executable, "-u", "-m", "fleetctl", *args], log=log, on_line=on_line,
                         env=env)

    @classmethod
    def spawn(cls, name: str, argv: Sequence[str], *, log: Optional[Path] = None,
              on_line: Optional[Callable[[str], None]] = None,
              env: Optional[Dict[str, str]] = None) -> "Child":
        """Any program `argv` in its own session, as `start` runs fleetctl."""
        out = open(log, "w") if log is not None else subprocess.PIPE
        try:
            process = subprocess.Popen(
                list(argv), stdin=subprocess.DEVNULL, stdout=out,
                stderr=subprocess.STDOUT, text=True, start_new_session=True, env=env,
                preexec_fn=die_with_parent)  # a parent killed outright takes its children along
        finally:
            if log is not None:
                out.close()  # type: ignore[union-attr]
        return cls(name, process, on_line)

    @property
    def pid(self) -> int:
        return self.process.pid

    def running(self) -> bool:
        return self.process.poll() is None

    def wait(self, timeout: float) -> Optional[int]:
        """The exit status, or None if still running after `timeout` seconds."""
        try:
            code = self.process.wait(timeout)
        except subprocess.TimeoutExpired:
            return None
        if self._reader is not None:
            self._reader.join(timeout=2.0)
        return code

    def stop(self, grace: float = 5.0) -> int:
        """Stop it (SIGINT, then SIGTERM, then SIGKILL to its group); its exit status."""
        for sig in (signal.SIGINT, signal.SIGTERM, signal.SIGKILL):
            if not self.running():
                break
            try:
                os.killpg(self.process.pid, sig)  # its own group: start_new_session made it leader
            except ProcessLookupError:
                break
            code = self.wait(grace)
            if code is not None:
                return code
        code = self.wait(grace)
        return code if code is not None else -9

    def wait_for_line(self, test: Callable[[str], bool], timeout: float) -> Optional[str]:
        """The first line (so far or within `timeout` s) for which `test` holds; None if the
        child ended or the time ran out first."""
        deadline = time.monotonic() + timeout
        seen = 0
        while True:
            for line in self.lines[seen:]:
                if test(line):
                    return line
            seen = len(self.lines)
            if not self.running() and (self._reader is None or not self._reader.is_alive()):
                return next((x for x in self.lines[seen:] if test(x)), None)
            if time.monotonic() >= deadline:
                return None
            time.sleep(0.05)

    def _read(self) -> None:
        assert self.process.stdout is not None
        for line in self.process.stdout:
            line = line.rstrip("\n")
            self.lines.append(line)
            if self.on_line is not None:
                self.on_line(line)
        self.process.stdout.close()
