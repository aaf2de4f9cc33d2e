"""Vicon Tracker's "UDP Object Stream" packets: bytes <-> `ViconPacket`.

Layout, little-endian and packed (one packet is Tracker's block size, 256, 512
or 1024 bytes; the bytes after the last item are padding):

    uint32 FrameNumber, uint8 ItemsInBlock,
    then per item: uint8 ItemID (0 = object), uint16 ItemDataSize (72),
                   char[24] name (NUL-padded), 3 x float64 translation (mm),
                   3 x float64 rotation (rad, Euler XYZ)

`decode_packet` is total: any bytes give a `ViconPacket` or a
`ViconPacketError` whose `cause` names the reason, never another exception.
A packet whose structure is wrong is refused whole; an object whose values are
unusable (all-zero translation, which some Vicon drivers send for an occluded
object; NaN or infinite values; out of any room) is left out of the packet and
named in `dropped`, so a zero or NaN pose never leaves this module.
`encode_frame` is the inverse (for the Tracker simulator and the tests).
"""
from __future__ import annotations

import math
import struct
from dataclasses import dataclass
from typing import List, Sequence, Tuple

from ..errors import FleetError
from ..limits import VICON_BLOCK_SIZES as BLOCK_SIZES
from ..limits import VICON_MAX_ABS_MM as MAX_ABS_MM
from ..limits import VICON_NAME_BYTES as NAME_BYTES

__all__ = [
    "BLOCK_SIZES", "ITEM_SIZE", "OBJECT_DATA_SIZE", "NAME_BYTES", "MAX_ABS_MM",
    "ViconObject", "ViconPacket", "ViconPacketError", "decode_packet", "encode_frame",
    "objects_per_packet", "REJECT_CAUSES", "DROP_CAUSES",
]

HEADER = struct.Struct("<IB")          # FrameNumber, ItemsInBlock
ITEM_HEADER = struct.Struct("<BH")     # ItemID, ItemDataSize
OBJECT_DATA = struct.Struct("<24s6d")  # name, translation, rotation
OBJECT_ITEM_ID = 0
OBJECT_DATA_SIZE = OBJECT_DATA.size    # 72
ITEM_SIZE = ITEM_HEADER.size + OBJECT_DATA_SIZE  # 75

#: Why a packet is refused whole.
REJECT_CAUSES = ("size", "overrun", "item-id", "item-size", "name", "duplicate")
#: Why one object of an accepted packet is left out.
DROP_CAUSES = ("zero", "non-finite", "range")


class ViconPacketError(FleetError):
    """A datagram that is not a Tracker packet; `cause` is one of REJECT_CAUSES."""

    def __init__(self, message: str, cause: str) -> None:
        super().__init__(message)
        self.cause = cause


@dataclass(frozen=True)
class ViconObject:
    """One tracked object in one frame: Vicon millimetres and radians (Euler XYZ)."""

    name: str
    translation: Tuple[float, float, float]
    rotation: Tuple[float, float, float]


@dataclass(frozen=True)
class ViconPacket:
    """A decoded packet: its frame, the usable objects, and (name, cause) of those left out."""

    frame_number: int
    objects: Tuple[ViconObject, ...]
    dropped: Tuple[Tuple[str, str], ...] = ()


def objects_per_packet(block_size: int) -> int:
    return (block_size - HEADER.size) // ITEM_SIZE


def _name(raw: bytes, offset: int) -> str:
    text = raw.split(b"\0", 1)[0]
    try:
        name = text.decode("utf-8")
    except UnicodeDecodeError:
        raise ViconPacketError("object name at byte {} is not UTF-8 text: {!r}".format(
            offset, text), "name") from None
    if not name or any(ord(c) < 32 or ord(c) == 127 for c in name):
        raise ViconPacketError("object name at byte {} is empty or holds control "
                               "characters: {!r}".format(offset, name), "name")
    return name


def _problem(values: Sequence[float]) -> str:
    """The drop cause for an object's six numbers, or '' if they are usable."""
    if not all(math.isfinite(v) for v in values):
        return "non-finite"
    if values[0] == 0.0 and values[1] == 0.0 and values[2] == 0.0:
        return "zero"
    if any(abs(v) > MAX_ABS_MM for v in values[:3]):
        return "range"
    return ""


def decode_packet(data: bytes) -> ViconPacket:
    """The packet in datagram `data`; ViconPacketError if it is not one."""
    if len(data) not in BLOCK_SIZES:
        raise ViconPacketError("datagram of {} bytes: a Tracker packet is {} bytes".format(
            len(data), ", ".join(map(str, BLOCK_SIZES))), "size")
    frame_number, count = HEADER.unpack_from(data, 0)
    offset = HEADER.size
    objects: List[ViconObject] = []
    dropped: List[Tuple[str, str]] = []
    seen = set()
    for index in range(count):
        if offset + ITEM_HEADER.size > len(data):
            raise ViconPacketError("item {} of {} starts at byte {}, past the {}-byte "
                                   "packet".format(index + 1, count, offset, len(data)), "overrun")
        item_id, size = ITEM_HEADER.unpack_from(data, offset)
        body = offset + ITEM_HEADER.size
        if body + size > len(data):
            raise ViconPacketError("item {} of {} ({} bytes at byte {}) runs past the {}-byte "
                                   "packet".format(index + 1, count, size, body, len(data)),
                                   "overrun")
        if item_id != OBJECT_ITEM_ID:
            raise ViconPacketError("item {} has unknown ItemID {} (0 is an object)".format(
                index + 1, item_id), "item-id")
        if size != OBJECT_DATA_SIZE:
            raise ViconPacketError("object item {} has {} data bytes, expected {}".format(
                index + 1, size, OBJECT_DATA_SIZE), "item-size")
        raw, *values = OBJECT_DATA.unpack_from(data, body)
        name = _name(raw, body)
        if name in seen:
            raise ViconPacketError("object {!r} appears twice in one packet".format(name),
                                   "duplicate")
        seen.add(name)
        problem = _problem(values)
        if problem:
            dropped.append((name, problem))
        else:
            objects.append(ViconObject(name, tuple(values[:3]), tuple(values[3:])))
        offset = body + size
    return ViconPacket(frame_number, tuple(objects), tuple(dropped))


def encode_frame(frame_number: int, objects: Sequence[ViconObject],
                 block_size: int = 1024) -> List[bytes]:
    """The packets of one frame: as many objects in each as the block holds, zero-padded.
    A frame without objects is one packet saying so. Values are packed as given."""
    if block_size not in BLOCK_SIZES:
        raise ValueError("block size {} is not one of {}".format(block_size, BLOCK_SIZES))
    per = objects_per_packet(block_size)
    chunks = [objects[i:i + per] for i in range(0, len(objects), per)] or [[]]
    packets = []
    for chunk in chunks:
        parts = [HEADER.pack(frame_number, len(chunk))]
        for obj in chunk:
            name = obj.name.encode("utf-8")
            if not 0 < len(name) <= NAME_BYTES:
                raise ValueError("object name {!r} must be 1..{} bytes of UTF-8".format(
                    obj.name, NAME_BYTES))
            parts.append(ITEM_HEADER.pack(OBJECT_ITEM_ID, OBJECT_DATA_SIZE))
            parts.append(OBJECT_DATA.pack(name, *obj.translation, *obj.rotation))
        packets.append(b"".join(parts).ljust(block_size, b"\0"))
    return packets
