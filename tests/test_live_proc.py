"""The test harness's process handle: stopping a process stops everything it started, even a
child in a session of its own that ignores Ctrl-C (as a roslaunch node hanging in its shutdown)."""
from __future__ import annotations

import os
import sys
import time
from pathlib import Path

from live import Proc

# a leader that starts, in a new session, a child that ignores SIGINT, then waits
LEADER = """
import os, signal, subprocess, sys, time
child = subprocess.Popen([sys.executable, "-c",
    "import signal, time; signal.signal(signal.SIGINT, signal.SIG_IGN); time.sleep(600)"],
    start_new_session=True)
print(child.pid, flush=True)
time.sleep(600)
"""


def alive(pid: int) -> bool:
    try:
        state = Path("/proc/{}/stat".format(pid)).read_text().rsplit(")", 1)[1].split()[0]
    except OSError:
        return False
    return state != "Z"


def test_stop_ends_a_child_that_left_the_group_and_ignores_ctrl_c(tmp_path: Path) -> None:
    proc = Proc([sys.executable, "-c", LEADER], tmp_path / "leader.log")
    child = int(proc.wait_line(r"^\d+$", 30))
    assert alive(child) and os.getpgid(child) != proc.popen.pid
    proc.stop(grace=1.0)
    for _ in range(100):  # SIGKILL is asynchronous; init reaps the orphan
        if not alive(child):
            break
        time.sleep(0.05)
    assert not alive(child)
