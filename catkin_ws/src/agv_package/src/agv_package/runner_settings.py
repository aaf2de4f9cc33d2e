"""agv_runner's settings: config/navigation.yaml, config/camera.yaml and the launch args.

Read once from the node's private parameters (a plain dict) into one object;
every value is checked before the node opens a socket or moves a wheel.
"""
from __future__ import annotations

from typing import Any, Mapping, NamedTuple

from fleet_common.wire.command_check import CommandLimits
from fleet_common.wire.ports import FEEDBACK_PORT

from .camera_model import CameraMount
from .settings import (LocalizationSettings, MotionSettings, SettingsError, check_keys,
                       number)

#: How the bumper reaches the runner: a std_msgs/UInt8 bitmask (sim_turtlebot, or a relay
#: of the Kobuki's sensor state), or kobuki_msgs/BumperEvent (the Kobuki driver's events).
BUMPER_TYPES = ("mask", "kobuki")

_TOP = ("robot_id", "definitions", "keys_dir", "bind", "feedback_port", "feedback_rate",
        "bumper_type", "camera_mount", "tag_size", "motion", "localization", "commands")


def _text(params: Mapping[str, Any], key: str) -> str:
    value = params.get(key, "")
    if not isinstance(value, str):
        raise SettingsError("agv_runner.{}: expected text, got {!r}".format(key, value))
    return value


class RunnerSettings(NamedTuple):
    robot_id: int
    definitions: str        # "" : the default robot_definitions.txt
    keys_dir: str           # "" : the default CurveZMQ key folder
    bind: str               # "" : the robot's host from the definitions
    feedback_port: int
    feedback_rate: float
    bumper_type: str
    mount: CameraMount
    motion: MotionSettings
    localization: LocalizationSettings
    commands: CommandLimits  # what the robot refuses: drives longer than a step or too slow

    @classmethod
    def from_params(cls, params: Mapping[str, Any]) -> "RunnerSettings":
        where = "agv_runner"
        check_keys(params, _TOP, where)
        for key in ("camera_mount", "motion", "localization"):
            if key not in params:
                raise SettingsError("{}: missing {} (load config/{}.yaml)".format(
                    where, key, "camera" if key == "camera_mount" else "navigation"))
        robot_id = number(params, "robot_id", where, low=0)
        if robot_id != int(robot_id):
            raise SettingsError("{}.robot_id: expected a whole number, got {}".format(
                where, robot_id))
        bumper_type = params.get("bumper_type", "mask")
        if bumper_type not in BUMPER_TYPES:
            raise SettingsError("{}.bumper_type: {!r} is not one of {}".format(
                where, bumper_type, ", ".join(BUMPER_TYPES)))
        tag_size = number(params, "tag_size", where, low=0.01)
        return cls(
            robot_id=int(robot_id),
            definitions=_text(params, "definitions"),
            keys_dir=_text(params, "keys_dir"),
            bind=_text(params, "bind"),
            feedback_port=int(number(params, "feedback_port", where, default=FEEDBACK_PORT,
                                     low=1, high=65535)),
            # The manager and the console expect pose feedback at 10 Hz or more.
            feedback_rate=number(params, "feedback_rate", where, default=20.0, low=10.0),
            bumper_type=bumper_type,
            mount=CameraMount.from_dict(check_keys(params["camera_mount"],
                                                   ("x", "y", "z", "yaw_deg"), "camera_mount")),
            motion=MotionSettings.from_dict(params["motion"]),
            localization=LocalizationSettings.from_dict(params["localization"], tag_size),
            commands=_command_limits(params.get("commands", {})),
        )


def _command_limits(data: Any) -> CommandLimits:
    where = "commands"
    check_keys(data, ("max_step", "max_time"), where)
    default = CommandLimits()
    return CommandLimits(max_step=number(data, "max_step", where, default=default.max_step,
                                         low=0.5, high=100.0),
                         max_time=number(data, "max_time", where, default=default.max_time,
                                         low=1.0, high=3600.0))
