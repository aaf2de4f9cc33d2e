"""The real robot path: `fleetctl manager` drives two simulated TurtleBots (sim_robot.launch,
agv_runner over sim_turtlebot, each in its own ROS namespace under one real roscore) through
short lab plans with ADG, over CurveZMQ.

Here the two robots' paths cross at one cell, so the Action Dependency Graph has to order them
(tests/test_ros_train.py: two robots as a train, the leader held mid-move). Judged by the
simulator's ground truth (each robot ends within 5 cm of its goal cell) and by the runners'
own logs (each command id carried out once). About a minute and a half; runs in its own
network namespace (tests/ros_procs.py).
"""
from __future__ import annotations

import math
import re
import threading
from pathlib import Path
from typing import Dict, List, Optional, Tuple

import pytest

from agv_package.geometry import Pose2D
from agv_package.grid_frame import GridFrame
from fleet_common.robots import RobotDefinition, format_robot_definitions
from fleet_common.transport.curve_keys import make_keys
from helpers import free_port_block
from live import Proc, fleetctl_args
from ros_procs import (ROSLAUNCH, leave_ros, master_up, netns_marker, ros_environment, run_inside_netns,
                       set_ros_variables, wait_for)

pytestmark = pytest.mark.slow
inside_netns = netns_marker(__file__)

Robots = Dict[int, Tuple[Tuple[int, int], Tuple[int, int]]]
#: robot id -> (start, goal), base cells of lab nodes; the paths cross at (2, 2)
ROBOTS: Robots = {1: ((0, 2), (4, 2)), 2: ((2, 4), (2, 0))}


def test_ros_manager_in_own_network_namespace() -> None:
    run_inside_netns(__file__, min_passed=1)


def launch_file(home: Path, definitions: Path, keys: Path, feedback: Dict[int, int],
                robots: Robots = ROBOTS) -> Path:
    groups = []
    for rid, (start, _) in robots.items():
        groups.append(
            '  <group ns="robot{rid}">\n'
            '    <include file="$(find agv_package)/launch/sim_robot.launch">\n'
            '      <arg name="robot_id" value="{rid}"/>\n'
            '      <arg name="definitions" value="{defs}"/>\n'
            '      <arg name="keys_dir" value="{keys}"/>\n'
            '      <arg name="feedback_port" value="{fb}"/>\n'
            '      <arg name="start_x" value="{x}"/>\n'
            '      <arg name="start_y" value="{y}"/>\n'
            '      <arg name="seed" value="{rid}"/>\n'
            '    </include>\n'
            '  </group>\n'.format(rid=rid, defs=definitions, keys=keys, fb=feedback[rid],
                                 x=start[0], y=start[1]))
    path = home / "two_robots.launch"
    path.write_text("<launch>\n{}</launch>\n".format("".join(groups)))
    return path


class Truth:
    """The simulator's ground truth of each robot, in base cells (a rospy node of the test's)."""

    def __init__(self, robots: Robots = ROBOTS) -> None:
        import rospy
        from nav_msgs.msg import Odometry

        self.frame = GridFrame()
        self.latest: Dict[int, Pose2D] = {}
        self.closest = math.inf  # metres between the two robots' centres, the least seen
        self._lock = threading.Lock()
        self._subs = [rospy.Subscriber("/robot{}/sim/ground_truth".format(rid), Odometry,
                                       self._on(rid), queue_size=10) for rid in robots]

    def _on(self, rid: int):
        def callback(msg: object) -> None:
            p = msg.pose.pose  # type: ignore[attr-defined]
            theta = 2.0 * math.atan2(p.orientation.z, p.orientation.w)
            with self._lock:
                self.latest[rid] = self.frame.pose_to_base(Pose2D(p.position.x, p.position.y, theta))
                if len(self.latest) == 2:
                    a, b = self.latest.values()
                    self.closest = min(self.closest, math.hypot(a.x - b.x, a.y - b.y) * self.frame.cell_size())
        return callback

    def where(self, rid: int) -> Pose2D:
        with self._lock:
            return self.latest[rid]


class TwoTurtleBots:
    """Two simulated TurtleBots on the lab (sim_robot.launch under one real roscore) and the
    manager driving them from `robots`' starts to their goals: one test's files, ports and
    processes (each started one is appended to `started`, for `leave_ros`)."""

    def __init__(self, home: Path, robots: Robots, name: str, started: List[Proc]) -> None:
        base = free_port_block(6)
        self.home, self.robots, self.started = home, robots, started
        master_port, self.console_port = base, base + 1
        commands = {rid: base + 2 + k for k, rid in enumerate(sorted(robots))}
        self.feedback = {rid: base + 4 + k for k, rid in enumerate(sorted(robots))}
        self.env = ros_environment(master_port, home)
        self.keys = home / "keys"
        make_keys(self.keys)
        self.definitions = home / "robot_definitions.txt"
        self.definitions.write_text(format_robot_definitions([
            RobotDefinition(rid, "127.0.0.1", commands[rid], "turtlebot", "turtlebot{}".format(rid), colour)
            for rid, colour in zip(sorted(robots), ("red", "green"))]))
        self.instance = home / name
        self.instance.write_text("map_file=lab.map\nagents=2\norientation=base\n" + "".join(
            "{},{},{},{}\n".format(s[0], s[1], g[0], g[1]) for s, g in robots.values()))

    def start_robots(self) -> Proc:
        """roscore, then both simulated robots' runners; the roslaunch process."""
        env = self.env
        roscore = Proc(["roscore", "-p", env["ROS_MASTER_URI"].rsplit(":", 1)[1]], self.home / "roscore.log", env)
        self.started.append(roscore)
        wait_for(lambda: master_up(env["ROS_MASTER_URI"]), 30.0, "roscore", roscore)
        launch = Proc(ROSLAUNCH + [str(launch_file(self.home, self.definitions, self.keys, self.feedback,
                                                   self.robots))], self.home / "roslaunch.log", env)
        self.started.append(launch)
        wait_for(lambda: launch.text().count("serving commands") >= 2, 90.0, "both runners", launch)
        return launch

    def start_manager(self) -> Proc:
        """`fleetctl manager` on the instance, ADG, started at once and until done."""
        manager = Proc(fleetctl_args("manager", self.instance, "--definitions", self.definitions, "--keys",
                                     self.keys, "--host", "127.0.0.1", "--bind",
                                     "tcp://127.0.0.1:{}".format(self.console_port), "--start",
                                     "--until-done", "--log", self.home / "runs", "--time-limit", "300",
                                     "--connect-timeout", "120", "--strategy", "adg"),
                       self.home / "manager.log", self.env)
        self.started.append(manager)
        return manager


@inside_netns
def test_the_manager_drives_simulated_turtlebots_through_a_lab_plan(tmp_path: Path) -> None:
    started: List[Proc] = []
    saved: Optional[Dict[str, Optional[str]]] = None
    try:
        lab = TwoTurtleBots(tmp_path, ROBOTS, "crossing.txt", started)
        launch = lab.start_robots()
        saved = set_ros_variables(lab.env)
        import rospy

        rospy.init_node("fleet_test_truth", anonymous=True, disable_signals=True)
        truth = Truth()
        wait_for(lambda: len(truth.latest) == 2, 30.0, "ground truth of both robots", launch)
        manager = lab.start_manager()
        assert manager.wait(420) == 0, manager.tail(60) + "\n" + launch.tail(30)
        out = manager.text()
        assert "arrived: 2/2" in out and "collisions: 0" in out, out
        for rid, (_, goal) in ROBOTS.items():
            where = truth.where(rid)
            off = math.hypot(where.x - goal[0], where.y - goal[1]) * GridFrame().cell_size()
            assert off < 0.05, "robot {} ended {:.3f} m from its goal cell {}".format(rid, off, goal)
        executed = re.findall(r"robot (\d+) executing (\w+) (\d+) of manager (\w+)", launch.text())
        drives = [e for e in executed if e[1] == "drive"]
        assert len(drives) == 8, executed  # four moves each, none twice
        assert len(set(executed)) == len(executed), "a command ran twice: {}".format(executed)
    finally:
        leave_ros(started, saved)

