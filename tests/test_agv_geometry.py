"""Robot-side geometry: planar poses and the base-grid <-> robot-frame conversion."""
from __future__ import annotations

import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

from agv_package.geometry import Pose2D, interpolate
from agv_package.grid_frame import GridFrame
from fleet_common.angles import wrap_angle
from fleet_common.frames import readable
from fleet_common.lab import node_table

coords = st.floats(-50, 50, allow_nan=False)
angles = st.floats(-10, 10, allow_nan=False)
poses = st.builds(Pose2D, coords, coords, angles.map(wrap_angle))


def close(a: Pose2D, b: Pose2D, tol: float = 1e-7) -> bool:
    return a.distance_to(b) < tol and abs(wrap_angle(a.theta - b.theta)) < tol


@given(angles)
def test_wrap_angle_lands_in_half_open_interval(angle: float) -> None:
    wrapped = wrap_angle(angle)
    assert -math.pi < wrapped <= math.pi
    assert math.isclose(math.cos(wrapped), math.cos(angle), abs_tol=1e-9)
    assert math.isclose(math.sin(wrapped), math.sin(angle), abs_tol=1e-9)


@given(poses, poses)
def test_compose_with_inverse_and_relative(a: Pose2D, b: Pose2D) -> None:
    assert close(a.compose(a.inverse()), Pose2D(0.0, 0.0, 0.0))
    assert close(a.compose(b.relative_to(a)), b, 1e-6)


def test_compose_moves_in_the_parent_frame() -> None:
    facing_north = Pose2D(1.0, 2.0, math.pi / 2)
    assert close(facing_north.compose(Pose2D(1.0, 0.0, 0.0)), Pose2D(1.0, 3.0, math.pi / 2))


def test_interpolate_turns_the_short_way() -> None:
    half = interpolate(Pose2D(0, 0, math.radians(170)), Pose2D(2, 0, math.radians(-170)), 0.5)
    assert half.x == 1.0 and abs(abs(half.theta) - math.pi) < 1e-9


def test_lab_frame_puts_cells_where_the_node_table_says() -> None:
    frame = GridFrame()
    table = node_table()
    assert frame.cell_size() == pytest.approx(0.7)
    for node_id in table.ids():
        cell = table.cell_of(node_id)
        assert frame.point_to_robot(*cell) == pytest.approx(table.cell_to_metres(cell))
    assert frame.point_to_robot(0, 0) == pytest.approx((0.7, 2.1))
    assert frame.heading_to_robot(1.0) == pytest.approx(1.0)  # no rotation in the lab


@given(poses)
def test_pose_round_trip_through_a_rotated_mirrored_frame(pose: Pose2D) -> None:
    frame = GridFrame(readable(0.5, 30.0, (2.0, -1.0), True, "base", "robot"))
    assert close(frame.pose_to_base(frame.pose_to_robot(pose)), pose, 1e-6)


def test_headings_follow_a_mirror_and_a_rotation() -> None:
    mirrored = GridFrame(readable(0.7, 0.0, (0.0, 0.0), True, "base", "robot"))
    assert mirrored.heading_to_robot(math.pi / 2) == pytest.approx(-math.pi / 2)
    rotated = GridFrame(readable(0.7, 90.0, (0.0, 0.0), False, "base", "robot"))
    assert rotated.heading_to_robot(0.0) == pytest.approx(math.pi / 2)
    assert rotated.point_to_robot(1.0, 0.0) == pytest.approx((0.0, 0.7))
