"""From one AprilTag seen by the downward camera to where the robot stands on the floor.

The detector reports the tag's pose in the camera frame (camera_T_tag, its
tag frame: origin at the tag centre, x right and y down across the upright
tag, z into the floor). The tag map says where the tag lies (world_T_tag)
and the mount says where the camera sits (robot_T_camera), so

    world_T_robot = world_T_tag . inverse(camera_T_tag) . inverse(robot_T_camera)

projected onto the floor: position from the translation, heading from the
robot's x axis. The robot origin must come out on the floor; its height
(`height_error`) shows a wrong tag size, mount or intrinsics.
"""
from __future__ import annotations

import math
from typing import NamedTuple, Tuple

import numpy as np

from .camera_model import CameraMount
from .geometry import Pose2D
from .tag_map import TagPlacement


class TagObservation(NamedTuple):
    """One detection: tag id and the tag's pose in the camera frame (3x3 R, 3-vector t)."""

    tag_id: int
    rotation: np.ndarray
    translation: np.ndarray
    decision_margin: float = 0.0
    hamming: int = 0


def world_from_tag(place: TagPlacement) -> np.ndarray:
    """4x4 pose of a tag lying face up on the floor (tag y points away from its top edge)."""
    c, s = math.cos(place.yaw), math.sin(place.yaw)
    out = np.eye(4)
    out[:3, :3] = np.array([[c, s, 0.0], [s, -c, 0.0], [0.0, 0.0, -1.0]])
    out[:3, 3] = (place.x, place.y, 0.0)
    return out


def _homogeneous(rotation: np.ndarray, translation: np.ndarray) -> np.ndarray:
    out = np.eye(4)
    out[:3, :3] = rotation
    out[:3, 3] = np.asarray(translation, dtype=float).reshape(3)
    return out


def _rigid_inverse(transform: np.ndarray) -> np.ndarray:
    out = np.eye(4)
    out[:3, :3] = transform[:3, :3].T
    out[:3, 3] = -transform[:3, :3].T @ transform[:3, 3]
    return out


def robot_pose_from_tag(seen: TagObservation, place: TagPlacement,
                        mount: CameraMount) -> Tuple[Pose2D, float]:
    """(robot pose on the floor in the world frame, height of the robot origin in metres)."""
    camera_from_tag = _homogeneous(seen.rotation, seen.translation)
    world_from_robot = (world_from_tag(place) @ _rigid_inverse(camera_from_tag)
                        @ _rigid_inverse(mount.robot_from_camera()))
    x_axis = world_from_robot[:3, 0]
    pose = Pose2D(float(world_from_robot[0, 3]), float(world_from_robot[1, 3]),
                  math.atan2(float(x_axis[1]), float(x_axis[0])))
    return pose, float(world_from_robot[2, 3])


def tag_in_camera(robot: Pose2D, place: TagPlacement, mount: CameraMount) -> TagObservation:
    """The observation a perfect detector would make (the inverse of `robot_pose_from_tag`)."""
    c, s = math.cos(robot.theta), math.sin(robot.theta)
    world_from_robot = np.eye(4)
    world_from_robot[:2, :2] = [[c, -s], [s, c]]
    world_from_robot[:2, 3] = (robot.x, robot.y)
    camera_from_tag = (_rigid_inverse(world_from_robot @ mount.robot_from_camera())
                       @ world_from_tag(place))
    return TagObservation(-1, camera_from_tag[:3, :3], camera_from_tag[:3, 3])
