"""agv_runner: the robot's side of FleetControl (thesis 3.6.2, 5.2).

Serves the wire protocol (fleet_common.wire: a ROUTER on the robot's command
port from robot_definitions.txt, CurveZMQ with the lab's keys, pose feedback
on the feedback port at `feedback_rate` Hz) and runs the commands, one at a
time, through the ROS navigator (`ros_navigator`) behind a `WireNavigator`,
which converts base cells to robot metres. A bumper press stops the robot
and raises the "bumper" fault (`wire_navigator`).

Parameters (private, see config/*.yaml and launch/*.launch): robot_id,
definitions, keys_dir, bind, feedback_port, feedback_rate, bumper_type,
camera_mount, tag_size, motion, localization, commands (what the robot
refuses: fleet_common.wire.command_check, on the lab's map when it localizes
on the lab's tags). Also publishes `~pose`
(geometry_msgs/PoseStamped, frame `world`: the fused pose, robot-frame metres)
at the feedback rate.
"""
from __future__ import annotations

import logging
import sys
import time
from typing import Callable, Dict

import rospy
import zmq
from std_msgs.msg import UInt8

from fleet_common.errors import FleetError
from fleet_common.lab import node_table
from fleet_common.robots import RobotDefinition, read_robot_definitions
from fleet_common.transport.curve_keys import load_robot_keys
from fleet_common.transport.robot_endpoint import RobotEndpoint
from fleet_common.transport.robot_loop import RobotLoop
from fleet_common.transport.zap import ZapHandler
from fleet_common.wire.command_check import CommandCheck
from geometry_msgs.msg import PoseStamped

from .grid_frame import GridFrame
from .ros_messages import pose_stamped
from .ros_navigator import RosLocalization, make_navigator
from .runner_settings import RunnerSettings
from .tag_map import LAB, load_tag_map
from .wire_navigator import WireNavigator


def _find_robot(settings: RunnerSettings) -> RobotDefinition:
    robots = read_robot_definitions(settings.definitions or None)
    for robot in robots:
        if robot.id == settings.robot_id:
            return robot
    raise FleetError("robot {} is not in {} (robots there: {})".format(
        settings.robot_id, settings.definitions or "robot_definitions.txt",
        ", ".join(str(r.id) for r in robots)))


def _subscribe_bumper(kind: str, report: Callable[[bool], None]) -> None:
    if kind == "mask":
        rospy.Subscriber("mobile_base/sensors/bumper", UInt8,
                         lambda msg: report(msg.data != 0), queue_size=10)
        return
    from kobuki_msgs.msg import BumperEvent  # only on a real TurtleBot (ROS Noetic)

    pressed: Dict[int, bool] = {}

    def on_event(msg: "BumperEvent") -> None:
        pressed[msg.bumper] = msg.state == BumperEvent.PRESSED
        report(any(pressed.values()))

    rospy.Subscriber("mobile_base/events/bumper", BumperEvent, on_event, queue_size=10)


def _log_execution(robot_id: int, epoch: str, command: object) -> None:
    """One line per command the robot carries out: its log shows that none ran twice."""
    rospy.loginfo("agv_runner: robot %d executing %s %d of manager %s", robot_id,
                  getattr(command, "TYPE", "?"), getattr(command, "id", -1), epoch)


def main() -> None:
    rospy.init_node("agv_runner")
    log = logging.getLogger("rosout.agv_runner")  # rospy forwards "rosout.*" to /rosout
    try:
        settings = RunnerSettings.from_params(rospy.get_param("~"))
        robot = _find_robot(settings)
        tags = load_tag_map(settings.localization.tag_map)
        keys = load_robot_keys(settings.keys_dir or None)
    except FleetError as err:
        rospy.logfatal("agv_runner: %s", err)
        sys.exit(2)

    localization = RosLocalization(settings.localization, settings.mount, tags)
    navigator = make_navigator(settings.motion, localization)
    # the robot's map: the lab's, or none when it localizes on another tag map
    grid = node_table().grid() if settings.localization.tag_map == LAB else None
    wire = WireNavigator(navigator, GridFrame())
    navigator.interlock = wire.interlock
    _subscribe_bumper(settings.bumper_type, wire.bumper)

    pose_pub = rospy.Publisher("~pose", PoseStamped, queue_size=10)

    def publish_pose(_event: object) -> None:
        pose = wire.robot_pose()
        if pose is not None:
            pose_pub.publish(pose_stamped(rospy.Time.now(), "world", pose))

    rospy.Timer(rospy.Duration(1.0 / settings.feedback_rate), publish_pose)

    context = zmq.Context()
    zap = ZapHandler(context, log, time.monotonic)
    bind = settings.bind or robot.host
    try:
        endpoint = RobotEndpoint(context, robot.id, wire, robot.command_port,
                                 settings.feedback_port, bind=bind, keys=keys, zap=zap, log=log,
                                 feedback_rate=settings.feedback_rate,
                                 check=CommandCheck(grid, settings.commands),
                                 on_execute=lambda epoch, command: _log_execution(
                                     robot.id, epoch, command))
    except FleetError as err:
        rospy.logfatal("agv_runner: %s", err)
        context.term()
        sys.exit(2)
    rospy.loginfo("agv_runner: robot %d serving commands on %s:%d, pose feedback on port %d",
                  robot.id, bind, robot.command_port, settings.feedback_port)
    loop = RobotLoop(zap, log=log)
    loop.add(endpoint)
    try:
        loop.run(rospy.is_shutdown)
    finally:
        endpoint.close()
        zap.socket.close()
        context.term()
