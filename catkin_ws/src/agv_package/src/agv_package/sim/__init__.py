"""The simulated TurtleBot 2: base kinematics with odometry errors, walls, floor camera."""
from __future__ import annotations
