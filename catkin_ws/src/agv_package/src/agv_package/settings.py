"""The robot's settings, read once from plain data (a node's ~params, config/*.yaml).

Each settings class checks its mapping before anything runs: unknown keys,
missing keys and values out of range raise `SettingsError`, whose message
names the setting and lists what is expected. Angles are degrees in the files
and radians in the objects.
"""
from __future__ import annotations

import math
from typing import Any, Iterable, Mapping, NamedTuple, Optional

from fleet_common.errors import FleetError


class SettingsError(FleetError, ValueError):
    """A setting is missing, unknown or out of range."""


def check_keys(data: Any, allowed: Iterable[str], where: str) -> Mapping[str, Any]:
    if not isinstance(data, Mapping):
        raise SettingsError("{}: expected a mapping of settings, got {!r}".format(where, data))
    allowed = sorted(allowed)
    for key in data:
        if key not in allowed:
            raise SettingsError("{}: unknown setting {!r}; the settings are {}".format(
                where, key, ", ".join(allowed)))
    return data


def number(data: Mapping[str, Any], key: str, where: str, default: Optional[float] = None,
           low: Optional[float] = None, high: Optional[float] = None) -> float:
    """data[key] as a float in [low, high] (`default` if absent and given)."""
    if key not in data:
        if default is None:
            raise SettingsError("{}: missing setting {!r}".format(where, key))
        return float(default)
    value = data[key]
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise SettingsError("{}.{}: expected a number, got {!r}".format(where, key, value))
    if (low is not None and value < low) or (high is not None and value > high):
        raise SettingsError("{}.{}: {} is out of range [{}, {}]".format(
            where, key, value, "-inf" if low is None else low, "inf" if high is None else high))
    return float(value)


class MotionSettings(NamedTuple):
    """Speeds (m/s, rad/s), accelerations, controller gains and tolerances."""

    max_speed: float
    min_speed: float
    max_accel: float
    max_turn_rate: float
    min_turn_rate: float
    max_turn_accel: float
    turn_gain: float
    heading_gain: float
    lateral_gain: float
    position_tolerance: float
    heading_tolerance: float
    align_tolerance: float
    control_rate: float

    @classmethod
    def from_dict(cls, data: Any, where: str = "motion") -> "MotionSettings":
        angles = ("heading_tolerance", "align_tolerance")
        keys = [k + "_deg" if k in angles else k for k in cls._fields]
        check_keys(data, keys, where)
        values = {}
        for field, key in zip(cls._fields, keys):
            value = number(data, key, where, low=0.0)
            if value <= 0.0:
                raise SettingsError("{}.{}: must be positive, got {}".format(where, key, value))
            values[field] = math.radians(value) if field in angles else value
        made = cls(**values)
        if made.min_speed > made.max_speed or made.min_turn_rate > made.max_turn_rate:
            raise SettingsError("{}: min_speed/min_turn_rate must not exceed max_speed/"
                                "max_turn_rate".format(where))
        return made


class LocalizationSettings(NamedTuple):
    """AprilTag detection and how its fixes are fused with odometry."""

    tag_map: str
    tag_size: float
    fusion_gain: float
    max_jump: float
    odom_history: float
    min_decision_margin: float
    max_hamming: int
    quad_decimate: float

    @classmethod
    def from_dict(cls, data: Any, tag_size: float, where: str = "localization"
                  ) -> "LocalizationSettings":
        check_keys(data, [f for f in cls._fields if f != "tag_size"], where)
        tag_map = data.get("tag_map", "lab")
        if not isinstance(tag_map, str) or not tag_map:
            raise SettingsError("{}.tag_map: expected 'lab' or a YAML file path, got {!r}".format(
                where, tag_map))
        return cls(
            tag_map=tag_map,
            tag_size=tag_size,
            fusion_gain=number(data, "fusion_gain", where, low=0.01, high=1.0),
            max_jump=number(data, "max_jump", where, low=0.0),
            odom_history=number(data, "odom_history", where, low=0.1),
            min_decision_margin=number(data, "min_decision_margin", where, default=0.0, low=0.0),
            max_hamming=int(number(data, "max_hamming", where, default=0, low=0, high=2)),
            quad_decimate=number(data, "quad_decimate", where, default=1.0, low=1.0),
        )
