"""Floor tags: the tag map, tag pose -> robot pose, and the simulated camera's frames
detected by pupil-apriltags (the same detector the robot runs)."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from agv_package.camera_model import CameraMount, floor_to_pixels
from agv_package.geometry import Pose2D
from agv_package.sim.floor_camera import FloorCamera, marker_bitmap
from agv_package.tag_localizer import TagLocalizer
from agv_package.tag_map import TagMap, TagPlacement, load_tag_map, node_tag_id
from agv_package.tag_pose import robot_pose_from_tag, tag_in_camera
from fleet_common.angles import wrap_angle
from fleet_common.errors import FormatError
from fleet_common.lab import node_table

K = (420.0, 420.0, 319.5, 239.5)
MOUNT = CameraMount(0.05, 0.0, 0.30)


def test_lab_tag_map_has_a_distinct_tag36h11_id_for_every_node() -> None:
    tags = load_tag_map()
    table = node_table()
    assert len(tags) == len(table)
    assert all(0 <= tag_id < 587 for tag_id in tags)  # the family's ids
    assert node_tag_id(419) == 419 and node_tag_id(597) == 10 and node_tag_id(623) == 36
    assert tags.get(419) == TagPlacement(1.4, 2.1, 0.0)  # node 419: cell (1, 0)


def test_yaml_tag_map(tmp_path: Path) -> None:
    path = tmp_path / "tags.yaml"
    path.write_text("tags:\n  - {id: 5, position: [1.0, 2.0]}\n"
                    "  - {id: 6, position: [1.7, 2.0], yaw_deg: 90}\n")
    tags = load_tag_map(str(path))
    assert tags.get(6) == TagPlacement(1.7, 2.0, pytest.approx(math.pi / 2))
    assert list(tags) == [5, 6]


@pytest.mark.parametrize("text, line, message", [
    ("tags:\n  - {id: 5, position: [1.0]}\n", 2, "position must be [X, Y]"),
    ("tags:\n  - {id: 5, position: [1, 2]}\n  - {id: 5, position: [3, 4]}\n", 3,
     "tag 5 is listed twice"),
    ("tags:\n  - {id: -1, position: [1, 2]}\n", 2, "non-negative integer"),
    ("tags:\n  - {id: 1, position: [1, x]}\n", 2, "position Y must be a number"),
    ("tags:\n  - {id: 1, pos: [1, 2]}\n", 2, "a tag is {id: N, position: [X, Y]}"),
    ("nodes: []\n", 1, "expected a mapping with one key, tags"),
])
def test_malformed_tag_map_names_file_and_line(tmp_path: Path, text: str, line: int,
                                               message: str) -> None:
    path = tmp_path / "tags.yaml"
    path.write_text(text)
    with pytest.raises(FormatError) as caught:
        load_tag_map(str(path))
    assert caught.value.path == str(path) and caught.value.line == line
    assert message in caught.value.message


def test_missing_tag_map_file_says_how_to_use_the_lab(tmp_path: Path) -> None:
    with pytest.raises(FormatError, match="or give tag_map: lab"):
        load_tag_map(str(tmp_path / "nope.yaml"))


poses = st.builds(Pose2D, st.floats(-5, 5), st.floats(-5, 5), st.floats(-math.pi, math.pi))
mounts = st.builds(CameraMount, st.floats(-0.2, 0.2), st.floats(-0.2, 0.2), st.floats(0.1, 1.0),
                   st.floats(-math.pi, math.pi))
places = st.builds(TagPlacement, st.floats(-5, 5), st.floats(-5, 5), st.floats(-math.pi, math.pi))


@given(poses, mounts, places)
def test_robot_pose_from_a_perfect_observation_is_exact(robot: Pose2D, mount: CameraMount,
                                                        place: TagPlacement) -> None:
    seen = tag_in_camera(robot, place, mount)
    pose, height = robot_pose_from_tag(seen, place, mount)
    assert pose.distance_to(robot) < 1e-9
    assert abs(wrap_angle(pose.theta - robot.theta)) < 1e-9
    assert abs(height) < 1e-9


def test_floor_to_pixels_centres_the_point_under_the_camera() -> None:
    robot = Pose2D(1.0, 2.0, 0.3)
    camera_x = 1.0 + 0.05 * math.cos(0.3)
    camera_y = 2.0 + 0.05 * math.sin(0.3)
    pixel = floor_to_pixels(robot, MOUNT, K) @ np.array([camera_x, camera_y, 1.0])
    assert pixel == pytest.approx([319.5, 239.5])
    ahead = floor_to_pixels(robot, MOUNT, K) @ np.array(
        [camera_x + 0.1 * math.cos(0.3), camera_y + 0.1 * math.sin(0.3), 1.0])
    assert ahead == pytest.approx([319.5, 239.5 - 0.1 * 420 / 0.3])  # ahead = up the image


@pytest.fixture(scope="module")
def camera_and_localizer() -> tuple:
    tags = load_tag_map()
    camera = FloorCamera(tags, 0.12, MOUNT, 640, 480, K, noise=2.0, seed=4)
    return camera, TagLocalizer(tags, 0.12, MOUNT, quad_decimate=2.0, min_decision_margin=30)


def test_rendered_tags_are_detected_with_their_id_and_millimetre_poses(
        camera_and_localizer: tuple) -> None:
    camera, localizer = camera_and_localizer
    rng = np.random.default_rng(11)
    ids = list(camera.tags)
    errors, headings, missed = [], [], 0
    for _ in range(60):
        tag_id = ids[int(rng.integers(len(ids)))]
        place = camera.tags.get(tag_id)
        robot = Pose2D(place.x + rng.uniform(-0.03, 0.03), place.y + rng.uniform(-0.03, 0.03),
                       rng.uniform(-math.pi, math.pi))
        fixes = [f for f in localizer.locate(camera.render(robot), K).fixes if f.tag_id == tag_id]
        if not fixes:
            missed += 1
            continue
        errors.append(fixes[0].pose.distance_to(robot))
        headings.append(abs(wrap_angle(fixes[0].pose.theta - robot.theta)))
    assert missed <= 3
    assert max(errors) < 0.005 and math.degrees(max(headings)) < 1.0


def test_an_empty_floor_gives_no_fix(camera_and_localizer: tuple) -> None:
    camera, localizer = camera_and_localizer
    between = Pose2D(1.75, 2.45, 0.0)  # between four nodes: no tag in view
    assert camera.visible_tags(between) == []
    assert localizer.locate(camera.render(between), K) == ([], [])


def test_tags_are_drawn_upright_as_apriltag_defines_them(camera_and_localizer: tuple) -> None:
    camera, localizer = camera_and_localizer
    # Robot on node 419 facing +x: the drawn tag (yaw 0) must give heading 0; a map claiming
    # the tag lies turned by 90 degrees makes the same view read as a robot turned by 90.
    robot = Pose2D(1.4, 2.1, 0.0)
    assert localizer.locate(camera.render(robot), K).fixes[0].pose.theta == pytest.approx(
        0.0, abs=0.01)
    turned = TagMap({419: TagPlacement(1.4, 2.1, math.pi / 2)}, "test")
    fix = TagLocalizer(turned, 0.12, MOUNT).locate(camera.render(robot), K).fixes[0]
    assert fix.pose.theta == pytest.approx(math.pi / 2, abs=0.01)
    assert marker_bitmap(419).shape == (240, 240)


def test_unknown_tags_and_bad_geometry_are_reported_not_used(
        camera_and_localizer: tuple) -> None:
    camera, _ = camera_and_localizer
    frame = camera.render(Pose2D(1.4, 2.1, 0.0))
    others = TagLocalizer(TagMap({1: TagPlacement(0, 0, 0)}, "tags.yaml"), 0.12, MOUNT)
    assert others.locate(frame, K) == ([], [(419, "not in the tag map (tags.yaml)")])
    wrong_size = TagLocalizer(camera.tags, 0.24, MOUNT)  # twice the printed size
    located = wrong_size.locate(frame, K)
    assert located.fixes == [] and "off the floor" in located.rejected[0][1]
    with pytest.raises(ValueError, match="mono8"):
        wrong_size.locate(frame.astype(np.float32), K)
