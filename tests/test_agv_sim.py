"""The simulated TurtleBot 2 without ROS: odometry that drifts, walls that press the bumper,
and camera frames converted from sensor_msgs/Image bytes."""
from __future__ import annotations

import math

import numpy as np
import pytest

from agv_package.geometry import Pose2D
from agv_package.grid_frame import GridFrame
from agv_package.image_convert import image_to_grey
from agv_package.motion import Twist
from agv_package.sim.base_model import BaseModel, BaseNoise
from agv_package.sim.walls import CENTRE, LEFT, RIGHT, Walls
from fleet_common.lab import node_table

QUIET = BaseNoise(slip=0.0, slip_walk=0.0, encoder_noise=0.0, gyro_noise=0.0, turn_slip=0.0)


def drive(base: BaseModel, twist: Twist, seconds: float, walls: Walls = None) -> None:
    for _ in range(int(round(seconds / 0.01))):
        base.step(twist, 0.01, walls.touching if walls is not None else (lambda pose: False))


def test_a_perfect_base_follows_its_commands_exactly() -> None:
    base = BaseModel(Pose2D(0.0, 0.0, 0.0), QUIET, max_accel=100.0, max_turn_accel=100.0)
    drive(base, Twist(0.2, 0.0), 5.0)
    drive(base, Twist(0.0, math.pi / 4), 2.0)
    drive(base, Twist(0.2, 0.0), 5.0)
    assert base.truth.distance_to(Pose2D(1.0, 1.0, 0.0)) < 0.01
    assert base.truth == base.odom


def test_slipping_wheels_make_odometry_run_ahead_of_the_truth() -> None:
    base = BaseModel(Pose2D(0.0, 0.0, 0.0), BaseNoise(slip=0.02, slip_walk=0.0), seed=1)
    drive(base, Twist(0.3, 0.0), 10.0)
    assert base.odom.x - base.truth.x == pytest.approx(0.02 * base.odom.x, rel=0.2)
    assert base.velocity == Twist(0.3, 0.0)  # after the acceleration ramp


def test_acceleration_is_limited() -> None:
    base = BaseModel(Pose2D(0.0, 0.0, 0.0), QUIET, max_accel=1.0)
    base.step(Twist(0.5, 0.0), 0.1)
    assert base.velocity.linear == pytest.approx(0.1)


@pytest.fixture(scope="module")
def walls() -> Walls:
    return Walls(node_table().grid(), GridFrame())


def test_nodes_are_clear_of_walls(walls: Walls) -> None:
    frame = GridFrame()
    for cell in node_table().grid().free_cells():
        for heading in (0.0, math.pi / 2, math.pi, -math.pi / 2):
            assert walls.bumper(frame.pose_to_robot(Pose2D(cell[0], cell[1], heading))) == 0


def test_driving_into_a_blocked_cell_presses_the_bumper_and_stalls(walls: Walls) -> None:
    frame = GridFrame()
    # Node 607 at (3, 1); the cell east of it, (4, 1), is blocked.
    base = BaseModel(frame.pose_to_robot(Pose2D(3, 1, 0.0)), QUIET)
    drive(base, Twist(0.2, 0.0), 4.0, walls)
    assert walls.bumper(base.truth) & CENTRE
    stalled_at = base.truth.x
    wall_x = frame.point_to_robot(3.5, 1)[0]
    assert stalled_at == pytest.approx(wall_x - 0.177, abs=0.01)
    drive(base, Twist(0.2, 0.0), 1.0, walls)
    assert base.truth.x == stalled_at  # pushing does nothing
    drive(base, Twist(-0.1, 0.0), 1.0, walls)
    assert walls.bumper(base.truth) == 0  # backing off releases it


def test_bumper_sides(walls: Walls) -> None:
    frame = GridFrame()
    near_edge = frame.pose_to_robot(Pose2D(0, 5, 0.0))
    # West edge of the grid at x = -0.5 cells: touch it with the left or right side.
    west = frame.point_to_robot(-0.5, 5)[0]
    facing_north = Pose2D(west + 0.17, near_edge.y, math.pi / 2)
    assert walls.bumper(facing_north) == LEFT
    facing_south = Pose2D(west + 0.17, near_edge.y, -math.pi / 2)
    assert walls.bumper(facing_south) == RIGHT


def test_image_bytes_to_grey() -> None:
    mono = bytes(range(12))  # 3 rows of 4, with one byte of row padding
    grey = image_to_grey("mono8", 3, 3, 4, mono)
    assert grey.tolist() == [[0, 1, 2], [4, 5, 6], [8, 9, 10]]
    rgb = bytes([255, 0, 0, 0, 255, 0])
    assert image_to_grey("rgb8", 1, 2, 6, rgb).tolist() == [[76, 150]]
    assert image_to_grey("bgr8", 1, 2, 6, rgb).tolist() == [[29, 150]]
    with pytest.raises(ValueError, match="'yuv422' are not supported; use one of 8UC1, bgr8"):
        image_to_grey("yuv422", 1, 2, 4, bytes(4))
    with pytest.raises(ValueError, match="needs step >= 6"):
        image_to_grey("rgb8", 1, 2, 4, bytes(4))
    assert image_to_grey("mono8", 2, 2, 2, bytes(4)).dtype == np.uint8
