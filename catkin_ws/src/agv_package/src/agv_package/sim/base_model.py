"""A differential-drive base with imperfect odometry: the simulated TurtleBot 2 (Kobuki).

The base follows velocity commands with limited acceleration. Its wheels
slip: the ground-truth motion is the wheel motion shrunk by a slip fraction
that wanders slowly around `slip` (a random walk kept in [0, 3 x slip]).
Odometry integrates what the encoders and the gyro measure, the wheel motion
with a little noise, so it drifts from the truth the way a real base's
/odom does. The odometry frame starts on the world frame (the base was reset
where it stands), so /odom and the truth agree at the start.

A wall stops the base: when `blocked(pose)` says the front bumper touches
something, forward motion is refused (the base can still turn and reverse).
"""
from __future__ import annotations

import math
from typing import Callable, NamedTuple, Optional

import numpy as np

from fleet_common.angles import wrap_angle

from ..geometry import Pose2D
from ..motion import STOP, Twist


class BaseNoise(NamedTuple):
    """Odometry imperfections, as fractions of the motion."""

    slip: float = 0.005              # mean wheel slip (truth moves this much less)
    slip_walk: float = 0.002         # slip random-walk step per second (std dev)
    encoder_noise: float = 0.01      # encoder speed noise per step (std dev)
    gyro_noise: float = 0.002        # gyro rate noise per step (std dev, fraction)
    turn_slip: float = 0.01          # turns fall short by this fraction (the gyro sees it)


class BaseModel:
    """Integrates velocity commands into a true pose and an odometry pose."""

    def __init__(self, start: Pose2D, noise: BaseNoise = BaseNoise(),
                 max_accel: float = 1.0, max_turn_accel: float = 4.0,
                 seed: Optional[int] = None) -> None:
        self.truth = start
        self.odom = start
        self.noise = noise
        self.max_accel = max_accel
        self.max_turn_accel = max_turn_accel
        self.velocity = STOP          # what the wheels do now (after acceleration limits)
        self.odom_velocity = STOP     # what odometry measured on the last step
        self._slip = noise.slip
        self._rng = np.random.default_rng(seed)

    def step(self, command: Twist, dt: float,
             blocked: Callable[[Pose2D], bool] = lambda pose: False) -> None:
        """Advance `dt` seconds under `command`; `blocked(pose)`: the bumper touches a wall."""
        v = _toward(self.velocity.linear, command.linear, self.max_accel * dt)
        w = _toward(self.velocity.angular, command.angular, self.max_turn_accel * dt)
        if v > 0.0 and blocked(self.truth):
            v = 0.0  # pushing into a wall: the wheels stall
        self.velocity = Twist(v, w)
        n = self.noise
        rng = self._rng
        walk = n.slip_walk * math.sqrt(dt) * float(rng.normal())
        self._slip = min(max(self._slip + walk, 0.0), 3.0 * n.slip)
        true_v = v * (1.0 - self._slip)
        true_w = w * (1.0 - n.turn_slip)
        measured_v = v * (1.0 + n.encoder_noise * float(rng.normal()))
        measured_w = true_w * (1.0 + n.gyro_noise * float(rng.normal()))
        self.truth = _integrate(self.truth, true_v, true_w, dt)
        self.odom = _integrate(self.odom, measured_v, measured_w, dt)
        self.odom_velocity = Twist(measured_v, measured_w)


def _toward(current: float, wanted: float, max_step: float) -> float:
    return current + max(-max_step, min(max_step, wanted - current))


def _integrate(pose: Pose2D, v: float, w: float, dt: float) -> Pose2D:
    """Exact motion along the arc for constant (v, w) over dt."""
    theta = pose.theta
    if abs(w) < 1e-9:
        return Pose2D(pose.x + v * dt * math.cos(theta), pose.y + v * dt * math.sin(theta), theta)
    radius = v / w
    end = theta + w * dt
    return Pose2D(pose.x + radius * (math.sin(end) - math.sin(theta)),
                  pose.y - radius * (math.cos(end) - math.cos(theta)), wrap_angle(end))
