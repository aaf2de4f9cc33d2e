"""`fleetctl virtual-fleet` and `fleetctl keys` as a user runs them: real processes, real ports."""
from __future__ import annotations

import os
import signal
import stat
import subprocess
import sys
import time
from pathlib import Path
from typing import Iterator, List

import pytest
import zmq

from fleet_common.robots import read_robot_definitions
from fleet_common.wire import Completed
from fleet_common.transport.curve_keys import load_manager_keys
from fleet_common.transport.links import LinkSet
from fleet_common.transport.robot_link import RobotLink, RobotReply
from helpers import fleetctl, free_port_block, free_ports, virtual_fleet_process






def test_keys_are_made_once_with_private_secrets(tmp_path: Path) -> None:
    folder = tmp_path / "keys"
    made = fleetctl("keys", "--dir", folder)
    assert made.returncode == 0, made.stderr
    names = sorted(p.name for p in folder.iterdir())
    assert names == ["console.key", "console.key_secret", "manager.key", "manager.key_secret",
                     "robot.key", "robot.key_secret"]
    for name in ("console.key_secret", "manager.key_secret", "robot.key_secret"):
        assert stat.S_IMODE((folder / name).stat().st_mode) == 0o600
    before = (folder / "manager.key").read_bytes()
    again = fleetctl("keys", "--dir", folder)
    assert again.returncode == 2
    assert "already has keys" in again.stderr and "--force" in again.stderr
    assert (folder / "manager.key").read_bytes() == before
    assert fleetctl("keys", "--dir", folder, "--force").returncode == 0
    assert (folder / "manager.key").read_bytes() != before


def test_a_key_folder_from_before_consoles_gets_the_console_pair_added(tmp_path: Path) -> None:
    folder = tmp_path / "keys"
    assert fleetctl("keys", "--dir", folder).returncode == 0
    manager = (folder / "manager.key_secret").read_bytes()
    for name in ("console.key", "console.key_secret"):
        (folder / name).unlink()
    again = fleetctl("keys", "--dir", folder)
    assert again.returncode == 0, again.stderr
    assert (folder / "console.key_secret").is_file()
    assert (folder / "manager.key_secret").read_bytes() == manager  # the robots' keys are kept


def test_keys_go_to_the_folder_named_by_the_environment(tmp_path: Path) -> None:
    env = dict(os.environ, FLEETCONTROL_KEYS=str(tmp_path / "env-keys"))
    assert fleetctl("keys", env=env).returncode == 0
    assert (tmp_path / "env-keys" / "robot.key_secret").is_file()


@pytest.fixture
def fleet_files(tmp_path: Path) -> Path:
    ports = free_ports(3)
    (tmp_path / "robots.txt").write_text("".join(
        "{}  192.168.2.{}  {}  turtlebot  tb{}  red\n".format(i, 10 + i, port, i)
        for i, port in enumerate(ports, 1)))
    assert fleetctl("keys", "--dir", tmp_path / "keys").returncode == 0
    return tmp_path


@pytest.fixture
def running_fleet(fleet_files: Path) -> Iterator[subprocess.Popen]:
    feedback = free_port_block(3)
    with virtual_fleet_process(fleet_files / "robots.txt", fleet_files / "keys", feedback,
                               "warning") as proc:
        yield proc


def test_virtual_fleet_serves_every_robot_and_stops_on_ctrl_c(fleet_files: Path,
                                                               running_fleet) -> None:
    banner = running_fleet.stdout.readline()
    assert banner.startswith("virtual fleet: 3 robots on 127.0.0.1"), banner
    assert "CURVE on" in banner
    robots = read_robot_definitions(fleet_files / "robots.txt")
    context = zmq.Context()
    links = LinkSet([RobotLink(context, r, "cli-test", host="127.0.0.1",
                               keys=load_manager_keys(fleet_files / "keys")) for r in robots])
    try:
        ids = {r.id: links[r.id].turn(1.0) for r in robots}
        done = set()
        deadline = time.monotonic() + 15
        while done != set(ids):
            assert time.monotonic() < deadline and running_fleet.poll() is None
            for ev in links.poll(0.05):
                if isinstance(ev, RobotReply) and ev.reply == Completed(ids[ev.robot_id]):
                    done.add(ev.robot_id)
    finally:
        links.close()
        context.destroy(linger=0)
    running_fleet.send_signal(signal.SIGINT)
    assert running_fleet.wait(timeout=10) == 0
    assert "virtual fleet stopped" in running_fleet.stdout.read()
    assert "Traceback" not in running_fleet.stderr.read()


def test_two_processes_serve_one_fleet_each_robot_on_its_own_ports(fleet_files: Path) -> None:
    path = fleet_files / "robots.txt"
    path.write_text(path.read_text() + "4 192.168.2.14 {} turtlebot tb4 red\n".format(free_ports(1)[0]))
    feedback = free_port_block(4)
    fleets = []
    for ids in ("1,2", "3-4"):
        fleets.append(subprocess.Popen(
            [sys.executable, "-m", "fleetctl", "virtual-fleet", "--definitions", str(path), "--robots", ids,
             "--keys", str(fleet_files / "keys"), "--time-scale", "10", "--feedback-base", str(feedback),
             "--log-level", "warning"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True))
    context = zmq.Context()
    links = None
    try:
        banners = [f.stdout.readline() for f in fleets]
        robots = read_robot_definitions(path)
        # the ports of the whole file: the second process's robots come after the first's
        assert banners[0].startswith("virtual fleet: 2 robots (1-2 of 4) on 127.0.0.1, command ports {}..{}, "
                                     "feedback ports {}..{},".format(robots[0].command_port, robots[1].command_port,
                                                                     feedback, feedback + 1)), banners
        assert banners[1].startswith("virtual fleet: 2 robots (3-4 of 4) on 127.0.0.1, command ports {}..{}, "
                                     "feedback ports {}..{},".format(robots[2].command_port, robots[3].command_port,
                                                                     feedback + 2, feedback + 3)), banners
        links = LinkSet([RobotLink(context, r, "split-test", host="127.0.0.1",
                                   keys=load_manager_keys(fleet_files / "keys")) for r in robots])
        ids = {r.id: links[r.id].turn(1.0) for r in robots}
        done = set()
        deadline = time.monotonic() + 15
        while done != set(ids):  # one fleet: every robot answers, whichever process serves it
            assert time.monotonic() < deadline and all(f.poll() is None for f in fleets), done
            for ev in links.poll(0.05):
                if isinstance(ev, RobotReply) and ev.reply == Completed(ids[ev.robot_id]):
                    done.add(ev.robot_id)
    finally:
        if links is not None:
            links.close()
        context.destroy(linger=0)
        for f in fleets:
            f.kill()
            f.wait(timeout=10)
            f.stdout.close()
            f.stderr.close()


@pytest.mark.parametrize("args, message", [
    (["--robots", "1-"], "argument --robots: expected robot ids and ranges separated by commas, e.g. 1-150,300, "
                         "got '1-' in '1-'"),
    (["--robots", "7"], "robots.txt: robot 7 is not defined (this file defines 1-3)"),
    (["--robots", "1", "--stall", "2:1:1"], "--stall names robot 2, which this fleet does not serve (--robots)"),
])
def test_a_part_of_the_fleet_that_cannot_be_served_is_one_line(fleet_files: Path, args: List[str],
                                                               message: str) -> None:
    proc = fleetctl("virtual-fleet", "--definitions", fleet_files / "robots.txt", "--no-curve", *args)
    assert proc.returncode == 2
    assert len(proc.stderr.strip().splitlines()) == 1 and message in proc.stderr, proc.stderr


@pytest.mark.parametrize("args, message", [
    (["--delay-model", "wobble=1"], "delay model 'wobble=1': unknown term 'wobble=1'; expected factor="),
    (["--keys", "{tmp}/nokeys"], "robot.key_secret not found: make the keys with `fleetctl keys"),
    (["--no-curve", "--paired"], "--paired needs --instance PLAN"),
    (["--no-curve", "--paired", "--instance", "{lab}"], "--paired needs --instance to be a plan"),
])
def test_virtual_fleet_errors_are_one_line(tmp_path: Path, args: List[str], message: str) -> None:
    from fleet_common.lab import lab_instance_path

    proc = fleetctl("virtual-fleet", *[a.format(tmp=tmp_path, lab=lab_instance_path()) for a in args])
    assert proc.returncode == 2
    assert len(proc.stderr.strip().splitlines()) == 1 and message in proc.stderr
    if "keys" in message:
        assert "--no-curve" in proc.stderr


def test_virtual_fleet_names_the_definitions_line_of_a_port_clash(tmp_path: Path) -> None:
    path = tmp_path / "robots.txt"
    path.write_text("1 10.0.0.1 10001 u a red\n# comment\n2 10.0.0.2 10001 u b red\n")
    proc = fleetctl("virtual-fleet", "--definitions", path, "--no-curve")
    assert proc.returncode == 2
    assert proc.stderr.strip() == ("{}:3: robots 1 and 2 both use command port 10001; on one "
                                   "host (127.0.0.1) every robot needs its own".format(path))
