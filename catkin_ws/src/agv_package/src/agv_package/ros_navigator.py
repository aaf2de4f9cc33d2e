"""The ROS Navigator: AprilTag fixes from the camera fused with /odom, Twist to the base.

`RosLocalization` subscribes `odom` (nav_msgs/Odometry), `camera/camera_info`
(sensor_msgs/CameraInfo, for the intrinsics) and `camera/image_raw`
(sensor_msgs/Image, rectified; newest frame only), feeds a `PoseFusion` and
publishes `~tag_fix` (each accepted fix, geometry_msgs/PoseStamped, frame
`world`, stamped with its camera frame's time). `make_navigator` joins it to a
`ControlledNavigator` that publishes geometry_msgs/Twist on
`mobile_base/commands/velocity` (remap it to the velocity mux input on a real
robot). The math lives in the pure modules; this one only moves messages.
"""
from __future__ import annotations

import threading
import time
from typing import Optional

import rospy
from geometry_msgs.msg import PoseStamped
from geometry_msgs.msg import Twist as TwistMsg
from nav_msgs.msg import Odometry
from sensor_msgs.msg import CameraInfo, Image

from .camera_model import CameraMount, Intrinsics
from .geometry import Pose2D
from .image_convert import image_to_grey
from .motion import Twist
from .navigator import ControlledNavigator
from .pose_fusion import PoseFusion
from .ros_messages import intrinsics_from_k, pose_from_msg, pose_stamped, twist_msg
from .settings import LocalizationSettings, MotionSettings
from .tag_localizer import TagLocalizer
from .tag_map import TagMap

#: Odometry older than this (seconds) means the base driver stopped: no pose, no motion.
ODOM_STALE = 0.5
#: Seconds between repeated warnings about frames or fixes that could not be used.
WARN_EVERY = 5.0


class RosLocalization:
    """Where the robot is, from odometry and floor tags; thread-safe `pose()`."""

    def __init__(self, settings: LocalizationSettings, mount: CameraMount, tags: TagMap) -> None:
        self.fusion = PoseFusion(settings.fusion_gain, settings.max_jump, settings.odom_history)
        self.localizer = TagLocalizer(tags, settings.tag_size, mount, settings.quad_decimate,
                                      settings.min_decision_margin, settings.max_hamming)
        self._lock = threading.Lock()
        self._intrinsics: Optional[Intrinsics] = None
        self._odom_seen = 0.0  # monotonic time of the last odometry message
        self.frames = 0
        self.fixes = 0
        self._fix_pub = rospy.Publisher("~tag_fix", PoseStamped, queue_size=10)
        rospy.Subscriber("odom", Odometry, self._on_odom, queue_size=50)
        rospy.Subscriber("camera/camera_info", CameraInfo, self._on_info, queue_size=1)
        rospy.Subscriber("camera/image_raw", Image, self._on_image, queue_size=1,
                         buff_size=1 << 24)

    def pose(self) -> Optional[Pose2D]:
        with self._lock:
            if time.monotonic() - self._odom_seen > ODOM_STALE:
                return None
            return self.fusion.pose()

    def _on_odom(self, msg: Odometry) -> None:
        with self._lock:
            self.fusion.add_odometry(msg.header.stamp.to_sec(), pose_from_msg(msg.pose.pose))
            self._odom_seen = time.monotonic()

    def _on_info(self, msg: CameraInfo) -> None:
        self._intrinsics = intrinsics_from_k(msg.K)

    def _on_image(self, msg: Image) -> None:
        intrinsics = self._intrinsics
        if intrinsics is None:
            rospy.logwarn_throttle(WARN_EVERY, "agv_runner: no camera_info yet; frames ignored")
            return
        try:
            grey = image_to_grey(msg.encoding, msg.height, msg.width, msg.step, msg.data)
        except ValueError as err:
            rospy.logerr_throttle(WARN_EVERY, "agv_runner: %s" % err)
            return
        located = self.localizer.locate(grey, intrinsics)
        self.frames += 1
        stamp = msg.header.stamp.to_sec()
        for tag_id, why in located.rejected:
            rospy.logwarn_throttle(WARN_EVERY, "agv_runner: tag %d not used: %s" % (tag_id, why))
        for fix in located.fixes:
            with self._lock:
                accepted, why = self.fusion.add_fix(stamp, fix.pose)
            if accepted:
                self.fixes += 1
                self._fix_pub.publish(pose_stamped(msg.header.stamp, "world", fix.pose))
            else:
                rospy.logwarn_throttle(WARN_EVERY, "agv_runner: fix from tag %d refused: %s"
                                       % (fix.tag_id, why))


def make_navigator(motion: MotionSettings, localization: RosLocalization) -> ControlledNavigator:
    """A navigator that reads `localization` and publishes Twist to the base."""
    publisher = rospy.Publisher("mobile_base/commands/velocity", TwistMsg, queue_size=1)

    def send(twist: Twist) -> None:
        publisher.publish(twist_msg(twist))

    return ControlledNavigator(motion, localization.pose, send, clock=time.time)
