"""`fleetctl vicon listen` and `simulate` as lab staff run them."""
from __future__ import annotations

import signal
import socket
import subprocess
import sys
from typing import Iterator

import pytest

from helpers import fleetctl, free_port


@pytest.fixture
def simulator() -> Iterator[int]:
    """`fleetctl vicon simulate --demo circle` streaming to a free port, robot 3 occluded."""
    port = free_port()
    proc = subprocess.Popen([sys.executable, "-m", "fleetctl", "vicon", "simulate", "--demo",
                             "circle", "--port", str(port), "--block-size", "256", "--loss",
                             "0.2", "--occlude", "turtlebot3", "--for", "60"],
                            stdout=subprocess.PIPE, text=True)
    try:
        assert proc.stdout.readline().startswith("simulated Tracker: ")  # sending from now on
        yield port
    finally:
        proc.send_signal(signal.SIGINT)
        out, _ = proc.communicate(timeout=10)
        assert proc.returncode == 0 and "simulated Tracker stopped:" in out


def test_listen_prints_each_robot_its_age_and_the_counters(simulator: int) -> None:
    done = fleetctl("vicon", "listen", "--port", simulator, "--bind", "127.0.0.1", "--for", "1.5")
    assert done.returncode == 0, done.stderr
    lines = done.stdout.splitlines()
    assert lines[0].startswith("UDP 127.0.0.1:{} after".format(simulator))
    rows = {line.split()[0]: line.split() for line in lines[2:] if line.startswith("turtlebot")}
    assert sorted(rows) == ["turtlebot1", "turtlebot2", "turtlebot4", "turtlebot5"]
    assert [rows[n][1] for n in sorted(rows)] == ["1", "2", "4", "5"]
    assert all(0.0 <= float(r[2]) <= 13.0 and 0.0 <= float(r[3]) <= 14.0 for r in rows.values())
    assert "never seen: turtlebot3" in done.stdout
    counters = lines[-1]
    assert counters.startswith("counters: ") and "rejected: none" in counters
    assert " lost," in counters


def test_listen_until_ctrl_c_prints_every_interval(simulator: int) -> None:
    proc = subprocess.Popen([sys.executable, "-m", "fleetctl", "vicon", "listen", "--port",
                             str(simulator), "--bind", "127.0.0.1", "--every", "0.2"],
                            stdout=subprocess.PIPE, text=True)
    try:
        first = [proc.stdout.readline() for _ in range(2)]
    finally:
        proc.send_signal(signal.SIGINT)
        proc.wait(timeout=10)
    rest = proc.stdout.read()
    assert proc.returncode == 0
    assert first[0].startswith("UDP 127.0.0.1:{} after".format(simulator))
    assert first[1].split() == ["object", "robot", "x", "y", "heading", "frame", "age"]
    assert rest.rstrip().splitlines()[-1].startswith("counters: ")


def test_listen_to_nothing_says_so_and_exits_0() -> None:
    done = fleetctl("vicon", "listen", "--port", free_port(), "--bind", "127.0.0.1",
                    "--for", "0.3")
    assert done.returncode == 0
    assert "nothing received on UDP 127.0.0.1:" in done.stdout


def test_listen_on_a_port_in_use_is_one_line() -> None:
    taken = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    taken.bind(("127.0.0.1", 0))
    try:
        done = fleetctl("vicon", "listen", "--port", taken.getsockname()[1], "--bind",
                        "127.0.0.1", "--for", "0.3")
    finally:
        taken.close()
    assert done.returncode == 2 and "cannot listen on UDP 127.0.0.1:" in done.stderr
    assert len(done.stderr.strip().splitlines()) == 1


@pytest.mark.parametrize("args, fragment", [
    (["--rate", "150"], "at most 100 Hz"),
    (["--loss", "1"], "a probability 0 <= P < 1"),
    (["--noise", "-2"], "a number >= 0"),
    (["--occlude", "3:5-2"], "expected ROBOT or ROBOT:FROM-TO"),
    (["--block-size", "300"], "invalid choice"),
    (["--occlude", "robot9"], "no robot 'robot9': expected a robot id or Vicon name"),
])
def test_simulate_refuses_what_tracker_cannot_do(args: list, fragment: str) -> None:
    done = fleetctl("vicon", "simulate", "--demo", "still", "--port", free_port(), "--for", "0.2",
                    *args)
    assert done.returncode == 2 and fragment in done.stderr, done.stderr
    assert "Traceback" not in done.stderr
