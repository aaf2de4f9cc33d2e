"""ViconStream: frames from packets, lost and late frames, restarts, staleness, base grid."""
from __future__ import annotations

import math
from typing import List

import pytest
from hypothesis import given
from hypothesis import strategies as st

from fleet_common.frames import similarity
from fleet_common.lab import lab_transforms
from fleet_common.vicon import ViconObject, ViconStream, encode_frame
from fleet_common.vicon.base_grid import (fix_of, from_base, load_vicon_to_base, to_base,
                                          vicon_to_base)
from fleet_common.limits import VICON_MAX_FRAME_GAP as MAX_FRAME_GAP
from fleet_common.wire.messages import Pose


def obj(name: str, x: float, y: float = 10.0, yaw: float = 0.0) -> ViconObject:
    return ViconObject(name, (x, y, 400.0), (0.0, 0.0, yaw))


def frame(number: int, *objects: ViconObject, block: int = 256) -> List[bytes]:
    return encode_frame(number, list(objects), block)


def feed(stream: ViconStream, packets: List[bytes], now: float = 0.0) -> List[str]:
    return [s.obj.name for p in packets for s in stream.receive(p, now)]


def test_gaps_in_frame_numbers_count_as_lost_frames() -> None:
    stream = ViconStream()
    for number in (10, 11, 14, 15, 20):
        feed(stream, frame(number, obj("a", number)))
    c = stream.counters
    assert (c.frames, c.frames_lost, c.late_packets, c.restarts) == (5, 6, 0, 0)
    assert stream.sightings["a"].frame == 20


def test_a_late_frame_is_taken_off_the_lost_count_but_never_moves_an_object_back() -> None:
    stream = ViconStream()
    feed(stream, frame(1, obj("a", 1.0), obj("b", 1.0)))
    feed(stream, frame(3, obj("a", 3.0)), now=1.0)
    assert stream.counters.frames_lost == 1
    # frame 2 arrives after frame 3: "a" keeps frame 3's pose, "b" (absent from 3) takes 2's
    assert feed(stream, frame(2, obj("a", 2.0), obj("b", 2.0)), now=2.0) == ["b"]
    assert stream.sightings["a"].obj.translation[0] == 3.0
    assert stream.sightings["b"].obj.translation[0] == 2.0
    c = stream.counters
    assert (c.frames, c.frames_lost, c.late_packets) == (3, 0, 1)


def test_a_duplicated_packet_changes_nothing() -> None:
    stream = ViconStream()
    packets = frame(5, obj("a", 1.0))
    assert feed(stream, packets, now=1.0) == ["a"]
    assert feed(stream, packets, now=2.0) == []
    assert stream.sightings["a"].received == 1.0
    assert (stream.counters.frames, stream.counters.packets) == (1, 2)


def test_packets_of_one_frame_in_any_order_give_every_object() -> None:
    objects = [obj("r{}".format(i), i + 1.0) for i in range(10)]
    packets = frame(42, *objects)  # 4 packets of 256 bytes
    assert len(packets) == 4
    stream = ViconStream()
    assert sorted(feed(stream, packets[::-1])) == sorted(o.name for o in objects)
    assert stream.counters.frames == 1 and stream.counters.frames_lost == 0


def test_a_big_jump_is_a_restart_not_millions_of_lost_frames() -> None:
    stream = ViconStream()
    feed(stream, frame(2 ** 32 - 5, obj("a", 1.0)))
    feed(stream, frame(3, obj("a", 2.0)))  # Tracker restarted (or wrapped round)
    assert stream.sightings["a"].obj.translation[0] == 2.0
    feed(stream, frame(3 + MAX_FRAME_GAP + 1, obj("a", 3.0)))
    c = stream.counters
    assert (c.restarts, c.frames_lost, c.frames) == (2, 0, 3)
    assert stream.sightings["a"].obj.translation[0] == 3.0


def test_a_spoofed_frame_number_never_shows_an_object_at_frame_minus_one() -> None:
    stream = ViconStream()
    feed(stream, frame(100, obj("a", 1.0), obj("b", 1.0)))
    feed(stream, frame(100 + MAX_FRAME_GAP + 7, obj("a", 2.0)))  # a spoofed (or restarted) count
    assert stream.counters.restarts == 1
    assert stream.sightings["b"].frame == 100  # b was not seen since: its frame, as it was
    assert stream.sightings["a"].frame == 100 + MAX_FRAME_GAP + 7
    assert all(s.frame >= 0 for s in stream.sightings.values())
    feed(stream, frame(101, obj("b", 3.0)))  # back to the real count: newer than what b had
    assert stream.sightings["b"].obj.translation[0] == 3.0 and stream.sightings["b"].frame == 101


def test_objects_beyond_the_limit_are_dropped_and_counted() -> None:
    stream = ViconStream(max_objects=3)
    feed(stream, frame(1, *[obj("r{}".format(i), 1.0) for i in range(5)]))
    assert sorted(stream.sightings) == ["r0", "r1", "r2"]
    assert stream.counters.dropped == {"too-many": 2}
    feed(stream, frame(2, obj("r1", 5.0)))  # the known ones still update
    assert stream.sightings["r1"].obj.translation[0] == 5.0


@given(st.lists(st.integers(0, 60), min_size=1, max_size=60))
def test_lost_frames_are_the_numbers_never_seen_between_first_and_newest(
        order: List[int]) -> None:
    stream = ViconStream()
    for number in order:
        feed(stream, frame(1000 + number, obj("a", 1.0 + number)))
    counted = {n for n in order if n >= order[0]}  # older than the first: late packets
    assert stream.counters.frames == len(counted)
    assert stream.counters.frames_lost == max(counted) - order[0] + 1 - len(counted)
    assert stream.sightings["a"].frame == 1000 + max(counted)


# ---- staleness and the base grid ----------------------------------------------------------

def test_an_object_not_seen_for_longer_than_the_limit_is_stale() -> None:
    stream = ViconStream()
    feed(stream, frame(1, obj("a", 700.0, 2100.0)), now=10.0)
    to_base_t = vicon_to_base(lab_transforms())
    fresh = fix_of(to_base_t, stream.sightings["a"], now=10.4, stale_after=0.5)
    stale = fix_of(to_base_t, stream.sightings["a"], now=10.6, stale_after=0.5)
    assert not fresh.stale and stale.stale
    assert stale.age == pytest.approx(0.6) and stale.frame == 1
    assert (stale.pose.x, stale.pose.y) == pytest.approx((0.0, 0.0), abs=1e-12)


def test_the_lab_frames_file_places_vicon_millimetres_on_cells() -> None:
    t = load_vicon_to_base()
    # nominal lab transform: Vicon mm = robot-frame metres x 1000 (cell (1, 8) at 1.4, 7.7 m)
    pose = to_base(t, ViconObject("r", (1400.0, 7700.0, 400.0), (0.0, 0.0, math.pi / 2)))
    assert (pose.x, pose.y, pose.theta) == pytest.approx((1.0, 8.0, math.pi / 2))


@given(st.floats(0.1, 10.0), st.floats(-math.pi, math.pi), st.floats(-5e3, 5e3),
       st.floats(-5e3, 5e3), st.floats(-20.0, 20.0), st.floats(-20.0, 20.0),
       st.floats(-3.0, 3.0))
def test_from_base_then_to_base_gives_the_pose_back(scale: float, angle: float, tx: float,
                                                    ty: float, x: float, y: float,
                                                    theta: float) -> None:
    base_to_vicon = similarity(scale * 700.0, angle, tx, ty, "base", "vicon")
    seen = from_base(base_to_vicon, "r", Pose(x, y, theta))
    back = to_base(base_to_vicon.inverse(), seen)
    assert (back.x, back.y) == pytest.approx((x, y), abs=1e-6)
    assert math.cos(back.theta - theta) == pytest.approx(1.0, abs=1e-9)
