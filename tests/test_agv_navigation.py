"""Navigation without ROS: pose fusion, the controllers, and the navigator closed around the
simulated base, camera and tag detector on a simulated clock (no waiting)."""
from __future__ import annotations

import math
from pathlib import Path
from typing import List, Tuple

import pytest
import yaml

from agv_package.camera_model import CameraMount
from agv_package.geometry import Pose2D
from agv_package.grid_frame import GridFrame
from agv_package.motion import STOP, DriveController, TurnController, Twist
from agv_package.navigator import ControlledNavigator
from agv_package.pose_fusion import PoseFusion
from agv_package.settings import MotionSettings
from agv_package.sim.base_model import BaseModel, BaseNoise
from agv_package.sim.floor_camera import FloorCamera
from agv_package.tag_localizer import TagLocalizer
from agv_package.tag_map import load_tag_map
from fleet_common.angles import wrap_angle
from fleet_common.wire.navigator import MotionOutcome

CONFIG = Path(__file__).resolve().parents[1] / "catkin_ws" / "src" / "agv_package" / "config"
MOTION = MotionSettings.from_dict(yaml.safe_load((CONFIG / "navigation.yaml").read_text())["motion"])
K = (420.0, 420.0, 319.5, 239.5)
MOUNT = CameraMount(0.05, 0.0, 0.30)


# ---- pose fusion -----------------------------------------------------------------------

def test_not_localized_until_a_fix_or_reset() -> None:
    fusion = PoseFusion()
    assert fusion.pose() is None and not fusion.reset(Pose2D(1, 1, 0))  # no odometry yet
    fusion.add_odometry(0.0, Pose2D(0.0, 0.0, 0.0))
    assert fusion.pose() is None
    assert fusion.reset(Pose2D(1.0, 2.0, math.pi / 2))
    fusion.add_odometry(1.0, Pose2D(1.0, 0.0, 0.0))  # odometry: 1 m ahead
    assert fusion.pose().distance_to(Pose2D(1.0, 3.0, 0.0)) < 1e-9


def test_a_late_fix_corrects_with_the_odometry_of_its_own_time() -> None:
    fusion = PoseFusion(gain=1.0)
    for i in range(11):  # driving along x at 1 m/s, odometry 10 % short
        fusion.add_odometry(i * 0.1, Pose2D(0.09 * i, 0.0, 0.0))
    # A frame taken at t = 0.5 (odometry 0.45) says the robot was really at 0.5.
    accepted, _ = fusion.add_fix(0.5, Pose2D(0.5, 0.0, 0.0))
    assert accepted
    assert fusion.pose().x == pytest.approx(0.9 + 0.05)  # now: odometry 0.9 + the 0.05 found


def test_gain_pulls_part_way_and_far_fixes_are_refused() -> None:
    fusion = PoseFusion(gain=0.5, max_jump=0.3)
    fusion.add_odometry(0.0, Pose2D(0.0, 0.0, 0.0))
    fusion.add_fix(0.0, Pose2D(1.0, 1.0, 0.0))  # first fix: taken whole
    fusion.add_fix(0.0, Pose2D(1.1, 1.0, 0.0))
    assert fusion.pose().x == pytest.approx(1.05)
    accepted, why = fusion.add_fix(0.0, Pose2D(2.0, 1.0, 0.0))  # a misread tag
    assert not accepted and "max_jump" in why
    assert (fusion.accepted, fusion.refused) == (2, 1)
    accepted, why = fusion.add_fix(5.0, Pose2D(1.0, 1.0, 0.0))  # no odometry that late
    assert not accepted and "time stamp" in why


def test_odometry_history_is_trimmed_and_survives_a_restart() -> None:
    fusion = PoseFusion(history=1.0)
    for i in range(50):
        fusion.add_odometry(i * 0.1, Pose2D(i * 0.1, 0.0, 0.0))
    assert fusion.odometry_at(2.0) is None and fusion.odometry_at(4.5).x == pytest.approx(4.5)
    fusion.add_odometry(0.0, Pose2D(0.0, 0.0, 0.0))  # the base driver restarted
    assert fusion.odometry_at(0.0) == Pose2D(0.0, 0.0, 0.0)


# ---- controllers on a perfect base -----------------------------------------------------

def integrate(pose: Pose2D, twist: Twist, dt: float) -> Pose2D:
    return Pose2D(pose.x + twist.linear * dt * math.cos(pose.theta),
                  pose.y + twist.linear * dt * math.sin(pose.theta),
                  wrap_angle(pose.theta + twist.angular * dt))


def run(controller: object, pose: Pose2D, dt: float = 0.05) -> Tuple[Pose2D, float, List[Twist]]:
    t, sent = 0.0, []
    while True:
        twist = controller.step(pose, t, dt)
        if twist is None:
            return pose, t, sent
        sent.append(twist)
        pose = integrate(pose, twist, dt)
        t += dt
        assert t < 120, "controller never finished"


@pytest.mark.parametrize("start, goal", [(0.0, math.pi / 2), (3.0, -3.0), (0.0, math.pi),
                                         (1.0, 1.01)])
def test_turn_ends_within_tolerance_without_exceeding_limits(start: float, goal: float) -> None:
    pose, _, sent = run(TurnController(MOTION, goal), Pose2D(1, 1, start))
    assert abs(wrap_angle(pose.theta - goal)) <= MOTION.heading_tolerance + 1e-9
    assert all(t.linear == 0 and abs(t.angular) <= MOTION.max_turn_rate for t in sent)


def test_drive_arrives_at_the_requested_time() -> None:
    start = Pose2D(0.7, 2.1, 0.0)
    controller = DriveController(MOTION, start, (2.1, 2.1), arrival=8.0)  # 1.4 m in 8 s
    pose, took, sent = run(controller, start)
    assert pose.distance_to(Pose2D(2.1, 2.1, 0)) < 0.012
    assert took == pytest.approx(8.0, abs=0.3)
    assert max(t.linear for t in sent) <= MOTION.max_speed


def test_drive_with_no_time_goes_at_top_speed_and_steers_back_onto_the_line() -> None:
    start = Pose2D(0.0, 0.05, math.radians(10))  # 5 cm off the line and pointing off it
    controller = DriveController(MOTION, Pose2D(0, 0, 0), (2.8, 0.0), arrival=0.0)
    pose, took, sent = run(controller, start)
    assert abs(pose.y) < 0.005 and abs(pose.x - 2.8) < 0.012
    assert max(t.linear for t in sent) == pytest.approx(MOTION.max_speed)
    assert took < 2.8 / MOTION.max_speed + 2.0


# ---- the navigator around the simulated robot ------------------------------------------

class World:
    """The simulated base, camera and detector on a simulated clock advanced by `sleep`."""

    def __init__(self, start_cell: Tuple[int, int], noise: BaseNoise, seed: int) -> None:
        self.frame = GridFrame()
        tags = load_tag_map()
        self.base = BaseModel(self.frame.pose_to_robot(Pose2D(*start_cell, 0.0)), noise,
                              seed=seed)
        self.camera = FloorCamera(tags, 0.12, MOUNT, 640, 480, K, seed=seed)
        self.localizer = TagLocalizer(tags, 0.12, MOUNT, quad_decimate=2.0)
        self.fusion = PoseFusion(0.5, 0.3, 2.0)
        self.now, self.command, self.next_frame = 0.0, STOP, 0.0
        self.fusion.add_odometry(0.0, self.base.odom)
        self.sleep(0.1)

    def sleep(self, seconds: float) -> None:
        end = self.now + seconds
        while self.now < end - 1e-9:
            step = min(0.01, end - self.now)
            self.base.step(self.command, step)
            self.now += step
            self.fusion.add_odometry(self.now, self.base.odom)
            if self.now >= self.next_frame:  # 15 Hz camera
                self.next_frame += 1.0 / 15.0
                for fix in self.localizer.locate(self.camera.render(self.base.truth), K).fixes:
                    self.fusion.add_fix(self.now, fix.pose)

    def navigator(self) -> ControlledNavigator:
        return ControlledNavigator(MOTION, self.fusion.pose,
                                   lambda twist: setattr(self, "command", twist),
                                   clock=lambda: self.now, sleep=self.sleep)


def test_tag_fixes_keep_the_robot_on_the_grid_while_odometry_drifts() -> None:
    # 4 % wheel slip and a sloppy gyro: odometry ends far off, the robot does not.
    world = World((0, 2), BaseNoise(slip=0.04, slip_walk=0.01, gyro_noise=0.02, turn_slip=0.05),
                  seed=5)
    navigator = world.navigator()
    for cell in [(3, 2), (3, 5), (6, 5), (6, 3)]:
        goal = world.frame.point_to_robot(*cell)
        assert navigator.drive_to_position(goal[0], goal[1], world.now).ok
        world.sleep(0.3)
        truth = world.base.truth
        assert math.hypot(truth.x - goal[0], truth.y - goal[1]) < 0.03, cell
        assert world.fusion.pose().distance_to(truth) < 0.01
    assert navigator.turn(math.pi).ok
    assert abs(wrap_angle(world.base.truth.theta - math.pi)) < math.radians(2)
    assert world.base.odom.distance_to(world.base.truth) > 0.15  # what the tags made up for


def test_navigator_refuses_to_move_without_a_pose_and_stops_when_told() -> None:
    sent: List[Twist] = []
    lost = ControlledNavigator(MOTION, lambda: None, sent.append, clock=lambda: 0.0,
                               sleep=lambda s: None)
    result = lost.drive_to_position(1.0, 1.0, 0.0)
    assert not result.ok and "not localized" in result.reason and sent == [STOP]

    world = World((0, 2), BaseNoise(), seed=1)
    navigator = world.navigator()
    navigator.interlock = lambda: "bumper pressed" if world.now > 1.0 else None
    goal = world.frame.point_to_robot(4, 2)
    result = navigator.drive_to_position(goal[0], goal[1], 0.0)
    assert result == MotionOutcome(False, "bumper pressed") and world.command == STOP
    assert world.now < 1.2


def test_a_drive_with_a_hold_point_waits_there_and_goes_on_when_released() -> None:
    # the simulated robot (base, camera, tags) drives 2 cells east; it may go 0.5 m only
    world = World((0, 2), BaseNoise(), seed=2)
    navigator = world.navigator()
    goal = world.frame.point_to_robot(2, 2)
    start = world.base.truth
    hold = (start.x + 0.5, start.y)
    result: List[MotionOutcome] = []
    releases = {12.0: (start.x + 1.0, start.y), 25.0: goal}  # long after it reached the hold point

    def sleep(seconds: float) -> None:  # the manager releases it while it waits
        World.sleep(world, seconds)
        for at in sorted(releases):
            if world.now >= at:
                navigator.release(*releases.pop(at))
        positions.append((world.now, world.base.truth.x - start.x))

    positions: List[Tuple[float, float]] = []
    navigator._sleep = sleep
    result.append(navigator.drive_to_position(goal[0], goal[1], 0.0, hold))
    assert result == [MotionOutcome(True)]  # no time-out while it waited (25 s)
    before_release = [x for t, x in positions if t < 12.0]
    assert max(before_release) <= 0.5 + MOTION.position_tolerance  # never past its hold point
    assert before_release[-1] == pytest.approx(0.5, abs=MOTION.position_tolerance)  # stopped there
    second = [x for t, x in positions if 12.0 <= t < 25.0]
    assert max(second) <= 1.0 + MOTION.position_tolerance and second[-1] == pytest.approx(1.0, abs=0.02)
    assert world.base.truth.x - start.x == pytest.approx(1.4, abs=0.02)
