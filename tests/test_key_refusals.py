"""Every refused CURVE handshake leaves one clear line on the side that refused and the side that tried.

Consoles against a manager with keys (no key, a client key it was not given,
the wrong manager public key), and a manager against virtual robots that
hold another key set (our key refused, their public key wrong, no keys on
our side): real processes on 127.0.0.1, each retrying many times (libzmq
reconnects by itself), each logged once per peer (then counted, a minute
later). A manager that cannot start for it says so after its timeout.
Secret key files others may read are refused with the chmod to run.
"""
from __future__ import annotations

import logging
import os
import shutil
import time
from pathlib import Path
from typing import Dict, List, Optional, Tuple

import pytest
import zmq

from fleet_common.errors import FleetError
from fleet_common.lab import lab_instance_path
from fleet_common.ratelimit import RateLimitedLog
from fleet_common.transport.console_channel import ConsoleClient
from fleet_common.transport.curve_keys import ConsoleKeys, load_console_keys, load_manager_keys, make_keys
from fleet_common.transport.zap import ZapHandler
from live import Proc, fleet_definitions, fleetctl_args

pytestmark = pytest.mark.slow


def key_sets(tmp_path: Path) -> Dict[str, Path]:
    """The lab's keys (a), another set (b), and folders mixing them."""
    a, b = tmp_path / "a", tmp_path / "b"
    make_keys(a)
    make_keys(b)
    mixed = {"a": a, "b": b}
    for name, parts in (("their-key", {"manager": b, "robot": a, "console": a}),     # our key is b's
                        ("wrong-robot", {"manager": a, "robot": b, "console": a})):  # their public key
        folder = tmp_path / name
        folder.mkdir(mode=0o700)
        for who, source in parts.items():
            for suffix in (".key", ".key_secret"):
                if (source / (who + suffix)).exists():
                    shutil.copy2(source / (who + suffix), folder / (who + suffix))
        mixed[name] = folder
    return mixed


def count(text: str, needle: str) -> int:
    return sum(needle in line for line in text.splitlines())


# ---- consoles: the manager refuses, the console tried ------------------------------------------

def console_tries(port: int, keys, seconds: float = 3.0) -> Tuple[Optional[str], int]:
    """A console that keeps trying for `seconds`, a new connection every 0.3 s as the live console
    makes one for each hello: the problem its last connection saw, and how many failed."""
    context = zmq.Context.instance()
    end = time.monotonic() + seconds
    problem, failures = None, 0
    while time.monotonic() < end:
        client = ConsoleClient(context, "tcp://127.0.0.1:{}".format(port), keys=keys)
        try:
            until = time.monotonic() + 0.3
            while time.monotonic() < until:
                client.receive()
                time.sleep(0.02)
            problem, failures = client.problem, failures + client.handshake.failures
        finally:
            client.close()
    return problem, failures


def test_consoles_without_the_right_keys_are_logged_once_on_both_sides(tmp_path: Path, caplog) -> None:
    keys = key_sets(tmp_path)
    definitions, _, port = fleet_definitions(tmp_path, 5)
    manager = Proc(fleetctl_args("manager", lab_instance_path(), "--definitions", definitions,
                                 "--keys", keys["a"], "--host", "127.0.0.1", "--no-log",
                                 "--bind", "tcp://127.0.0.1:{}".format(port)), tmp_path / "manager.log")
    a, b = load_console_keys(keys["a"]), load_console_keys(keys["b"])
    cases = [
        ("none", None, "refused a client without a CURVE key", "and we run without (--no-curve)"),
        ("client key", ConsoleKeys(b.public, b.secret, a.manager_public),
         "consoles: refused a connection from 127.0.0.1 with key",
         "refused our key (status 400): console.key_secret is not a key it was given"),
        ("server key", ConsoleKeys(a.public, a.secret, b.manager_public),
         "refused a client that does not have this manager's public key",
         "manager.key is probably not its public key"),
    ]
    caplog.set_level(logging.WARNING, logger="fleet_console")
    try:
        manager.wait_line(r"^manager: ")
        for name, console_keys, manager_line, console_line in cases:
            caplog.clear()
            problem, failures = console_tries(port, console_keys)
            assert problem is not None and console_line in problem, (name, problem)
            assert failures >= 5, "it should have tried again and again"
            assert count(caplog.text, console_line) == 1, (name, caplog.text)
            deadline = time.monotonic() + 5
            while count(manager.text(), manager_line) < 1 and time.monotonic() < deadline:
                time.sleep(0.05)
            assert count(manager.text(), manager_line) == 1, (name, manager.text()[-3000:])
        assert console_tries(port, a, 1.0) == (None, 0)
    finally:
        manager.stop()
    assert "not the manager key" not in manager.text()  # consoles offer console keys
    assert "not the console key (console.key) it was given" in manager.text()


def test_a_zap_refusal_flood_from_one_address_is_one_line_and_a_count() -> None:
    lines: List[str] = []

    class Capture(logging.Handler):
        def emit(self, record: logging.LogRecord) -> None:
            lines.append(record.getMessage())

    log = logging.getLogger("test-zap-flood")
    log.propagate = False
    log.addHandler(Capture())
    clock = [0.0]
    context = zmq.Context()
    try:
        zap = ZapHandler(context, log, lambda: clock[0])
        zap.allow("consoles", [zmq.curve_keypair()[0]], "the console key")
        for _ in range(10_000):  # a new key each time, from one address
            key = os.urandom(32)
            answer = zap._answer([b"1.0", b"1", b"consoles", b"10.0.0.66", b"", b"CURVE", key])
            assert answer[2] == b"400"
        assert len(lines) == 1 and "refused a connection from 10.0.0.66" in lines[0]
        clock[0] = 61.0
        zap.flush()
        assert lines[1] == "9,999 more refused connections from 10.0.0.66 to consoles in the last 60 s"
    finally:
        context.destroy(linger=0)
    assert isinstance(zap.refusals, RateLimitedLog)


# ---- robots: the robot refuses, the manager tried ----------------------------------------------

@pytest.mark.parametrize("case", ["their-key", "wrong-robot", "no-curve"])
def test_robots_refusing_the_managers_keys_are_logged_on_both_sides_and_said_at_the_timeout(
        tmp_path: Path, case: str) -> None:
    keys = key_sets(tmp_path)
    definitions, feedback, port = fleet_definitions(tmp_path, 5)
    fleet = Proc(fleetctl_args("virtual-fleet", "--definitions", definitions, "--keys", keys["a"],
                               "--feedback-base", feedback, "--log-level", "warning"), tmp_path / "fleet.log")
    manager_keys = ["--no-curve"] if case == "no-curve" else ["--keys", keys[case]]
    try:
        fleet.wait_line(r"^virtual fleet: ")
        manager = Proc(fleetctl_args("manager", lab_instance_path(), "--definitions", definitions,
                                     *manager_keys, "--host", "127.0.0.1", "--no-log", "--start",
                                     "--connect-timeout", "4", "--bind", "tcp://127.0.0.1:{}".format(port)),
                       tmp_path / "manager.log")
        try:
            assert manager.wait(60) == 1
        finally:
            manager.stop()
    finally:
        fleet.stop()
    tried, refused = manager.text(), fleet.text()
    said = {
        "their-key": ("refused our key (status 400): manager.key is not a key it was given",
                      "refused a connection from 127.0.0.1 with key"),
        "wrong-robot": ("the CURVE handshake with robot {} failed: robot.key is probably not its public key",
                        "robot {}: refused a client that does not have this robot's public key"),
        "no-curve": ("robot {} ", "robot {}: refused a client"),
    }[case]
    logged = "\n".join(line for line in tried.splitlines() if " WARNING " in line)
    for robot in range(1, 6):
        manager_line, robot_line = (s.format(robot) for s in said)
        manager_line = manager_line if "{}" in said[0] else "robot {} {}".format(robot, manager_line)
        assert count(logged, manager_line) == 1, (robot, tried[-3000:])
        assert count(tried, "robot {} link down: ".format(robot)) <= 1  # and said once to the consoles
        assert count(refused, robot_line if "{}" in said[1] else "robot {}: {}".format(robot, robot_line)) == 1, \
            (robot, refused[-3000:])
    assert "cannot start after 4 s: not connected: robots 1, 2, 3, 4, 5 (" in tried
    assert "no summary: the run never started" in tried and "executed makespan" not in tried


def test_a_secret_key_others_may_read_is_refused_with_the_chmod_to_run(tmp_path: Path) -> None:
    make_keys(tmp_path)
    secret = tmp_path / "manager.key_secret"
    os.chmod(secret, 0o644)
    with pytest.raises(FleetError) as refused:
        load_manager_keys(tmp_path)
    assert "may be read by others (mode 0644)" in str(refused.value)
    assert "run `chmod 600 {}`".format(secret) in str(refused.value)
    os.chmod(secret, 0o600)
    assert load_manager_keys(tmp_path).secret
