"""The manager's Vicon provider on a real UDP socket on 127.0.0.1, polled by zmq.Poller."""
from __future__ import annotations

import socket
import struct
import time
from typing import Iterator, List

import pytest
import zmq

from fleet_common.lab import lab_transforms
from fleet_common.robots import parse_robot_definitions
from fleet_common.vicon import ViconObject, encode_frame
from fleet_common.vicon.base_grid import ViconFix, vicon_to_base
from fleet_manager.vicon_provider import ViconProvider

ROBOTS = parse_robot_definitions(
    "1 127.0.0.1 10001 u turtlebot1 red\n2 127.0.0.1 10002 u turtlebot2 blue\n")


class Clock:
    def __init__(self) -> None:
        self.now = 100.0

    def __call__(self) -> float:
        return self.now


@pytest.fixture
def clock() -> Clock:
    return Clock()


@pytest.fixture
def provider(clock: Clock) -> Iterator[ViconProvider]:
    p = ViconProvider(ROBOTS, vicon_to_base(lab_transforms()), port=0, bind="127.0.0.1",
                      stale_after=0.5, clock=clock)
    yield p
    p.close()


@pytest.fixture
def sender() -> Iterator[socket.socket]:
    s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    yield s
    s.close()


def wait_for(provider: ViconProvider, packets: int) -> List[ViconFix]:
    """Poll like the manager does until `packets` more datagrams were read (at most 5 s)."""
    poller = zmq.Poller()
    poller.register(provider, zmq.POLLIN)
    target = provider.counters.packets + packets
    fixes: List[ViconFix] = []
    deadline = time.monotonic() + 5.0
    while provider.counters.packets < target and time.monotonic() < deadline:
        if poller.poll(100):
            fixes += provider.handle_readable()
    return fixes


def at_cell(name: str, x: float, y: float, yaw: float = 0.0) -> ViconObject:
    # the lab's nominal transform: cell (x, y) is at (700 x + 700, 700 y + 2100) mm
    return ViconObject(name, (700.0 * x + 700.0, 700.0 * y + 2100.0, 400.0), (0.0, 0.0, yaw))


def test_robots_are_found_by_vicon_name_and_placed_on_cells(
        provider: ViconProvider, sender: socket.socket) -> None:
    objects = [at_cell("turtlebot2", 3.0, 4.5, 1.0), at_cell("turtlebot1", 1.0, 8.0),
               at_cell("wand", 0.0, 0.0)]
    for data in encode_frame(10, objects, 256):
        sender.sendto(data, provider.address)
    fixes = wait_for(provider, 1)
    assert sorted(f.robot_id for f in fixes) == [1, 2]
    two = provider.poses()[2]
    assert (two.pose.x, two.pose.y, two.pose.theta) == pytest.approx((3.0, 4.5, 1.0))
    assert (two.frame, two.age, two.stale, two.name) == (10, 0.0, False, "turtlebot2")
    assert [f.name for f in provider.objects() if f.robot_id is None] == ["wand"]


def test_a_robot_not_seen_for_the_stale_time_is_stale(
        provider: ViconProvider, sender: socket.socket, clock: Clock) -> None:
    for number, names in ((1, ("turtlebot1", "turtlebot2")), (2, ("turtlebot1",))):
        for data in encode_frame(number, [at_cell(n, 1.0, 1.0) for n in names]):
            sender.sendto(data, provider.address)
        wait_for(provider, 1)
        clock.now += 0.3
    poses = provider.poses()
    assert (poses[1].stale, poses[2].stale) == (False, True)
    assert poses[2].age == pytest.approx(0.6) and poses[2].frame == 1


def test_bad_datagrams_are_counted_and_the_provider_keeps_going(
        provider: ViconProvider, sender: socket.socket) -> None:
    bad = [b"", b"hello", bytes(2000), struct.pack("<IB", 1, 1) + bytes(251),
           encode_frame(1, [at_cell("turtlebot1", 1, 1)], 256)[0][:-1]]
    for data in bad:
        sender.sendto(data, provider.address)
    assert wait_for(provider, len(bad)) == []
    assert provider.counters.rejected == {"size": 4, "item-size": 1}
    sender.sendto(encode_frame(2, [at_cell("turtlebot1", 1, 1)])[0], provider.address)
    assert [f.robot_id for f in wait_for(provider, 1)] == [1]


def test_datagrams_from_other_hosts_are_refused_when_sources_are_given(
        sender: socket.socket, clock: Clock) -> None:
    for sources, expected in ((["127.0.0.1"], [1]), (["192.0.2.7"], [])):
        p = ViconProvider(ROBOTS, vicon_to_base(lab_transforms()), port=0, bind="127.0.0.1",
                          sources=sources, clock=clock)
        try:
            sender.sendto(encode_frame(1, [at_cell("turtlebot1", 1, 1)])[0], p.address)
            assert [f.robot_id for f in wait_for(p, 1)] == expected
            assert p.counters.rejected == ({} if expected else {"source": 1})
        finally:
            p.close()
