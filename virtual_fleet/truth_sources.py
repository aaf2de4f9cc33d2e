"""Where the simulated Tracker learns where the robots really are.

A `TruthSource` answers `poses(now)`: Vicon object name -> true base-grid pose.
`fleet_common.transport.truth_stream.TruthSubscriber` is one (the virtual fleet's
ground-truth socket); the scripted ones are here:

- `CircleTruth`: robots going round a circle, for lab staff without a fleet.
- `StillTruth`: robots standing where they are put (calibration practice, tests).
"""
from __future__ import annotations

import math
import time
from typing import Callable, Dict, Mapping, Protocol, Sequence, Tuple

from fleet_common.wire.messages import Pose

__all__ = ["TruthSource", "CircleTruth", "StillTruth"]


class TruthSource(Protocol):
    """Where each robot really is (by Vicon name) at monotonic time `now`."""

    def poses(self, now: float) -> Dict[str, Pose]:
        ...

    def close(self) -> None:
        ...


class CircleTruth:
    """Robots evenly spaced on a circle, going round counter-clockwise, facing their way."""

    def __init__(self, names: Sequence[str], centre: Tuple[float, float] = (6.0, 6.5),
                 radius: float = 4.0, period: float = 30.0,
                 clock: Callable[[], float] = time.monotonic) -> None:
        self.names = list(names)
        self.centre, self.radius, self.period = centre, radius, period
        self.t0 = clock()

    def poses(self, now: float) -> Dict[str, Pose]:
        out = {}
        for i, name in enumerate(self.names):
            a = 2.0 * math.pi * ((now - self.t0) / self.period + i / max(1, len(self.names)))
            out[name] = Pose(self.centre[0] + self.radius * math.cos(a),
                             self.centre[1] + self.radius * math.sin(a),
                             math.remainder(a + math.pi / 2, 2.0 * math.pi))
        return out

    def close(self) -> None:
        pass


class StillTruth:
    """Robots standing still at the given poses."""

    def __init__(self, poses: Mapping[str, Pose]) -> None:
        self.fixed = dict(poses)

    def poses(self, now: float) -> Dict[str, Pose]:
        return dict(self.fixed)

    def close(self) -> None:
        pass
