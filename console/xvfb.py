"""A private X server (Xvfb) for rendering without a screen.

`--screenshot` on a machine without a display, and the tests, start one with
`Xvfb.start()`: Xvfb picks a free display number itself (`-displayfd`), so
parallel runs never collide; it listens on no TCP port, and `stop()` ends
exactly the process it started, by its pid.
"""
from __future__ import annotations

import os
import select
import shutil
import subprocess
from typing import Optional

from fleet_common.errors import FleetError
from fleet_common.lifetime import die_with_parent

START_TIMEOUT = 10.0


class Xvfb:
    """A running Xvfb; `display` is its DISPLAY value (":N")."""

    def __init__(self, process: "subprocess.Popen[bytes]", display: str) -> None:
        self.process = process
        self.display = display

    @property
    def pid(self) -> int:
        return self.process.pid

    @classmethod
    def start(cls, width: int = 1280, height: int = 1024) -> "Xvfb":
        exe = shutil.which("Xvfb")
        if exe is None:
            raise FleetError("Xvfb is not installed (Debian package 'xvfb'); it is needed to "
                             "render without a display")
        read_fd, write_fd = os.pipe()
        try:
            process = subprocess.Popen(
                [exe, "-displayfd", str(write_fd), "-screen", "0", "{}x{}x24".format(width, height),
                 "-nolisten", "tcp"],
                pass_fds=(write_fd,), stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                stderr=subprocess.DEVNULL, preexec_fn=die_with_parent)
        finally:
            os.close(write_fd)
        try:
            number = _read_display_number(read_fd, process)
        except BaseException:
            process.kill()
            process.wait()
            raise
        finally:
            os.close(read_fd)
        return cls(process, ":" + number)

    def stop(self) -> None:
        if self.process.poll() is None:
            self.process.terminate()
            try:
                self.process.wait(5)
            except subprocess.TimeoutExpired:
                self.process.kill()
                self.process.wait()

    def __enter__(self) -> "Xvfb":
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop()


def _read_display_number(fd: int, process: "subprocess.Popen[bytes]") -> str:
    data = b""
    while not data.endswith(b"\n"):
        ready, _, _ = select.select([fd], [], [], START_TIMEOUT)
        chunk = os.read(fd, 32) if ready else b""
        if not chunk:
            code: Optional[int] = process.poll()
            raise FleetError("Xvfb did not start ({})".format(
                "exit status {}".format(code) if code is not None else "no display number in time"))
        data += chunk
    return data.decode("ascii").strip()
