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
from typing import Iterator, List

import pytest

from agv_package.geometry import Pose2D
from fleet_common.angles import wrap_angle
from ros_procs import netns_marker, run_inside_netns
from sim_robot import AT_NODE, START, Observer, SimRobot, running_sim_robot

pytestmark = pytest.mark.slow

inside_netns = netns_marker(__file__)


def test_ros_in_own_network_namespace() -> None:
    run_inside_netns(__file__, min_passed=2)


@pytest.fixture(scope="module")
def sim_robot(tmp_path_factory: pytest.TempPathFactory) -> Iterator[SimRobot]:
    with running_sim_robot(tmp_path_factory.mktemp("ros")) as robot:
        yield robot


# ---- the tests -----------------------------------------------------------------------

def assert_completed(replies: List[object], what: str) -> None:
    kinds = [r.TYPE for r in replies]
    assert kinds == ["accepted", "completed"], "{}: {}".format(what, replies)


@inside_netns
def test_manager_drives_the_robot_across_six_cells_with_turns(sim_robot: SimRobot) -> None:
    manager, observer, frame = sim_robot.manager, sim_robot.observer, sim_robot.frame

    # Pose feedback: in base cells, at the start node, in order (its rate: bench/sim_robot.py).
    feedback = manager.next_poses(10)
    seqs = [message.seq for message in feedback]
    assert seqs == sorted(seqs) and len(set(seqs)) == len(seqs)
    start = feedback[-1].pose
    assert math.hypot(start.x - START[0], start.y - START[1]) < 0.03, start

    route = [
        ("2 cells east, as fast as allowed", lambda link: link.drive_to_position(2.0, 2.0, 0.0)),
        ("left turn, 2 cells north in 8 s", lambda link: link.drive_to_position(2.0, 4.0, 8.0)),
        ("right turn, 2 cells east", lambda link: link.drive_to_position(4.0, 4.0, 0.0)),
        ("turn to face north", lambda link: link.turn(math.pi / 2)),
    ]
    corrected_errors = []
    for what, make in route:
        replies, _ = manager.run(make)  # (how close to 8 s the timed drive arrives: the bench)
        assert_completed(replies, what)
        sim_robot.settle()
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
    print("\nodom {:.3f} m {:.2f} deg from target; {} fixes, worst {:.4f} m;"
          " fused at stops worst {:.4f} m; frames at nodes {}/{} with their tag".format(
              odom_error, odom_heading, len(fix_errors), max(fix_errors),
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
    before = observer.latest_truth()
    drive_id = manager.send(lambda link: link.drive_to_position(goal[0], goal[1], 0.0))
    assert manager.receive(10.0).TYPE == "accepted"
    manager.wait_for(lambda: observer.latest_truth().distance_to(before) > 0.1, 20.0, "the drive to get under way")
    observer.press_bumper(2)  # centre part
    failed = manager.receive(5.0)
    assert failed.TYPE == "failed" and failed.id == drive_id, failed
    assert "bumper" in failed.reason
    manager.wait_for(observer.at_rest, 5.0, "the base to stop after the bumper press")
    stopped = observer.latest_truth()
    faults = [message.faults for message in manager.next_poses(5)]
    assert all("bumper" in f for f in faults), faults

    # While the fault stands nothing moves; a stop acknowledges it once the bumper is free.
    replies, _ = manager.run(lambda link: link.drive_to_position(goal[0], goal[1], 0.0))
    assert [r.TYPE for r in replies] == ["failed"] and "bumper" in replies[0].reason
    observer.press_bumper(0)
    assert observer.latest_truth().distance_to(stopped) < 0.005, "it moved while the fault stood"

    def acknowledged() -> bool:  # a stop clears the fault once the runner has seen the release
        assert_completed(manager.run(lambda link: link.stop())[0], "stop")
        return manager.run(lambda link: link.get_status())[0][-1].faults == ()

    manager.wait_for(acknowledged, 10.0, "a stop to clear the released bumper's fault")
    replies, _ = manager.run(lambda link: link.drive_to_position(goal[0], goal[1], 0.0))
    assert_completed(replies, "the drive after the fault was cleared")
