"""Frames from Tracker packets: per object the last pose, its frame and when it came.

Theory of operation. Tracker sends each frame as one or more packets carrying
the same FrameNumber (a big fleet does not fit one block). Packets are UDP:
they may be lost, duplicated or reordered, and Tracker may restart its count.
`ViconStream.receive(data, now)` takes one datagram and never raises:

- a datagram that does not decode is counted under its cause in `rejected`;
- an object is updated only by a frame newer than the one it was last seen in,
  so a late or duplicated packet never moves an object back in time;
- FrameNumber gaps count as lost frames; a frame that arrives late after being
  counted lost is taken off again (a few thousand are remembered);
- a jump of more than MAX_FRAME_GAP either way is a restart of the stream, not
  millions of lost frames: the count starts again from the new number.

An object missing from a frame is simply not seen (Tracker has no occlusion
flag); its age grows until the reader calls it stale (`ObjectState.stale`).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Dict, List, Optional

from ..limits import VICON_MAX_FRAME_GAP as MAX_FRAME_GAP
from ..limits import VICON_MAX_OBJECTS as MAX_OBJECTS
from ..limits import VICON_MAX_REMEMBERED_GAPS as MAX_REMEMBERED_GAPS
from .packet import ViconObject, ViconPacketError, decode_packet

__all__ = ["ViconStream", "ViconCounters", "Sighting"]

@dataclass(frozen=True)
class Sighting:
    """Where an object was last seen: its pose, the frame and the receive time."""

    obj: ViconObject
    frame: int
    received: float
    #: Tracker restarts the stream had counted when it was taken: frame numbers of two counts
    #: do not compare (any frame after a restart is newer)
    restarts: int = 0

    def age(self, now: float) -> float:
        return max(0.0, now - self.received)


@dataclass
class ViconCounters:
    """What the stream has seen since it started."""

    packets: int = 0          # datagrams handed in
    accepted: int = 0         # of those, decoded
    frames: int = 0           # distinct frames seen
    frames_lost: int = 0      # FrameNumber gaps not filled by late packets
    late_packets: int = 0     # packets of a frame older than the newest
    restarts: int = 0         # FrameNumber jumps taken as a restart of Tracker
    rejected: Dict[str, int] = field(default_factory=dict)  # packets refused, by cause
    dropped: Dict[str, int] = field(default_factory=dict)   # objects left out, by cause

    def summary(self) -> str:
        def causes(counts: Dict[str, int]) -> str:
            return ", ".join("{} {}".format(k, v) for k, v in sorted(counts.items())) or "none"
        return ("{} packets ({} accepted), {} frames, {} lost, {} late packets, {} restarts; "
                "rejected: {}; objects dropped: {}".format(
                    self.packets, self.accepted, self.frames, self.frames_lost,
                    self.late_packets, self.restarts, causes(self.rejected),
                    causes(self.dropped)))


def _bump(counts: Dict[str, int], cause: str) -> None:
    counts[cause] = counts.get(cause, 0) + 1


class ViconStream:
    """Tracker packets in, per-object sightings out; see the module's docstring."""

    def __init__(self, max_objects: int = MAX_OBJECTS) -> None:
        self.max_objects = max_objects
        self.counters = ViconCounters()
        self.sightings: Dict[str, Sighting] = {}
        self.newest: Optional[int] = None
        self._gaps: Dict[int, None] = {}  # lost frame numbers, oldest first

    def receive(self, data: bytes, now: float) -> List[Sighting]:
        """Take one datagram received at `now`; the sightings it updated."""
        self.counters.packets += 1
        try:
            packet = decode_packet(data)
        except ViconPacketError as err:
            _bump(self.counters.rejected, err.cause)
            return []
        self.counters.accepted += 1
        for _, cause in packet.dropped:
            _bump(self.counters.dropped, cause)
        self._count_frame(packet.frame_number)
        updated = []
        for obj in packet.objects:
            last = self.sightings.get(obj.name)
            if last is None and len(self.sightings) >= self.max_objects:
                _bump(self.counters.dropped, "too-many")
                continue
            if last is not None and last.restarts == self.counters.restarts and last.frame >= packet.frame_number:
                continue
            sighting = Sighting(obj, packet.frame_number, now, self.counters.restarts)
            self.sightings[obj.name] = sighting
            updated.append(sighting)
        return updated

    def refuse(self, cause: str) -> None:
        """Count a datagram its reader refused before decoding (e.g. from a foreign host)."""
        self.counters.packets += 1
        _bump(self.counters.rejected, cause)

    def _count_frame(self, frame: int) -> None:
        c = self.counters
        newest = self.newest
        if newest is None or abs(frame - newest) > MAX_FRAME_GAP:
            if newest is not None:
                c.restarts += 1
                self._gaps.clear()  # objects keep their pose, age and frame; any new frame is newer
            self.newest = frame
            c.frames += 1
        elif frame > newest:
            c.frames += 1
            c.frames_lost += frame - newest - 1
            for missing in range(max(newest + 1, frame - MAX_REMEMBERED_GAPS), frame):
                self._gaps[missing] = None
            while len(self._gaps) > MAX_REMEMBERED_GAPS:
                del self._gaps[next(iter(self._gaps))]
            self.newest = frame
        elif frame < newest:
            c.late_packets += 1
            if frame in self._gaps:  # the first packet of a frame counted lost
                del self._gaps[frame]
                c.frames_lost -= 1
                c.frames += 1
