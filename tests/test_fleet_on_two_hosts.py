"""One fleet served from two hosts, as the lab's robots are: two `fleetctl virtual-fleet` processes in
two network namespaces, each serving a part of one definitions file, driven by one manager.

Each namespace is a host with its own address, joined to this one by a veth pair (private
addresses chosen here, in 10.77.0.0/16, free on this machine). The robots' lines name those
addresses and use the same command ports on both hosts; each process serves its robots
(`--robots`) on their own addresses (`--on-hosts`), and robots sharing a host count their
feedback ports up from 9980 among themselves, as real robots on one host would. The manager,
in this namespace, connects to every robot at its definitions address and runs a plan through
to the end. Namespaces and processes go again whatever happens (processes by their pid).
"""
from __future__ import annotations

import json
import math
import os
import re
import shutil
import subprocess
from contextlib import contextmanager
from pathlib import Path
from typing import Dict, Iterator, List, Tuple

import pytest

from helpers import fleetctl, free_port
from live import Proc, fleetctl_args

pytestmark = pytest.mark.slow

#: Robots per host; both hosts use the same command ports.
PER_HOST = 3
COMMAND_PORTS = (10001, 10002, 10003)
#: The plan: 6 agents crossing an open 8 x 4 map (rows y = 0 and y = 3 swap sides).
MAP = "height 4\nwidth 8\nmap\n" + "........\n" * 4
AGENTS = [(0, 0, 7, 3), (1, 0, 6, 3), (2, 0, 5, 3), (7, 3, 0, 0), (6, 3, 1, 0), (5, 3, 2, 0)]


def _ip(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run(["ip", *args], capture_output=True, text=True, timeout=20)


def _free_subnets(count: int) -> List[int]:
    """Third octets k of 10.77.k.0/24 that no route of this machine touches."""
    routes = _ip("-4", "route", "show", "table", "all").stdout
    used = {int(m) for m in re.findall(r"\b10\.77\.(\d+)\.", routes)}
    start = os.getpid() % 200  # tests running at once on this machine start apart
    free = [k for k in list(range(start, 250)) + list(range(1, start)) if k not in used]
    return free[:count]


@contextmanager
def two_hosts() -> Iterator[List[Tuple[str, str]]]:
    """Two network namespaces, each reachable from here at its own address: (namespace, address)."""
    names = ["fc{}h{}".format(os.getpid() % 100000, i) for i in range(2)]
    if shutil.which("ip") is None:
        pytest.skip("network namespaces cannot be made here: no `ip` command (iproute2)")
    made = _ip("netns", "add", names[0])
    if made.returncode != 0:
        pytest.skip("network namespaces cannot be created here (`ip netns add`: {})".format(
            made.stderr.strip() or made.returncode))
    try:
        assert _ip("netns", "add", names[1]).returncode == 0
        hosts = []
        for name, k in zip(names, _free_subnets(2)):
            here, there = name + "a", name + "b"
            for args in (("link", "add", here, "type", "veth", "peer", "name", there, "netns", name),
                         ("addr", "add", "10.77.{}.1/24".format(k), "dev", here),
                         ("link", "set", here, "up"),
                         ("-n", name, "addr", "add", "10.77.{}.2/24".format(k), "dev", there),
                         ("-n", name, "link", "set", there, "up"),
                         ("-n", name, "link", "set", "lo", "up")):
                done = _ip(*args)
                assert done.returncode == 0, "ip {}: {}".format(" ".join(args), done.stderr)
            hosts.append((name, "10.77.{}.2".format(k)))
        yield hosts
    finally:
        for name in names:
            _ip("link", "del", name + "a")  # one end of a veth pair takes the other with it
            _ip("netns", "del", name)
        left = _ip("netns", "list").stdout + _ip("link", "show").stdout
        assert not any(name in left for name in names), left


def _files(folder: Path, addresses: List[str]) -> Tuple[Path, Path]:
    (folder / "open.map").write_text(MAP)
    instance = folder / "crossing.txt"
    instance.write_text("map_file=open.map\nagents={}\nseed=0\nrandom_problem=0\nmax_timestep=100\n"
                        "max_comp_time=10000\n".format(len(AGENTS))
                        + "".join("{},{},{},{}\n".format(*a) for a in AGENTS))
    lines = []
    for host, address in enumerate(addresses):
        for k, port in enumerate(COMMAND_PORTS):
            robot = host * PER_HOST + k + 1
            lines.append("{} {} {} tester tb{} {}\n".format(robot, address, port, robot, "red"))
    definitions = folder / "robots.txt"
    definitions.write_text("".join(lines))
    return definitions, instance


def _last_poses(truth: Path) -> Dict[int, Tuple[float, float]]:
    last: Dict[int, Tuple[float, float]] = {}
    for line in truth.read_text().splitlines():
        record = json.loads(line)
        if record.get("k") == "poses":
            last = {r: (x, y) for r, x, y, _ in record["p"]}
    return last


def test_one_fleet_from_two_hosts_runs_a_plan_to_the_end(tmp_path: Path) -> None:
    assert fleetctl("keys", "--dir", tmp_path / "keys").returncode == 0
    with two_hosts() as hosts:
        definitions, instance = _files(tmp_path, [address for _, address in hosts])
        fleets: List[Proc] = []
        manager = None
        try:
            for host, (namespace, address) in enumerate(hosts):
                ids = "{}-{}".format(host * PER_HOST + 1, (host + 1) * PER_HOST)
                fleets.append(Proc(["ip", "netns", "exec", namespace] + fleetctl_args(
                    "virtual-fleet", "--definitions", definitions, "--robots", ids, "--on-hosts",
                    "--keys", tmp_path / "keys", "--instance", instance, "--time-scale", "10",
                    "--truth", tmp_path / "truth{}.jsonl".format(host), "--log-level", "warning"),
                    tmp_path / "fleet{}.log".format(host)))
            for (_, address), fleet, ids in zip(hosts, fleets, ("1-3", "4-6")):
                banner = fleet.wait_line(r"^virtual fleet: ")
                # its robots on its own address, with the ports robots sharing a host have
                assert banner.startswith("virtual fleet: 3 robots ({} of 6) on {}, command ports 10001..10003, "
                                         "feedback ports 9980..9982,".format(ids, address)), banner
            manager = Proc(fleetctl_args("manager", instance, "--definitions", definitions, "--keys",
                                         tmp_path / "keys", "--bind", "tcp://127.0.0.1:{}".format(free_port()),
                                         "--start", "--until-done", "--time-limit", "120", "--log",
                                         tmp_path / "runs", "--step-time", "0.25"),
                           tmp_path / "manager.log")
            assert manager.wait(180) == 0, manager.text()[-4000:]
        finally:
            for proc in ([manager] if manager is not None else []) + fleets:
                proc.stop()
    out = manager.text()
    assert re.search(r"^arrived: 6/6$", out, re.M), out[-3000:]
    assert re.search(r"^collisions: 0 \(pairs closer than 0.454 m\)$", out, re.M), out[-3000:]
    # what really happened, as each host saw its own robots: every one on its goal
    final: Dict[int, Tuple[float, float]] = {}
    for host in range(2):
        poses = _last_poses(tmp_path / "truth{}.jsonl".format(host))
        assert sorted(poses) == [host * PER_HOST + k + 1 for k in range(PER_HOST)]  # its own robots only
        final.update(poses)
    for robot, (_, _, gx, gy) in enumerate(AGENTS, 1):
        x, y = final[robot]
        assert math.hypot(x - gx, y - (3 - gy)) < 0.05, (robot, x, y)  # the file's y runs downwards
