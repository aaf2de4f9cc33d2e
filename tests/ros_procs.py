"""What the ROS integration tests share: a loopback ROS environment (and joining it from the test's
own process), waiting, and a netns of their own.

roscore's rosout (a C++ node) listens on every interface whatever ROS_IP says, and our rule
is that a test's servers listen on loopback only or inside a network namespace the test
makes. So, when it can (root, unshare, ip), a ROS test module runs itself again inside a
fresh network namespace that has nothing but a loopback interface, and the outer run checks
that inner run (`run_inside_netns`); the module's tests are skipped in the outer run only
(`netns_marker`). Nodes started by roslaunch run with their shebang's `python3`, so the
venv's bin folder goes first on PATH: the venv is Debian's python3 with system site
packages, which has rospy and the pip packages.
"""
from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
import time
import xmlrpc.client
from pathlib import Path
from typing import Callable, Dict, List, Mapping, Optional

import pytest

from live import Proc

REPO_ROOT = Path(__file__).resolve().parents[1]
VENV_BIN = Path(sys.executable).parent
IN_NETNS = os.environ.get("FLEETCONTROL_ROS_NETNS") == "1"
NETNS_WRAPPER = (not IN_NETNS and os.geteuid() == 0
                 and shutil.which("unshare") is not None and shutil.which("ip") is not None)


def netns_marker(module_file: str) -> pytest.MarkDecorator:
    """Mark for the tests of a module: skipped in the outer run, run in the namespace."""
    return pytest.mark.skipif(NETNS_WRAPPER, reason="run inside a fresh network namespace by "
                              "the module's own wrapper test")


def run_inside_netns(module_file: str, min_passed: int, timeout: float = 900) -> None:
    """The module's tests, run again in a fresh network namespace; fails with their report."""
    if not NETNS_WRAPPER:
        pytest.skip("this is the run inside the namespace" if IN_NETNS
                    else "not root or no unshare/ip: the tests run directly")
    script = 'ip link set lo up && exec "$0" -m pytest -q -p no:cacheprovider "$1"'
    proc = subprocess.run(["unshare", "--net", "--", "sh", "-c", script, sys.executable, module_file],
                          env=dict(os.environ, FLEETCONTROL_ROS_NETNS="1"), capture_output=True,
                          text=True, timeout=timeout, cwd=str(REPO_ROOT))
    report = proc.stdout[-6000:] + proc.stderr[-3000:]
    assert proc.returncode == 0, report
    passed = re.search(r"(\d+) passed", proc.stdout)
    assert passed and int(passed.group(1)) >= min_passed and "failed" not in proc.stdout, report


def ros_environment(master_port: int, home: Path) -> Dict[str, str]:
    env = dict(os.environ)
    env.update({
        "PATH": "{}:/usr/bin:/bin".format(VENV_BIN),
        "ROS_MASTER_URI": "http://127.0.0.1:{}".format(master_port),
        "ROS_IP": "127.0.0.1",  # nodes advertise and (rospy) listen on loopback only
        "ROS_HOME": str(home),
        "ROS_LOG_DIR": str(home / "log"),
        "ROS_PACKAGE_PATH": "{}:/usr/share".format(REPO_ROOT / "catkin_ws" / "src"),
        "PYTHONUNBUFFERED": "1",
    })
    env.pop("ROS_HOSTNAME", None)
    env.pop("PYTHONPATH", None)
    return env


#: roslaunch's own escalation after Ctrl-C, as deploy.yaml starts the robots' runner.
ROSLAUNCH = ["roslaunch", "--sigint-timeout", "4", "--sigterm-timeout", "2"]

#: What a rospy node reads to find its master and where to log.
ROS_VARIABLES = ("ROS_MASTER_URI", "ROS_IP", "ROS_HOME", "ROS_LOG_DIR", "ROS_HOSTNAME")


def set_ros_variables(values: Mapping[str, Optional[str]]) -> Dict[str, Optional[str]]:
    """Give this process `values`' ROS_VARIABLES (missing or None: unset), so that a rospy
    node of the test joins that master; returns the old values, to set back the same way."""
    old = {k: os.environ.get(k) for k in ROS_VARIABLES}
    for key in ROS_VARIABLES:
        value = values.get(key)
        if value is None:
            os.environ.pop(key, None)
        else:
            os.environ[key] = value
    return old


def leave_ros(started: List[Proc], saved: Optional[Dict[str, Optional[str]]]) -> None:
    """Undo a ROS set-up: this process's rospy node down, the `started` processes stopped (last
    first), the ROS variables `set_ros_variables` replaced put back (`saved`, if any)."""
    if "rospy" in sys.modules and sys.modules["rospy"].core.is_initialized():
        sys.modules["rospy"].signal_shutdown("done")
    for process in reversed(started):
        process.stop()
    if saved is not None:
        set_ros_variables(saved)


def wait_for(condition: Callable[[], bool], timeout: float, what: str,
             process: Optional[Proc] = None) -> None:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if condition():
            return
        if process is not None and process.popen.poll() is not None:
            raise AssertionError("{} exited ({}) while waiting for {}:\n{}".format(
                process.log.name, process.popen.returncode, what, process.tail()))
        time.sleep(0.1)
    raise AssertionError("timed out after {:.0f} s waiting for {}{}".format(
        timeout, what, "\n" + process.tail() if process is not None else ""))


def master_up(uri: str) -> bool:
    try:
        code, _, _ = xmlrpc.client.ServerProxy(uri).getPid("/fleet_test")
        return code == 1
    except OSError:
        return False
