"""Tracker's UDP Object Stream: packets built byte by byte here, decoded by fleet_common.vicon.

The layout is written out again in this file with struct (not taken from the
decoder), so a decoder that misreads the layout fails here.
"""
from __future__ import annotations

import math
import struct
from typing import List, Optional, Sequence, Tuple

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from fleet_common.vicon import (ViconObject, ViconPacket, ViconPacketError, ViconStream,
                                decode_packet, encode_frame)

BLOCKS = (256, 512, 1024)
PER_PACKET = {256: 3, 512: 6, 1024: 13}  # (block - 5) // 75


def item(name: bytes, t: Sequence[float], r: Sequence[float] = (0.0, 0.0, 0.5),
         item_id: int = 0, size: int = 72) -> bytes:
    """One item: uint8 id, uint16 size, char[24] name, 6 float64, little-endian."""
    return (struct.pack("<BH", item_id, size) + name.ljust(24, b"\0")
            + struct.pack("<ddd", *t) + struct.pack("<ddd", *r))


def packet(frame: int, items: Sequence[bytes], block: int = 256,
           count: Optional[int] = None) -> bytes:
    body = struct.pack("<I", frame) + bytes([len(items) if count is None else count])
    return (body + b"".join(items)).ljust(block, b"\0")


def robot(i: int) -> Tuple[bytes, Tuple[float, float, float], Tuple[float, float, float]]:
    return ("turtlebot{}".format(i).encode(), (100.0 * i + 0.25, -50.0 * i - 1.5, 412.0),
            (0.01, -0.02, 0.1 * i))


@pytest.mark.parametrize("block", BLOCKS)
def test_one_object_in_each_block_size(block: int) -> None:
    data = packet(123456, [item(b"turtlebot1", (1500.5, -20.25, 410.0), (0.0, 0.1, 1.25))], block)
    assert len(data) == block
    got = decode_packet(data)
    assert got == ViconPacket(123456, (ViconObject("turtlebot1", (1500.5, -20.25, 410.0),
                                                   (0.0, 0.1, 1.25)),))


@pytest.mark.parametrize("block", BLOCKS)
def test_thirty_objects_split_over_the_packets_of_one_frame(block: int) -> None:
    per = PER_PACKET[block]
    items = [item(*robot(i)) for i in range(30)]
    packets = [packet(77, items[i:i + per], block) for i in range(0, 30, per)]
    assert len(packets) == math.ceil(30 / per)
    stream = ViconStream()
    updated = []
    for data in packets:
        updated += stream.receive(data, now=5.0)
    assert [s.obj.name for s in updated] == ["turtlebot{}".format(i) for i in range(30)]
    for i in range(30):
        name, t, r = robot(i)
        s = stream.sightings[name.decode()]
        assert (s.obj.translation, s.obj.rotation, s.frame, s.received) == (t, r, 77, 5.0)
    c = stream.counters
    assert (c.packets, c.accepted, c.frames, c.frames_lost, c.rejected) == (
        len(packets), len(packets), 1, 0, {})


def test_a_full_packet_and_an_empty_one() -> None:
    full = packet(1, [item(*robot(i)) for i in range(13)], 1024)
    assert len(decode_packet(full).objects) == 13
    assert decode_packet(packet(2, [], 512)) == ViconPacket(2, ())
    # a name of all 24 bytes has no NUL at all
    assert decode_packet(packet(3, [item(b"x" * 24, (1.0, 2.0, 3.0))])).objects[0].name == "x" * 24


GOOD = item(b"turtlebot1", (1.0, 2.0, 3.0))

MALFORMED = [
    ("size", b""),
    ("size", packet(1, [GOOD], 256)[:255]),
    ("size", packet(1, [GOOD], 256) + b"\0"),
    ("size", packet(1, [GOOD], 1024)[:1000]),
    ("size", packet(1, [GOOD], 2048)),
    # ItemsInBlock says one more item than the block holds (5 + 4 x 75 > 256)
    ("overrun", packet(1, [item(*robot(i)) for i in range(3)] + [struct.pack("<BH", 0, 72)],
                       256)),
    ("overrun", packet(1, [item(*robot(i)) for i in range(13)] + [struct.pack("<BH", 0, 72)],
                       1024)),
    ("overrun", packet(1, [item(b"a", (1, 2, 3), size=300)])),      # data past the end
    ("item-id", packet(1, [item(b"a", (1, 2, 3), item_id=1)])),
    ("item-id", packet(1, [GOOD, item(b"b", (1, 2, 3), item_id=255)])),
    ("item-size", packet(1, [item(b"a", (1, 2, 3), size=71)])),
    ("item-size", packet(1, [item(b"a", (1, 2, 3), size=80) + b"\0" * 8])),
    ("item-size", struct.pack("<IB", 1, 255) + b"\0" * 251),        # items of no data
    ("name", packet(1, [item(b"\xff\xfeobj", (1, 2, 3))])),
    ("name", packet(1, [item(b"", (1, 2, 3))])),
    ("name", packet(1, [item(b"bad\x01name", (1, 2, 3))])),
    ("name", packet(1, [item("robot\u00e9".encode()[:-1], (1, 2, 3))])),  # cut UTF-8
    ("duplicate", packet(1, [GOOD, GOOD])),
]


@pytest.mark.parametrize("cause,data", MALFORMED)
def test_malformed_packets_are_rejected_and_counted_by_cause(cause: str, data: bytes) -> None:
    with pytest.raises(ViconPacketError) as err:
        decode_packet(data)
    assert err.value.cause == cause
    stream = ViconStream()
    assert stream.receive(data, 1.0) == []
    assert stream.counters.rejected == {cause: 1}
    assert stream.counters.packets == 1 and stream.counters.accepted == 0
    assert stream.sightings == {}


@pytest.mark.parametrize("cause,values", [
    ("zero", (0.0, 0.0, 0.0, 0.0, 0.0, 0.0)),
    ("zero", (0.0, 0.0, 0.0, 0.1, 0.2, 1.0)),
    ("non-finite", (math.nan, 1.0, 2.0, 0.0, 0.0, 0.0)),
    ("non-finite", (1.0, 1.0, 2.0, 0.0, 0.0, math.inf)),
    ("non-finite", (1.0, -math.inf, 2.0, 0.0, 0.0, 0.0)),
    ("range", (2.0e6, 1.0, 2.0, 0.0, 0.0, 0.0)),
])
def test_unusable_objects_are_left_out_and_counted(cause: str, values: tuple) -> None:
    data = packet(9, [GOOD, item(b"hidden", values[:3], values[3:])])
    got = decode_packet(data)
    assert [o.name for o in got.objects] == ["turtlebot1"]
    assert got.dropped == (("hidden", cause),)
    stream = ViconStream()
    assert [s.obj.name for s in stream.receive(data, 0.0)] == ["turtlebot1"]
    assert stream.counters.dropped == {cause: 1} and "hidden" not in stream.sightings


def test_padding_after_the_items_is_not_read() -> None:
    data = bytearray(packet(1, [GOOD]))
    data[200:] = b"\xff" * 56
    assert decode_packet(bytes(data)).objects[0].name == "turtlebot1"


# ---- properties ----------------------------------------------------------------------------

NAMES = st.text(st.characters(min_codepoint=32, blacklist_characters="\x7f",
                              blacklist_categories=("Cs",)), min_size=1, max_size=24).filter(
    lambda s: len(s.encode("utf-8")) <= 24)
COORD = st.floats(-1.0e6, 1.0e6, allow_nan=False).filter(lambda v: v != 0.0)
ANGLE = st.floats(-4.0, 4.0, allow_nan=False)
OBJECTS = st.lists(st.builds(ViconObject, NAMES, st.tuples(COORD, COORD, COORD),
                             st.tuples(ANGLE, ANGLE, ANGLE)),
                   max_size=40, unique_by=lambda o: o.name)


@given(st.integers(0, 2 ** 32 - 1), OBJECTS, st.sampled_from(BLOCKS))
def test_encode_then_decode_is_the_identity(frame: int, objects: List[ViconObject],
                                            block: int) -> None:
    packets = encode_frame(frame, objects, block)
    assert all(len(p) == block for p in packets)
    decoded = [decode_packet(p) for p in packets]
    assert all(p.frame_number == frame and p.dropped == () for p in decoded)
    assert [o for p in decoded for o in p.objects] == objects


def _check_total(data: bytes) -> None:
    try:
        got = decode_packet(data)
    except ViconPacketError as err:
        assert err.cause in ("size", "overrun", "item-id", "item-size", "name", "duplicate")
        return
    for obj in got.objects:  # never a zero or NaN pose
        values = obj.translation + obj.rotation
        assert all(math.isfinite(v) for v in values) and obj.translation != (0.0, 0.0, 0.0)
    ViconStream().receive(data, 0.0)


@settings(max_examples=300)
@given(st.binary(max_size=1100) | st.sampled_from(BLOCKS).flatmap(
    lambda n: st.binary(min_size=n, max_size=n)))
def test_any_bytes_decode_or_raise_our_error(data: bytes) -> None:
    _check_total(data)


@settings(max_examples=300)
@given(st.integers(0, 2 ** 32 - 1), OBJECTS.filter(bool), st.sampled_from(BLOCKS), st.data())
def test_mutated_packets_decode_or_raise_our_error(frame: int, objects: List[ViconObject],
                                                   block: int, data: st.DataObject) -> None:
    raw = bytearray(encode_frame(frame, objects, block)[0])
    for _ in range(data.draw(st.integers(1, 6))):
        kind = data.draw(st.sampled_from(["byte", "count", "size", "id", "float", "cut", "grow"]))
        at = data.draw(st.integers(0, len(raw) - 1))
        if kind == "byte":
            raw[at] = data.draw(st.integers(0, 255))
        elif kind == "count" and len(raw) > 4:
            raw[4] = data.draw(st.integers(0, 255))
        elif kind in ("size", "id"):
            start = 5 + 75 * data.draw(st.integers(0, 12))
            if start + 3 <= len(raw):
                if kind == "size":
                    raw[start + 1:start + 3] = struct.pack("<H", data.draw(st.integers(0, 65535)))
                else:
                    raw[start] = data.draw(st.integers(0, 255))
        elif kind == "float" and at + 8 <= len(raw):
            raw[at:at + 8] = struct.pack("<d", data.draw(st.sampled_from(
                [math.nan, math.inf, -math.inf, 0.0, 1e300, -0.0])))
        elif kind == "cut":
            del raw[at:]
            if not raw:
                raw.append(0)
        elif kind == "grow":
            raw += bytes(data.draw(st.integers(1, 300)))
    _check_total(bytes(raw))
