"""ROS integration: a real roscore, sim_robot.launch started with roslaunch, and a manager
talking the wire protocol over TCP (CurveZMQ) to the agv_runner node.

The runner drives the simulated TurtleBot 2 (sim_turtlebot) across the lab's
floor grid; the test watches /odom, the simulator's ground truth, the
runner's AprilTag fixes and fused pose, and the camera frames, from a rospy
node of its own. Processes run in their own process groups and are stopped by
group id (SIGINT, then SIGKILL), also when a test fails. Nodes started by
roslaunch run with their shebang's `python3`, so the venv's bin folder goes
first on PATH: the venv is Debian's python3 with system site packages, which
has rospy and the pip packages (pupil-apriltags, OpenCV).

About a minute: roscore and roslaunch take ~5 s to start, the drives ~40 s.
"""
from __future__ import annotations

import math
import sys
import threading
import time
from collections import deque
from typing import Callable, Deque, Dict, Iterator, List, Optional, Tuple

import numpy as np
import pytest
import zmq

from agv_package.geometry import Pose2D, interpolate
from agv_package.grid_frame import GridFrame
from agv_package.tag_map import load_tag_map
from fleet_common.angles import wrap_angle
from fleet_common.robots import RobotDefinition, format_robot_definitions
from fleet_common.wire import PoseFeedback
from fleet_common.transport.curve_keys import ManagerKeys, load_manager_keys, make_keys
from fleet_common.transport.link_events import LinkDown, LinkUp, RobotReply
from fleet_common.transport.links import LinkSet
from fleet_common.transport.robot_link import RobotLink
from helpers import free_port
from live import Proc
from ros_procs import (ROSLAUNCH, master_up, netns_marker, ros_environment, run_inside_netns,
                       set_ros_variables, wait_for)

pytestmark = pytest.mark.slow

inside_netns = netns_marker(__file__)


def test_ros_in_own_network_namespace() -> None:
    run_inside_netns(__file__, min_passed=2)


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

    def close(self) -> None:
        self.links.close()
        self.context.destroy(linger=0)


# ---- the test's own ROS node -------------------------------------------------------

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

    def press_bumper(self, bits: int) -> None:
        from std_msgs.msg import UInt8

        self.bumper.publish(UInt8(bits))


# ---- fixtures ------------------------------------------------------------------------

class SimRobot:
    def __init__(self, manager: Manager, observer: Observer, frame: GridFrame,
                 launch: Proc) -> None:
        self.manager = manager
        self.observer = observer
        self.frame = frame
        self.launch = launch


ROBOT_ID = 3
START = (0, 2)  # base cell of node 406, heading +x


@pytest.fixture(scope="module")
def sim_robot(tmp_path_factory: pytest.TempPathFactory) -> Iterator[SimRobot]:
    home = tmp_path_factory.mktemp("ros")
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
             "max_step:=2.5"],  # the route below drives two cells at a time
            home / "roslaunch.log", env)
        started.append(launch)
        # The test's own node joins the same master (loopback only).
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
        if "rospy" in sys.modules and sys.modules["rospy"].core.is_initialized():
            sys.modules["rospy"].signal_shutdown("integration test done")
        for process in reversed(started):
            process.stop()
        if saved is not None:
            set_ros_variables(saved)


# ---- the tests -----------------------------------------------------------------------

def settle(robot: SimRobot, seconds: float = 0.4) -> None:
    """Let the stopped base's topics catch up (fused pose at 20 Hz, truth at 50 Hz)."""
    time.sleep(seconds)


def assert_completed(replies: List[object], what: str) -> None:
    kinds = [r.TYPE for r in replies]
    assert kinds == ["accepted", "completed"], "{}: {}".format(what, replies)


@inside_netns
def test_manager_drives_the_robot_across_six_cells_with_turns(sim_robot: SimRobot) -> None:
    manager, observer, frame = sim_robot.manager, sim_robot.observer, sim_robot.frame

    # Pose feedback: 10 Hz or more, in base cells, at the start node.
    feedback = manager.feedback_since(2.0)
    seqs = [message.seq for _, message in feedback]
    assert seqs == sorted(seqs)
    rate = (seqs[-1] - seqs[0]) / (feedback[-1][0] - feedback[0][0])  # poses the robot sent
    assert rate >= 10.0, "pose feedback at {:.1f} Hz".format(rate)
    start = feedback[-1][1].pose
    assert math.hypot(start.x - START[0], start.y - START[1]) < 0.03, start

    route = [
        ("2 cells east, as fast as allowed", lambda link: link.drive_to_position(2.0, 2.0, 0.0)),
        ("left turn, 2 cells north in 8 s", lambda link: link.drive_to_position(2.0, 4.0, 8.0)),
        ("right turn, 2 cells east", lambda link: link.drive_to_position(4.0, 4.0, 0.0)),
        ("turn to face north", lambda link: link.turn(math.pi / 2)),
    ]
    corrected_errors = []
    for what, make in route:
        replies, took = manager.run(make)
        assert_completed(replies, what)
        if "in 8 s" in what:
            assert abs(took - 8.0) < 1.0, "asked to arrive in 8 s, took {:.2f} s".format(took)
        settle(sim_robot)
        corrected_errors.append(observer.fused.distance_to(observer.latest_truth()))
    target = frame.pose_to_robot(Pose2D(4.0, 4.0, math.pi / 2))

    # The base's own odometry ends on the target: the runner steered by the tags, and the
    # simulated odometry's drift over this route is small (sim.yaml).
    odom = observer.odom
    odom_error = odom.distance_to(target)
    odom_heading = math.degrees(abs(wrap_angle(odom.theta - target.theta)))
    assert odom_error < 0.05 and odom_heading < 5.0, (odom, target)

    # The AprilTag-corrected pose: every tag fix and the fused pose at every stop agree with
    # where the simulated base really is.
    fix_errors = [pose.distance_to(observer.truth_at(stamp)) for stamp, pose in observer.fixes]
    assert len(fix_errors) >= 50
    assert max(fix_errors) < 0.03, "worst tag fix {:.3f} m off".format(max(fix_errors))
    assert max(corrected_errors) < 0.03, corrected_errors

    # Camera frames taken at nodes show the node's tag.
    judged = [(expected, seen) for stamp, expected, seen in observer.frames
              if _at(observer, stamp, expected)]
    hits = sum(1 for expected, seen in judged if expected in seen)
    assert len(judged) >= 20, "only {} frames taken at nodes".format(len(judged))
    assert hits >= 0.8 * len(judged), "{} of {} frames at nodes show their tag".format(
        hits, len(judged))

    # The status over the wire says the same, in base cells.
    replies, _ = manager.run(lambda link: link.get_status())
    status = replies[-1]
    assert status.current is None and status.faults == ()
    assert math.hypot(status.pose.x - 4.0, status.pose.y - 4.0) < 0.05, status.pose
    print("\nfeedback {:.1f} Hz; odom {:.3f} m {:.2f} deg from target; {} fixes, worst {:.4f} m;"
          " fused at stops worst {:.4f} m; frames at nodes {}/{} with their tag".format(
              rate, odom_error, odom_heading, len(fix_errors), max(fix_errors),
              max(corrected_errors), hits, len(judged)))


def _at(observer: Observer, stamp: float, tag_id: int) -> bool:
    place = observer.tags.get(tag_id)
    truth = observer.truth_at(stamp)
    return math.hypot(place.x - truth.x, place.y - truth.y) < AT_NODE


@inside_netns
def test_bumper_press_stops_the_robot_and_reports_a_fault(sim_robot: SimRobot) -> None:
    manager, observer = sim_robot.manager, sim_robot.observer
    here = sim_robot.frame.pose_to_base(observer.fused)
    cell = (round(here.x), round(here.y))
    goal = (cell[0], cell[1] + 2)  # two cells north: (4, 6) after the route test
    drive_id = manager.send(lambda link: link.drive_to_position(goal[0], goal[1], 0.0))
    assert manager.receive(10.0).TYPE == "accepted"
    time.sleep(1.5)  # under way
    observer.press_bumper(2)  # centre part
    failed = manager.receive(5.0)
    assert failed.TYPE == "failed" and failed.id == drive_id, failed
    assert "bumper" in failed.reason
    time.sleep(0.5)  # the base brakes
    before = observer.latest_truth()
    time.sleep(0.5)
    assert observer.latest_truth().distance_to(before) < 0.005, "the base did not stop"
    faults = [message.faults for _, message in manager.feedback_since(0.5)]
    assert faults and all("bumper" in f for f in faults), faults

    # While the fault stands nothing moves; a stop acknowledges it once the bumper is free.
    replies, _ = manager.run(lambda link: link.drive_to_position(goal[0], goal[1], 0.0))
    assert [r.TYPE for r in replies] == ["failed"] and "bumper" in replies[0].reason
    observer.press_bumper(0)
    time.sleep(0.3)
    replies, _ = manager.run(lambda link: link.stop())
    assert_completed(replies, "stop")
    replies, _ = manager.run(lambda link: link.get_status())
    assert replies[-1].faults == ()
    replies, _ = manager.run(lambda link: link.drive_to_position(goal[0], goal[1], 0.0))
    assert_completed(replies, "the drive after the fault was cleared")
