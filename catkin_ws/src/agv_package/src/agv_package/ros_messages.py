"""Conversions between our plain values and ROS messages (rospy nodes only).

The few places where a `Pose2D`, a `Twist` or a frame meets a ROS message,
kept together so that the node modules stay short. Imports rospy's message
classes: never imported by the pure modules.
"""
from __future__ import annotations

import math
from typing import Tuple

from geometry_msgs.msg import Pose, PoseStamped, Quaternion
from geometry_msgs.msg import Twist as TwistMsg
from nav_msgs.msg import Odometry

from .camera_model import Intrinsics
from .geometry import Pose2D
from .motion import Twist


def yaw_quaternion(yaw: float) -> Quaternion:
    return Quaternion(0.0, 0.0, math.sin(yaw / 2.0), math.cos(yaw / 2.0))


def quaternion_yaw(q: Quaternion) -> float:
    return math.atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z))


def pose_msg(pose: Pose2D) -> Pose:
    out = Pose()
    out.position.x, out.position.y = pose.x, pose.y
    out.orientation = yaw_quaternion(pose.theta)
    return out


def pose_from_msg(pose: Pose) -> Pose2D:
    return Pose2D(pose.position.x, pose.position.y, quaternion_yaw(pose.orientation))


def odometry_msg(stamp: object, frame: str, child: str, pose: Pose2D, velocity: Twist) -> Odometry:
    out = Odometry()
    out.header.stamp = stamp
    out.header.frame_id = frame
    out.child_frame_id = child
    out.pose.pose = pose_msg(pose)
    out.twist.twist.linear.x = velocity.linear
    out.twist.twist.angular.z = velocity.angular
    return out


def pose_stamped(stamp: object, frame: str, pose: Pose2D) -> PoseStamped:
    out = PoseStamped()
    out.header.stamp = stamp
    out.header.frame_id = frame
    out.pose = pose_msg(pose)
    return out


def twist_msg(twist: Twist) -> TwistMsg:
    out = TwistMsg()
    out.linear.x = twist.linear
    out.angular.z = twist.angular
    return out


def twist_from_msg(msg: TwistMsg) -> Twist:
    return Twist(msg.linear.x, msg.angular.z)


def intrinsics_from_k(k: Tuple[float, ...]) -> Intrinsics:
    """(fx, fy, cx, cy) from CameraInfo's row-major 3x3 K."""
    return (float(k[0]), float(k[4]), float(k[2]), float(k[5]))
