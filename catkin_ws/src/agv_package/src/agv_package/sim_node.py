"""sim_turtlebot: a simulated TurtleBot 2 base standing in for the Kobuki driver and camera.

Topics (relative, so a launch file can namespace or remap them):

- subscribes `mobile_base/commands/velocity` (geometry_msgs/Twist); a command
  older than half a second counts as stop, like the Kobuki's own timeout;
- publishes `odom` (nav_msgs/Odometry, frame `odom`, drifting; the odometry
  frame starts on the lab's robot frame), `camera/image_raw`
  (sensor_msgs/Image, mono8) with `camera/camera_info` (sensor_msgs/CameraInfo,
  same stamp), `mobile_base/sensors/bumper` (std_msgs/UInt8, latched: the
  Kobuki's bumper bits, 1 right, 2 centre, 4 left, 0 released; sent on every
  change and once a second; kobuki_msgs is not in Debian) and
  `sim/ground_truth` (nav_msgs/Odometry, frame `world`: where the base really is,
  for tests and demos);
- subscribes `sim/hold` (std_msgs/Float64, seconds): the base is held where it
  is that long whatever it is commanded (a stall: a visitor's hand, a wheel
  caught), then obeys again; for tests and demos.

The walls are the lab grid's blocked cells and its edge. The physics is in
`sim.base_model`, the camera in `sim.floor_camera`, the bumper in `sim.walls`.
"""
from __future__ import annotations

import sys
import threading
import time

import rospy
from geometry_msgs.msg import Twist as TwistMsg
from nav_msgs.msg import Odometry
from sensor_msgs.msg import CameraInfo, Image
from std_msgs.msg import Float64, UInt8

from fleet_common.errors import FleetError
from fleet_common.lab import node_table

from .grid_frame import GridFrame
from .motion import STOP
from .ros_messages import odometry_msg, twist_from_msg
from .sim.base_model import BaseModel
from .sim.floor_camera import FloorCamera
from .sim.sim_settings import SimSettings
from .sim.walls import Walls
from .tag_map import load_tag_map

#: Seconds after which the last velocity command no longer counts (Kobuki: 0.6 s).
COMMAND_TIMEOUT = 0.5
#: Longest physics step, so that a stalled loop does not teleport the base.
MAX_STEP = 0.05


def camera_info(settings: SimSettings) -> CameraInfo:
    fx, fy, cx, cy = settings.intrinsics
    info = CameraInfo()
    info.header.frame_id = "camera"
    info.width, info.height = settings.width, settings.height
    info.distortion_model = "plumb_bob"
    info.D = [0.0] * 5
    info.K = [fx, 0.0, cx, 0.0, fy, cy, 0.0, 0.0, 1.0]
    info.R = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0]
    info.P = [fx, 0.0, cx, 0.0, 0.0, fy, cy, 0.0, 0.0, 0.0, 1.0, 0.0]
    return info


def main() -> None:
    rospy.init_node("sim_turtlebot")
    try:
        settings = SimSettings.from_params(rospy.get_param("~"))
        tags = load_tag_map(settings.tag_map)
    except FleetError as err:
        rospy.logfatal("sim_turtlebot: %s", err)
        sys.exit(2)
    frame = GridFrame()
    table = node_table()
    walls = Walls(table.grid(), frame)
    start = frame.pose_to_robot(settings.start)
    if walls.touching(start) or table.node_at((round(settings.start.x),
                                                round(settings.start.y))) is None:
        rospy.logwarn("sim_turtlebot: the start (%.2f, %.2f) is not on a free lab node",
                      settings.start.x, settings.start.y)
    base = BaseModel(start, settings.noise, settings.max_accel, settings.max_turn_accel,
                     seed=settings.seed)
    camera = FloorCamera(tags, settings.tag_size, settings.mount, settings.width,
                         settings.height, settings.intrinsics, settings.image_noise,
                         seed=settings.seed + 1)
    info = camera_info(settings)

    odom_pub = rospy.Publisher("odom", Odometry, queue_size=10)
    truth_pub = rospy.Publisher("sim/ground_truth", Odometry, queue_size=10)
    image_pub = rospy.Publisher("camera/image_raw", Image, queue_size=2)
    info_pub = rospy.Publisher("camera/camera_info", CameraInfo, queue_size=2)
    bumper_pub = rospy.Publisher("mobile_base/sensors/bumper", UInt8, queue_size=10, latch=True)

    lock = threading.Lock()
    latest = {"twist": STOP, "at": 0.0, "held_until": 0.0}

    def on_velocity(msg: TwistMsg) -> None:
        with lock:
            latest["twist"] = twist_from_msg(msg)
            latest["at"] = time.monotonic()

    def on_hold(msg: Float64) -> None:
        seconds = msg.data if 0.0 <= msg.data <= 3600.0 else 0.0  # a hold is a stall, not a shutdown
        rospy.logwarn("sim_turtlebot: held where it is for %.1f s", seconds)
        with lock:
            latest["held_until"] = time.monotonic() + seconds

    rospy.Subscriber("mobile_base/commands/velocity", TwistMsg, on_velocity, queue_size=1)
    rospy.Subscriber("sim/hold", Float64, on_hold, queue_size=1)

    rate = rospy.Rate(settings.physics_rate)
    last = time.monotonic()
    next_odom = next_camera = next_bumper = last
    bumper = -1
    while not rospy.is_shutdown():
        now = time.monotonic()
        with lock:
            command = latest["twist"] if now - latest["at"] < COMMAND_TIMEOUT else STOP
            if now < latest["held_until"]:
                command = STOP
        base.step(command, min(now - last, MAX_STEP), walls.touching)
        last = now
        stamp = rospy.Time.now()
        pressed = walls.bumper(base.truth)
        if pressed != bumper or now >= next_bumper:
            if pressed != bumper and pressed:
                rospy.logwarn("sim_turtlebot: bumper pressed (bits %d) at (%.2f, %.2f)",
                              pressed, base.truth.x, base.truth.y)
            bumper, next_bumper = pressed, now + 1.0
            bumper_pub.publish(UInt8(pressed))
        if now >= next_odom:
            next_odom = max(next_odom + 1.0 / settings.odom_rate, now)
            odom_pub.publish(odometry_msg(stamp, "odom", "base_footprint", base.odom,
                                          base.odom_velocity))
            truth_pub.publish(odometry_msg(stamp, "world", "base_footprint", base.truth,
                                           base.velocity))
        if now >= next_camera:
            next_camera = max(next_camera + 1.0 / settings.camera_rate, now)
            image = Image()
            image.header.stamp = stamp
            image.header.frame_id = "camera"
            image.height, image.width = settings.height, settings.width
            image.encoding, image.step = "mono8", settings.width
            image.data = camera.render(base.truth).tobytes()
            info.header.stamp = stamp
            image_pub.publish(image)
            info_pub.publish(info)
        try:
            rate.sleep()
        except rospy.ROSInterruptException:
            break
