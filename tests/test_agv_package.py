"""agv_package as a catkin package: package.xml, CMakeLists, thin node scripts, launch files
loaded by roslaunch's own parser, and the settings read from its config files."""
from __future__ import annotations

import copy
import importlib.util
import os
import sys
from pathlib import Path
from typing import Any, Dict

import pytest
import yaml

from agv_package.runner_settings import RunnerSettings
from agv_package.settings import SettingsError
from agv_package.sim.sim_settings import SimSettings

PACKAGE = Path(__file__).resolve().parents[1] / "catkin_ws" / "src" / "agv_package"
NODES = ("agv_runner", "sim_turtlebot")


def config(*names: str) -> Dict[str, Any]:
    merged: Dict[str, Any] = {}
    for name in names:
        merged.update(yaml.safe_load((PACKAGE / "config" / name).read_text()))
    return merged


def test_package_xml_is_format_3_with_the_ros_run_dependencies() -> None:
    from catkin_pkg.package import parse_package

    import fleet_common

    package = parse_package(str(PACKAGE / "package.xml"))
    assert package.name == "agv_package" and package.package_format == 3
    assert package.version == fleet_common.__version__
    assert [d.name for d in package.buildtool_depends] == ["catkin"]
    assert {d.name for d in package.exec_depends} >= {
        "rospy", "std_msgs", "geometry_msgs", "nav_msgs", "sensor_msgs", "fleet_common"}


def test_cmakelists_installs_the_python_package_and_the_node_scripts() -> None:
    text = (PACKAGE / "CMakeLists.txt").read_text()
    assert "catkin_python_setup()" in text
    install = text.split("catkin_install_python(PROGRAMS", 1)[1].split(")", 1)[0]
    assert set(install.split()) >= {"nodes/" + node for node in NODES}


@pytest.mark.parametrize("node", NODES)
def test_node_scripts_are_thin_executables(node: str) -> None:
    script = PACKAGE / "nodes" / node
    assert os.access(script, os.X_OK)
    lines = script.read_text().splitlines()
    assert lines[0] == "#!/usr/bin/env python3"  # Noetic's interpreter; catkin rewrites it
    code = [line for line in lines if line and not line.startswith(("#", '"""'))]
    assert len(code) == 2 and code[1] == "main()"
    module = code[0].split()[1]
    assert importlib.util.find_spec(module) is not None


def load_launch(name: str, monkeypatch: pytest.MonkeyPatch, *args: str) -> Any:
    import roslaunch.config

    monkeypatch.setenv("ROS_PACKAGE_PATH", "{}:/usr/share".format(PACKAGE.parent))
    monkeypatch.setattr(sys, "argv", ["roslaunch"] + list(args))  # roslaunch reads args here
    return roslaunch.config.load_config_default([str(PACKAGE / "launch" / name)], None)


def test_sim_robot_launch_runs_runner_and_simulated_base(monkeypatch: pytest.MonkeyPatch) -> None:
    launch = load_launch("sim_robot.launch", monkeypatch, "robot_id:=4",
                         "definitions:=/tmp/robots.txt", "start_x:=2", "start_y:=3")
    assert sorted((n.package, n.type) for n in launch.nodes) == [
        ("agv_package", "agv_runner"), ("agv_package", "sim_turtlebot")]
    params = {name: p.value for name, p in launch.params.items()}
    assert params["/agv_runner/robot_id"] == 4
    assert params["/agv_runner/definitions"] == "/tmp/robots.txt"
    assert params["/agv_runner/motion/max_speed"] == 0.3  # config/navigation.yaml
    assert params["/sim_turtlebot/start_x"] == 2.0 and params["/sim_turtlebot/tag_size"] == 0.12


def test_robot_launch_remaps_to_the_kobuki_and_camera(monkeypatch: pytest.MonkeyPatch) -> None:
    launch = load_launch("robot.launch", monkeypatch, "robot_id:=2",
                         "velocity_topic:=/cmd_vel_mux/input/navi")
    [node] = launch.nodes
    assert node.type == "agv_runner" and node.respawn
    remaps = dict(node.remap_args)
    assert remaps["mobile_base/commands/velocity"] == "/cmd_vel_mux/input/navi"
    assert remaps["camera/image_raw"] == "/floor_camera/image_rect"
    params = {name: p.value for name, p in launch.params.items()}
    assert params["/agv_runner/bumper_type"] == "kobuki" and params["/agv_runner/robot_id"] == 2


def runner_params() -> Dict[str, Any]:
    params = config("navigation.yaml", "camera.yaml")
    params.update(robot_id=3, definitions="", keys_dir="", bind="", feedback_port=9980,
                  bumper_type="mask")
    return params


def test_runner_settings_from_the_shipped_config() -> None:
    settings = RunnerSettings.from_params(runner_params())
    assert settings.robot_id == 3 and settings.feedback_rate >= 10.0
    assert settings.motion.heading_tolerance == pytest.approx(0.017453, rel=1e-3)
    assert settings.localization.tag_map == "lab" and settings.mount.z == 0.3
    sim = SimSettings.from_params(config("sim.yaml", "camera.yaml"))
    assert sim.intrinsics == (420.0, 420.0, 319.5, 239.5) and sim.mount == settings.mount


@pytest.mark.parametrize("change, message", [
    (lambda p: p.update(colour="red"), "unknown setting 'colour'; the settings are bind, "),
    (lambda p: p["motion"].update(max_sped=1), "motion: unknown setting 'max_sped'"),
    (lambda p: p["motion"].update(max_speed=-1), "motion.max_speed: -1 is out of range"),
    (lambda p: p.update(bumper_type="laser"), "'laser' is not one of mask, kobuki"),
    (lambda p: p.update(feedback_rate=5), "feedback_rate: 5 is out of range [10.0, inf]"),
    (lambda p: p.pop("motion"), "missing motion (load config/navigation.yaml)"),
    (lambda p: p["localization"].update(fusion_gain=2), "fusion_gain: 2 is out of range"),
    (lambda p: p["camera_mount"].update(z="high"), "camera mount.z: expected a number"),
])
def test_bad_runner_settings_say_what_is_expected(change: Any, message: str) -> None:
    params = copy.deepcopy(runner_params())
    change(params)
    with pytest.raises(SettingsError) as caught:
        RunnerSettings.from_params(params)
    assert message in str(caught.value)
