"""A simulated Vicon Tracker: true robot poses in, UDP Object Stream packets out.

`TrackerSimulator` is pure: each `frame(truth, elapsed)` call is one Tracker
frame, the true base-grid poses turned into Vicon millimetres (through the
inverse of the lab's vicon -> base transform), with Gaussian noise, objects
hidden while occluded (left out, or sent as all zeros the way some drivers
do), split into packets of the block size, and each packet lost with a set
probability. `run_tracker` is the thin edge that sends them over UDP at the
set rate, reading poses from any `TruthSource` (the virtual fleet's truth
socket, or a scripted source: `virtual_fleet.truth_sources`).
"""
from __future__ import annotations

import math
import random
import socket
import time
from dataclasses import dataclass, field
from typing import Callable, Dict, List, Mapping, Tuple

from fleet_common.transform2d import Transform2D
from fleet_common.vicon.base_grid import DEFAULT_HEIGHT_MM, from_base
from fleet_common.vicon.packet import BLOCK_SIZES, ViconObject, encode_frame
from fleet_common.wire.messages import Pose

from .truth_sources import TruthSource

__all__ = ["Occlusion", "TrackerSettings", "TrackerSimulator", "run_tracker", "MAX_RATE"]

#: Tracker streams objects at most this often (Hz).
MAX_RATE = 100.0


@dataclass(frozen=True)
class Occlusion:
    """Object `name` is not seen from `start` to `end` seconds after the stream starts."""

    name: str
    start: float = 0.0
    end: float = math.inf

    def hides(self, name: str, elapsed: float) -> bool:
        return name == self.name and self.start <= elapsed < self.end


@dataclass(frozen=True)
class TrackerSettings:
    rate: float = MAX_RATE             # frames per second
    block_size: int = 1024             # bytes per packet
    noise_mm: float = 0.0              # standard deviation of each coordinate
    heading_noise_deg: float = 0.0     # standard deviation of the heading
    loss: float = 0.0                  # probability that a packet is lost
    occlusions: Tuple[Occlusion, ...] = ()
    zero_when_occluded: bool = False   # send an occluded object as zeros instead of leaving it out
    height_mm: float = DEFAULT_HEIGHT_MM

    def __post_init__(self) -> None:
        if not 0.0 < self.rate <= MAX_RATE:
            raise ValueError("rate must be in (0, {:g}] Hz, got {!r}".format(MAX_RATE, self.rate))
        if self.block_size not in BLOCK_SIZES:
            raise ValueError("block size must be one of {}, got {!r}".format(
                BLOCK_SIZES, self.block_size))
        if not (self.noise_mm >= 0.0 and self.heading_noise_deg >= 0.0 and 0.0 <= self.loss < 1.0):
            raise ValueError("noise must be >= 0 and loss in [0, 1)")


@dataclass
class TrackerCounters:
    frames: int = 0
    packets: int = 0   # made
    lost: int = 0      # of those, dropped on purpose
    hidden: Dict[str, int] = field(default_factory=dict)  # object -> frames occluded


class TrackerSimulator:
    """One `frame` call per Tracker frame; see the module's docstring."""

    def __init__(self, settings: TrackerSettings, base_to_vicon: Transform2D, seed: int = 0,
                 first_frame: int = 1) -> None:
        if (base_to_vicon.source, base_to_vicon.target) != ("base", "vicon"):
            raise ValueError("need a base -> vicon transform, got {}".format(base_to_vicon.name()))
        self.settings = settings
        self.base_to_vicon = base_to_vicon
        self.rng = random.Random(seed)
        self.frame_number = first_frame
        self.counters = TrackerCounters()

    def frame(self, truth: Mapping[str, Pose], elapsed: float) -> List[bytes]:
        """The packets of the next frame that survive the loss, in sending order."""
        s = self.settings
        objects: List[ViconObject] = []
        for name in sorted(truth):
            if any(o.hides(name, elapsed) for o in s.occlusions):
                self.counters.hidden[name] = self.counters.hidden.get(name, 0) + 1
                if s.zero_when_occluded:
                    objects.append(ViconObject(name, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)))
                continue
            seen = from_base(self.base_to_vicon, name, truth[name], s.height_mm)
            x, y, z = (v + self.rng.gauss(0.0, s.noise_mm) if s.noise_mm else v
                       for v in seen.translation)
            yaw = seen.rotation[2] + (self.rng.gauss(0.0, math.radians(s.heading_noise_deg))
                                      if s.heading_noise_deg else 0.0)
            objects.append(ViconObject(name, (x, y, z), (0.0, 0.0, math.remainder(yaw, math.tau))))
        packets = encode_frame(self.frame_number, objects, s.block_size)
        self.frame_number = (self.frame_number + 1) % 2 ** 32
        self.counters.frames += 1
        self.counters.packets += len(packets)
        kept = [p for p in packets if not (s.loss and self.rng.random() < s.loss)]
        self.counters.lost += len(packets) - len(kept)
        return kept


def run_tracker(sim: TrackerSimulator, source: TruthSource, sock: socket.socket,
                destination: Tuple[str, int], should_stop: Callable[[], bool],
                clock: Callable[[], float] = time.monotonic,
                sent: Callable[[int, float], None] = lambda frame, when: None) -> None:
    """Send a frame every 1/rate seconds until `should_stop()`; `sent(frame, time)` is told
    when each frame not lost whole began to go out (a benchmark's clock)."""
    period = 1.0 / sim.settings.rate
    start = clock()
    tick = 0
    while not should_stop():
        now = clock()
        number = sim.frame_number
        packets = sim.frame(source.poses(now), now - start)
        if packets:
            sent(number, clock())
        for data in packets:
            sock.sendto(data, destination)
        tick += 1
        # on a fixed schedule, so the rate holds whatever each frame costs; a late
        # frame is sent at once rather than skipped (Tracker does not skip either)
        time.sleep(max(0.0, start + tick * period - clock()))
