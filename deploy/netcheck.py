"""net:check: is each robot reachable, is SSH up (and do we get in), is its command port open,
and is its robot process alive? One table row per robot.

Reachable means the host answered on TCP at all (a connection accepted or
refused), which needs no root, unlike ping. The SSH column logs in the way
deployment does (pinned host keys, keys only). The wire column listens to the
robot's pose feedback stream (read-only, so it is safe during a run: a robot
obeys one manager at a time, and saying Hello would take it over from a running
manager); the stream uses the same CurveZMQ keys as commands, so "ok" also
means the keys fit. `hello=True` says Hello and GetStatus through the manager's
own robot links instead, which also checks the protocol version end to end,
and takes each robot over for a few seconds: before a demonstration, not during one.
"""
from __future__ import annotations

import socket
import time
import uuid
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from typing import Dict, List, Optional, Sequence, Tuple, Union

import zmq

from fleet_common.robots import RobotDefinition
from fleet_common.transport.curve_keys import ManagerKeys
from fleet_common.wire.link_events import LinkDown, LinkUp, RobotReply
from fleet_common.transport.links import LinkSet
from fleet_common.transport.pose_feedback import NotThisRobotsPose, read_pose, subscribe_feedback
from fleet_common.transport.robot_link import RobotLink
from fleet_common.wire import PoseFeedback, RemoteProtocolError, Status

from .config import DeployConfig
from .errors import DeployError, HostKeyRefused
from .ssh import connect
from .targets import Target

__all__ = ["Check", "check_robots", "format_checks", "tcp_probe", "feedback_status", "wire_status"]


@dataclass(frozen=True)
class Check:
    robot: RobotDefinition
    reachable: str
    ssh: str
    command_port: str
    wire: str
    notes: Tuple[str, ...]   # the full messages behind short cells

    @property
    def ok(self) -> bool:
        return (self.reachable, self.ssh, self.command_port) == ("yes", "ok", "open") \
            and self.wire.startswith("ok")


def tcp_probe(host: str, port: int, timeout: float) -> str:
    """open, refused, no answer, or the error."""
    try:
        with socket.create_connection((host, port), timeout=timeout):
            return "open"
    except ConnectionRefusedError:
        return "refused"
    except socket.timeout:
        return "no answer"
    except OSError as err:
        return err.strerror or str(err)


def _ssh(target: Target, config: DeployConfig, probe: str) -> Tuple[str, str]:
    """(cell, note) for the SSH column."""
    if probe != "open":
        return ("down ({})".format(probe), "")
    try:
        connect(target, config, accept_new=False).close()
    except HostKeyRefused as err:
        return ("host key changed" if err.changed else "host key unknown", str(err))
    except DeployError as err:
        text = str(err)
        return ("login refused" if "refused our key" in text else "error", text)
    return ("ok", "")


def _reachable(*probes: str) -> str:
    return "yes" if any(p in ("open", "refused") for p in probes) else "no"


def _status_text(status: Union[Status, PoseFeedback]) -> str:
    pose, current, faults = status.pose, status.current, status.faults
    where = "at ({:.1f}, {:.1f})".format(pose.x, pose.y)
    doing = "idle" if current is None else "running command {}".format(current)
    return "ok: {} {}{}".format(doing, where, "; faults: " + ", ".join(faults) if faults else "")


def _keys_hint(keys: Optional[ManagerKeys]) -> str:
    return " (CurveZMQ keys, or the robot's --no-curve?)" if keys is not None else \
        " (does the robot want CurveZMQ keys?)"


def feedback_status(robots: Sequence[RobotDefinition], ports: Dict[int, int],
                    keys: Optional[ManagerKeys], timeout: float) -> Dict[int, str]:
    """robot id -> "ok: ..." from the first pose on its feedback port (`ports`), or why not.

    Only listens: nothing reaches the robot's command port, so a manager
    driving it goes on undisturbed.
    """
    out: Dict[int, str] = {}
    problems: Dict[int, str] = {}
    context = zmq.Context()
    poller = zmq.Poller()
    of_socket: Dict[zmq.Socket, RobotDefinition] = {}
    try:
        for r in robots:
            sock = subscribe_feedback(context, r.host, ports[r.id], keys)
            of_socket[sock] = r
            poller.register(sock, zmq.POLLIN)
        give_up = time.monotonic() + timeout
        while len(out) < len(robots):
            left = give_up - time.monotonic()
            if left <= 0:
                break
            for sock, _ in poller.poll(min(left, 0.1) * 1000):
                robot = of_socket[sock]
                data = sock.recv(zmq.NOBLOCK)
                if robot.id in out:
                    continue
                try:
                    out[robot.id] = _status_text(read_pose(data, robot.id))
                except NotThisRobotsPose as err:
                    if err.sender is not None:
                        problems[robot.id] = "port {} carries robot {}'s poses (another --feedback-base?)".format(
                            ports[robot.id], err.sender)
                except RemoteProtocolError as err:
                    problems[robot.id] = "bad pose feedback on port {}: {}".format(ports[robot.id], err)
    finally:
        for sock in of_socket:
            sock.close(0)
        context.term()
    for r in robots:
        out.setdefault(r.id, problems.get(r.id) or "no pose feedback on port {} within {:g} s{}".format(
            ports[r.id], timeout, _keys_hint(keys)))
    return out


def wire_status(robots: Sequence[RobotDefinition], keys: Optional[ManagerKeys],
                timeout: float) -> Dict[int, str]:
    """robot id -> "ok: ..." or why not, asking every robot at once (one LinkSet)."""
    out: Dict[int, str] = {}
    if not robots:
        return out
    context = zmq.Context()
    epoch = "net-check-" + uuid.uuid4().hex[:8]
    links = LinkSet([RobotLink(context, r, epoch, keys=keys) for r in robots])
    try:
        give_up = time.monotonic() + timeout
        while len(out) < len(robots) and time.monotonic() < give_up:
            for event in links.poll(0.05):
                if isinstance(event, LinkUp):
                    links[event.robot_id].get_status()
                elif isinstance(event, LinkDown) and event.fatal:
                    out[event.robot_id] = "refused: " + event.reason
                elif isinstance(event, RobotReply) and isinstance(event.reply, Status):
                    out.setdefault(event.robot_id, _status_text(event.reply))
    finally:
        links.close()
        context.term()
    for r in robots:
        out.setdefault(r.id, "no answer within {:g} s{}".format(timeout, _keys_hint(keys)))
    return out


def check_robots(robots: Sequence[RobotDefinition], targets: Sequence[Target],
                 config: DeployConfig, keys: Optional[ManagerKeys], wire_timeout: float,
                 keys_problem: str = "", feedback: Optional[Dict[int, int]] = None) -> List[Check]:
    """Every probe for every robot; TCP and SSH in threads, the wire for all at once: the
    pose feedback on the ports `feedback` gives (robot id -> port), or without it Hello."""
    seconds = config.timeouts.connect

    def probes(pair: Tuple[RobotDefinition, Target]) -> Tuple[str, str, Tuple[str, str]]:
        robot, target = pair
        ssh_port = tcp_probe(robot.host, target.port, seconds)
        command = tcp_probe(robot.host, robot.command_port, seconds)
        return ssh_port, command, _ssh(target, config, ssh_port)

    with ThreadPoolExecutor(max_workers=max(1, len(robots))) as pool:
        found = list(pool.map(probes, zip(robots, targets)))
    listening = [r for r, (_, command, _) in zip(robots, found) if command == "open"]
    if keys_problem:
        wire: Dict[int, str] = {}
    elif feedback is not None:
        wire = feedback_status(listening, feedback, keys, wire_timeout)
    else:
        wire = wire_status(listening, keys, wire_timeout)
    checks = []
    for robot, (ssh_port, command, (ssh_cell, note)) in zip(robots, found):
        if command != "open":
            state = "not tried (port {})".format(command)
        else:
            state = wire.get(robot.id, "not tried: " + keys_problem)
        checks.append(Check(robot, _reachable(ssh_port, command), ssh_cell, command, state,
                            (note,) if note else ()))
    return checks


def format_checks(checks: Sequence[Check]) -> str:
    rows = [("ROBOT", "HOST", "REACHABLE", "SSH", "COMMAND PORT", "WIRE STATUS")]
    for c in checks:
        rows.append(("robot {}".format(c.robot.id), c.robot.host, c.reachable, c.ssh,
                     "{} {}".format(c.robot.command_port, c.command_port), c.wire))
    widths = [max(len(r[i]) for r in rows) for i in range(5)]
    lines = ["  ".join([cell.ljust(w) for cell, w in zip(row, widths)] + [row[5]]).rstrip()
             for row in rows]
    lines += ["robot {}: {}".format(c.robot.id, note) for c in checks for note in c.notes]
    good = sum(c.ok for c in checks)
    lines.append("{} of {} robots fully reachable".format(good, len(checks)))
    return "\n".join(lines)
