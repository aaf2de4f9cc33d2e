"""The machines a command reaches: the server (from deploy.yaml) and robots (from the definitions).

A `Target` is everything needed to act on one machine, with `{id}`, `{host}` and
`{user}` already put into its paths and commands. Robots are chosen by id or
`all`; an unknown id is an error that lists the defined ones.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import List, Optional, Sequence, Tuple

from fleet_common.robots import RobotDefinition

from .config import DeployConfig, Side
from .errors import DeployError

__all__ = ["Target", "server_target", "robot_targets", "select_robots"]


@dataclass(frozen=True)
class Target:
    name: str                 # "server", "robot 3": the table's first column
    host: str
    port: int
    user: str
    path: str                 # the checkout on that machine
    build: str
    processes: Tuple[Tuple[str, str], ...]
    robot_id: Optional[int] = None

    @property
    def address(self) -> str:
        return "{}@{}:{}".format(self.user, self.host, self.port)

    @property
    def log_name(self) -> str:
        """Per-host log file name: `<host>-server`, `<host>-robot<id>`."""
        return "{}-{}".format(self.host, "server" if self.robot_id is None else
                              "robot{}".format(self.robot_id))


def _fill(text: str, robot_id: Optional[int], host: str, user: str) -> str:
    # Plain replacement, not str.format: shell text is full of braces (${VAR}).
    values = {"{id}": "" if robot_id is None else str(robot_id), "{host}": host, "{user}": user}
    for key, value in values.items():
        text = text.replace(key, value)
    return text


def _target(name: str, side: Side, host: str, user: str, robot_id: Optional[int]) -> Target:
    return Target(name, host, side.port, user, _fill(side.path, robot_id, host, user),
                  _fill(side.build, robot_id, host, user),
                  tuple((n, _fill(c, robot_id, host, user)) for n, c in side.processes), robot_id)


def server_target(config: DeployConfig) -> Target:
    if config.server is None:
        raise DeployError("{} has no server: section (host, user, build, processes)".format(
            config.path))
    s = config.server
    return _target("server", s, s.host, s.user, None)


def select_robots(robots: Sequence[RobotDefinition], ids: Sequence[str],
                  path: str) -> List[RobotDefinition]:
    """The robots named by `ids` (numbers, or `all`), in definition order, each once."""
    if not ids:
        raise DeployError("name the robots: one or more ids, or 'all'")
    if "all" in ids:
        return list(robots)
    known = {r.id: r for r in robots}
    wanted = set()
    for text in ids:
        if not (text.isdigit() and text.isascii()) or int(text) not in known:
            raise DeployError("no robot {!r} in {}; defined: {} (or 'all')".format(
                text, path, ", ".join(str(r.id) for r in robots)))
        wanted.add(int(text))
    return [r for r in robots if r.id in wanted]


def robot_targets(config: DeployConfig, robots: Sequence[RobotDefinition]) -> List[Target]:
    return [_target("robot {}".format(r.id), config.robots, r.host, r.ssh_user, r.id)
            for r in robots]
