"""Vicon millimetres <-> base-grid cells, through the transform in a frames file.

The lab's frames.yaml holds `vicon_to_base` (written by `fleetctl vicon
calibrate`); any chain of entries from "vicon" to "base" would do, found by
`fleet_common.frames.find_transform`. A robot's heading is the object's
rotation about the Vicon z axis (the last Euler XYZ angle: robots stay on the
floor), turned into a base-grid heading by the transform's linear part.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Mapping, Optional, Union

from ..frames import find_transform, load_transforms
from ..transform2d import Transform2D
from ..wire.messages import Pose
from .packet import ViconObject
from .stream import Sighting

__all__ = ["VICON_TRANSFORM", "ViconFix", "load_vicon_to_base", "vicon_to_base",
           "to_base", "from_base", "fix_of", "DEFAULT_HEIGHT_MM"]

#: The frames-file entry calibration writes.
VICON_TRANSFORM = "vicon_to_base"
#: Height of a robot's marker constellation above the floor (the simulator's z).
DEFAULT_HEIGHT_MM = 400.0


def vicon_to_base(transforms: Mapping[str, Transform2D]) -> Transform2D:
    """The vicon -> base transform among a frames file's entries (TransformError if none)."""
    return find_transform(transforms.values(), "vicon", "base")


def load_vicon_to_base(path: Union[str, Path, None] = None) -> Transform2D:
    """vicon -> base from frames file `path` (default: the lab's frames.yaml)."""
    if path is None:
        from ..lab import lab_frames_path
        path = lab_frames_path()
    return vicon_to_base(load_transforms(path))


def to_base(transform: Transform2D, obj: ViconObject) -> Pose:
    """The object's pose in base-grid cells and radians."""
    x, y = transform.apply(obj.translation[:2])
    return Pose(x, y, transform.apply_heading(obj.rotation[2]))


def from_base(base_to_vicon: Transform2D, name: str, pose: Pose,
              height_mm: float = DEFAULT_HEIGHT_MM) -> ViconObject:
    """What Tracker would report for an object at base pose `pose` (the simulator)."""
    x, y = base_to_vicon.apply((pose.x, pose.y))
    return ViconObject(name, (x, y, height_mm), (0.0, 0.0, base_to_vicon.apply_heading(pose.theta)))


@dataclass(frozen=True)
class ViconFix:
    """An object as readers show it: base-grid pose, Tracker frame, age (s), whether stale,
    and the robot it is (None for an object no robot definition names)."""

    name: str
    pose: Pose
    frame: int
    age: float
    stale: bool
    robot_id: Optional[int] = None


def fix_of(transform: Transform2D, sighting: Sighting, now: float, stale_after: float,
           robot_id: Optional[int] = None) -> ViconFix:
    age = sighting.age(now)
    return ViconFix(sighting.obj.name, to_base(transform, sighting.obj), sighting.frame, age,
                    age > stale_after, robot_id)
