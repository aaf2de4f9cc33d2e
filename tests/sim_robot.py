"""A simulated robot under ROS for tests and benchmarks: roscore, sim_robot.launch, the
manager's end of the wire, and a rospy node that watches the robot's topics.

`running_sim_robot(home)` starts roscore and sim_robot.launch (the agv_runner node driving the
simulated TurtleBot 2 on the lab's floor grid) on loopback ports, joins that master from this
process with an `Observer` node (/odom, the simulator's ground truth, the runner's AprilTag
fixes and fused pose, camera frames), and connects the manager's own `RobotLink` (`Manager`),
and stops it all on the way out. tests/test_ros_sim_robot.py checks what it does;
bench/sim_robot.py times it. Call it inside a network namespace of its own
(`ros_procs.run_inside_netns`): roscore's rosout listens on every interface.
"""
from __future__ import annotations

import math
import threading
import time
from collections import deque
from contextlib import contextmanager
from pathlib import Path
from typing import Callable, Deque, Dict, Iterator, List, Optional, Tuple

import numpy as np
import zmq

from agv_package.geometry import Pose2D, interpolate
from agv_package.grid_frame import GridFrame
from agv_package.tag_map import load_tag_map
from fleet_common.robots import RobotDefinition, format_robot_definitions
from fleet_common.transport.curve_keys import ManagerKeys, load_manager_keys, make_keys
from fleet_common.wire.link_events import LinkDown, LinkUp, RobotReply
from fleet_common.transport.links import LinkSet
from fleet_common.transport.robot_link import RobotLink
from fleet_common.wire import PoseFeedback
from helpers import free_port
from live import Proc
from ros_procs import ROSLAUNCH, leave_ros, master_up, ros_environment, set_ros_variables, wait_for

__all__ = ["ROBOT_ID", "START", "AT_NODE", "Manager", "Observer", "SimRobot", "running_sim_robot"]


class Manager:
    """The manager's end of the robot: the manager's own `RobotLink` in a `LinkSet` (CURVE,
    handshake, heartbeats, reconnects as in `fleetctl manager`), seen one command at a
    time: replies and poses are kept as the link reports them."""

    def __init__(self, robot: RobotDefinition, keys: ManagerKeys) -> None:
        self.context = zmq.Context()
        self.link = RobotLink(self.context, robot, "test-epoch", keys=keys, host="127.0.0.1")
        self.links = LinkSet([self.link])
        self.replies: Deque[object] = deque()
        self.poses: List[Tuple[float, PoseFeedback]] = []
        self.up: Optional[LinkUp] = None

    def _serve(self, seconds: float) -> None:
        for event in self.links.poll(seconds):
            if isinstance(event, RobotReply):
                self.replies.append(event.reply)
            elif isinstance(event, PoseFeedback):
                self.poses.append((time.monotonic(), event))
            elif isinstance(event, LinkUp):
                self.up = event
            elif isinstance(event, LinkDown):
                raise AssertionError("the link went down: {}".format(event.reason))

    def wait_up(self, timeout: float) -> LinkUp:
        deadline = time.monotonic() + timeout
        while self.up is None:
            if time.monotonic() > deadline:
                raise AssertionError("no Welcome from the robot within {:.0f} s".format(timeout))
            self._serve(0.05)
        return self.up

    def receive(self, timeout: float) -> object:
        """The robot's next reply to a command (heartbeats are the link's business)."""
        deadline = time.monotonic() + timeout
        while not self.replies:
            if time.monotonic() > deadline:
                raise AssertionError("no reply from the robot within {:.0f} s".format(timeout))
            self._serve(0.05)
        return self.replies.popleft()

    def wait_for(self, condition: Callable[[], bool], timeout: float, what: str) -> None:
        """Wait for `condition`, serving the link meanwhile (heartbeats, replies, poses)."""
        deadline = time.monotonic() + timeout
        while not condition():
            if time.monotonic() > deadline:
                raise AssertionError("timed out after {:.0f} s waiting for {}".format(timeout, what))
            self._serve(0.02)

    def send(self, issue: Callable[[RobotLink], int]) -> int:
        """Issue a command through the link (e.g. `lambda link: link.stop()`); its id."""
        return issue(self.link)

    def run(self, issue: Callable[[RobotLink], int], timeout: float = 60.0) -> Tuple[List[object], float]:
        """Send a command; its replies up to the final one, and the seconds it took."""
        started = time.monotonic()
        command_id = self.send(issue)
        replies: List[object] = []
        while True:
            reply = self.receive(timeout)
            assert getattr(reply, "id", None) == command_id, reply
            replies.append(reply)
            if reply.TYPE in ("completed", "failed", "status"):
                return replies, time.monotonic() - started

    def feedback_since(self, seconds: float) -> List[Tuple[float, PoseFeedback]]:
        """Pose feedback received over the next `seconds` (the newest at each read)."""
        self._serve(0.0)
        self.poses = []
        deadline = time.monotonic() + seconds
        while time.monotonic() < deadline:
            self._serve(0.05)
        return list(self.poses)

    def next_poses(self, count: int, timeout: float = 10.0) -> List[PoseFeedback]:
        """The next `count` pose feedback messages (AssertionError if they take over `timeout` s)."""
        self._serve(0.0)
        self.poses = []
        deadline = time.monotonic() + timeout
        while len(self.poses) < count:
            if time.monotonic() > deadline:
                raise AssertionError("{} poses in {:.0f} s, expected {}".format(len(self.poses), timeout, count))
            self._serve(0.05)
        return [message for _, message in self.poses[:count]]

    def close(self) -> None:
        self.links.close()
        self.context.destroy(linger=0)


# ---- the observing ROS node -------------------------------------------------------

#: A camera frame counts as "taken at a node" when the base is this close to the node (m).
AT_NODE = 0.03


class Observer:
    """Records what the robot's topics say, from a rospy node in the test process."""

    def __init__(self) -> None:
        import rospy
        from geometry_msgs.msg import PoseStamped
        from nav_msgs.msg import Odometry
        from sensor_msgs.msg import CameraInfo, Image
        from std_msgs.msg import UInt8

        from agv_package.camera_model import CameraMount
        from agv_package.image_convert import image_to_grey
        from agv_package.ros_messages import intrinsics_from_k, pose_from_msg
        from agv_package.tag_localizer import TagLocalizer

        self._lock = threading.Lock()
        self._grey = image_to_grey
        self._pose = pose_from_msg
        self._intrinsics_from_k = intrinsics_from_k
        self.tags = load_tag_map()
        # The runner's own detector settings (config/camera.yaml, navigation.yaml).
        self.localizer = TagLocalizer(self.tags, 0.12, CameraMount(0.05, 0.0, 0.30),
                                      quad_decimate=2.0)
        self.truth: List[Tuple[float, Pose2D]] = []
        self.odom: Optional[Pose2D] = None
        self.fused: Optional[Pose2D] = None
        self.fused_stamp = 0.0
        self.fixes: List[Tuple[float, Pose2D]] = []
        self.frames: List[Tuple[float, int, List[int]]] = []  # (stamp, expected id, seen ids)
        self.intrinsics: Optional[Tuple[float, float, float, float]] = None
        self.bumper = rospy.Publisher("/mobile_base/sensors/bumper", UInt8, queue_size=1,
                                      latch=True)
        self.subscribers = [
            rospy.Subscriber("/sim/ground_truth", Odometry, self._on_truth, queue_size=100),
            rospy.Subscriber("/odom", Odometry, self._on_odom, queue_size=100),
            rospy.Subscriber("/agv_runner/pose", PoseStamped, self._on_fused, queue_size=100),
            rospy.Subscriber("/agv_runner/tag_fix", PoseStamped, self._on_fix, queue_size=100),
            rospy.Subscriber("/camera/camera_info", CameraInfo, self._on_info, queue_size=1),
            rospy.Subscriber("/camera/image_raw", Image, self._on_image, queue_size=5,
                             buff_size=1 << 24),
        ]

    def _on_truth(self, msg: object) -> None:
        with self._lock:
            self.truth.append((msg.header.stamp.to_sec(), self._pose(msg.pose.pose)))

    def _on_odom(self, msg: object) -> None:
        self.odom = self._pose(msg.pose.pose)

    def _on_fused(self, msg: object) -> None:
        self.fused = self._pose(msg.pose)
        self.fused_stamp = msg.header.stamp.to_sec()

    def _on_fix(self, msg: object) -> None:
        with self._lock:
            self.fixes.append((msg.header.stamp.to_sec(), self._pose(msg.pose)))

    def _on_info(self, msg: object) -> None:
        self.intrinsics = self._intrinsics_from_k(msg.K)

    def _on_image(self, msg: object) -> None:
        with self._lock:
            latest = self.truth[-1][1] if self.truth else None
        if latest is None or self.intrinsics is None:
            return
        near = [(tag_id, place) for tag_id, place in self.tags.items()
                if math.hypot(place.x - latest.x, place.y - latest.y) < 2 * AT_NODE]
        if not near:
            return  # only frames taken at (or next to) a node are judged
        grey = self._grey(msg.encoding, msg.height, msg.width, msg.step, msg.data)
        seen = [o.tag_id for o in self.localizer.observe(grey, self.intrinsics)]
        with self._lock:
            self.frames.append((msg.header.stamp.to_sec(), near[0][0], seen))

    def truth_at(self, stamp: float) -> Pose2D:
        with self._lock:
            history = list(self.truth)
        stamps = [s for s, _ in history]
        i = int(np.searchsorted(stamps, stamp))
        if i == 0 or i >= len(history):
            return history[min(i, len(history) - 1)][1]
        (t0, p0), (t1, p1) = history[i - 1], history[i]
        return interpolate(p0, p1, (stamp - t0) / (t1 - t0) if t1 > t0 else 0.0)

    def latest_truth(self) -> Pose2D:
        with self._lock:
            return self.truth[-1][1]

    def at_rest(self, window: float = 0.25) -> bool:
        """The simulated base has not moved (1 mm, 0.1 degree) over the last `window` seconds."""
        with self._lock:
            if not self.truth or self.truth[-1][0] - self.truth[0][0] < window:
                return False
            stamp, now = self.truth[-1]
        before = self.truth_at(stamp - window)
        return now.distance_to(before) < 0.001 and abs(before.heading_error_to(now)) < 0.002

    def rested_since(self) -> float:
        with self._lock:
            return self.truth[-1][0]

    def press_bumper(self, bits: int) -> None:
        from std_msgs.msg import UInt8

        self.bumper.publish(UInt8(bits))


# ---- the robot, started ------------------------------------------------------------------------

class SimRobot:
    """What `running_sim_robot` gives: the manager's link, the observer, the grid frame."""

    def __init__(self, manager: Manager, observer: Observer, frame: GridFrame,
                 launch: Proc) -> None:
        self.manager = manager
        self.observer = observer
        self.frame = frame
        self.launch = launch

    def settle(self, timeout: float = 10.0) -> None:
        """Wait until the base is at rest and a fused pose the runner computed after that has
        come in (the topics caught up with the stopped base)."""
        self.manager.wait_for(self.observer.at_rest, timeout, "the base to come to rest")
        rested = self.observer.rested_since()
        self.manager.wait_for(lambda: self.observer.fused_stamp > rested, timeout,
                              "a fused pose after the base came to rest")


ROBOT_ID = 3
START = (0, 2)  # base cell of node 406, heading +x


@contextmanager
def running_sim_robot(home: Path) -> Iterator[SimRobot]:
    """roscore, sim_robot.launch (robot ROBOT_ID on START), an observing rospy node in this
    process and the manager's link, up and localized; all stopped on the way out."""
    master_port, command_port, feedback_port = free_port(), free_port(), free_port()
    env = ros_environment(master_port, home)
    keys_dir = home / "keys"
    make_keys(keys_dir)
    definitions = home / "robot_definitions.txt"
    robot = RobotDefinition(ROBOT_ID, "127.0.0.1", command_port, "turtlebot", "turtlebot3", "blue")
    definitions.write_text(format_robot_definitions([robot]))
    started: List[Proc] = []
    saved: Optional[Dict[str, Optional[str]]] = None
    manager: Optional[Manager] = None
    try:
        roscore = Proc(["roscore", "-p", str(master_port)], home / "roscore.log", env)
        started.append(roscore)
        wait_for(lambda: master_up(env["ROS_MASTER_URI"]), 30.0, "roscore", roscore)
        launch = Proc(
            ROSLAUNCH + ["agv_package", "sim_robot.launch",
             "robot_id:={}".format(ROBOT_ID), "definitions:={}".format(definitions),
             "keys_dir:={}".format(keys_dir), "feedback_port:={}".format(feedback_port),
             "start_x:={}".format(START[0]), "start_y:={}".format(START[1]), "seed:=7",
             "max_step:=2.5"],  # the test's route drives two cells at a time
            home / "roslaunch.log", env)
        started.append(launch)
        # This process's own node joins the same master (loopback only).
        saved = set_ros_variables(env)
        import rospy

        rospy.init_node("fleet_test_observer", anonymous=True, disable_signals=True)
        observer = Observer()
        wait_for(lambda: observer.fused is not None, 60.0,
                 "the runner's first AprilTag-corrected pose", launch)
        manager = Manager(robot, load_manager_keys(keys_dir))
        manager.wait_up(10.0)
        assert manager.link.feedback_port == feedback_port
        yield SimRobot(manager, observer, GridFrame(), launch)
    finally:
        if manager is not None:
            manager.close()
        leave_ros(started, saved)
