"""sim_turtlebot's settings: config/sim.yaml and config/camera.yaml plus the launch args.

Read once from the node's private parameters (a plain dict), checked here so
that a typo fails at start-up with the list of valid keys.
"""
from __future__ import annotations

import math
from typing import Any, Mapping, NamedTuple

from ..camera_model import CameraMount, Intrinsics
from ..geometry import Pose2D
from ..settings import SettingsError, check_keys, number
from .base_model import BaseNoise

_TOP = ("rates", "camera_intrinsics", "odometry_noise", "limits", "camera_mount", "tag_size",
        "tag_map", "start_x", "start_y", "start_heading_deg", "seed")


class SimSettings(NamedTuple):
    physics_rate: float
    odom_rate: float
    camera_rate: float
    width: int
    height: int
    intrinsics: Intrinsics
    image_noise: float
    noise: BaseNoise
    max_accel: float
    max_turn_accel: float
    mount: CameraMount
    tag_size: float
    tag_map: str
    start: Pose2D           # base grid: cells and radians
    seed: int

    @classmethod
    def from_params(cls, params: Mapping[str, Any]) -> "SimSettings":
        check_keys(params, _TOP, "sim_turtlebot")
        rates = check_keys(params.get("rates", {}), ("physics", "odom", "camera"), "rates")
        cam = check_keys(params.get("camera_intrinsics", {}),
                         ("width", "height", "fx", "fy", "noise"), "camera_intrinsics")
        noise = check_keys(params.get("odometry_noise", {}), BaseNoise._fields, "odometry_noise")
        limits = check_keys(params.get("limits", {}), ("max_accel", "max_turn_accel"), "limits")
        width = int(number(cam, "width", "camera_intrinsics", low=16, high=8192))
        height = int(number(cam, "height", "camera_intrinsics", low=16, high=8192))
        fx = number(cam, "fx", "camera_intrinsics", low=1.0)
        fy = number(cam, "fy", "camera_intrinsics", low=1.0)
        if "camera_mount" not in params:
            raise SettingsError("sim_turtlebot: missing camera_mount (load config/camera.yaml)")
        tag_map = params.get("tag_map", "lab")
        if not isinstance(tag_map, str):
            raise SettingsError("tag_map: expected 'lab' or a YAML file path, got {!r}".format(
                tag_map))
        return cls(
            physics_rate=number(rates, "physics", "rates", default=100.0, low=10.0),
            odom_rate=number(rates, "odom", "rates", default=50.0, low=1.0),
            camera_rate=number(rates, "camera", "rates", default=15.0, low=0.5),
            width=width, height=height,
            intrinsics=(fx, fy, (width - 1) / 2.0, (height - 1) / 2.0),
            image_noise=number(cam, "noise", "camera_intrinsics", default=2.0, low=0.0),
            noise=BaseNoise(**{k: number(noise, k, "odometry_noise", default=getattr(
                BaseNoise(), k), low=0.0, high=0.5) for k in BaseNoise._fields}),
            max_accel=number(limits, "max_accel", "limits", default=1.0, low=0.01),
            max_turn_accel=number(limits, "max_turn_accel", "limits", default=4.0, low=0.01),
            mount=CameraMount.from_dict(check_keys(params["camera_mount"],
                                                   ("x", "y", "z", "yaw_deg"), "camera_mount")),
            tag_size=number(params, "tag_size", "sim_turtlebot", low=0.01),
            tag_map=tag_map,
            start=Pose2D(number(params, "start_x", "sim_turtlebot", default=0.0),
                         number(params, "start_y", "sim_turtlebot", default=0.0),
                         math.radians(number(params, "start_heading_deg", "sim_turtlebot",
                                             default=0.0))),
            seed=int(number(params, "seed", "sim_turtlebot", default=0.0, low=0.0)),
        )
