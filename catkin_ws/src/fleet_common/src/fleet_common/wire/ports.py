"""Which port each robot publishes pose feedback on.

A real robot publishes on 9980 (thesis 5.2), one robot per host. Robots that
share a host (the virtual fleet on 127.0.0.1) cannot all have 9980, so they
get `base`, `base + 1`, ... in definition order. The robot announces its port
in `Welcome`, so the manager never has to work this out; the rule lives here
so that it is written once. A feedback port that collides with a command port
on the same host is an error naming the definitions line.
"""
from __future__ import annotations

from typing import Dict, List, Sequence

from ..errors import RobotDefinitionsError
from ..robots import RobotDefinition

__all__ = ["FEEDBACK_PORT", "feedback_ports", "on_localhost"]

#: The pose feedback port of a robot alone on its host (thesis 5.2).
FEEDBACK_PORT = 9980


def feedback_ports(robots: Sequence[RobotDefinition], base: int = FEEDBACK_PORT,
                   path: str = "robot_definitions.txt") -> Dict[int, int]:
    """robot id -> feedback port, by the rule above."""
    by_host: Dict[str, List[RobotDefinition]] = {}
    for robot in robots:
        by_host.setdefault(robot.host.lower(), []).append(robot)
    ports: Dict[int, int] = {}
    for host, group in by_host.items():
        taken = {r.command_port: r for r in group}
        for index, robot in enumerate(group):
            port = base + index
            if port > 65535:
                raise RobotDefinitionsError(
                    "robot {} would publish feedback on port {}, above 65535; use a lower "
                    "feedback base than {}".format(robot.id, port, base), path, robot.line or None)
            if port in taken:
                other = taken[port]
                raise RobotDefinitionsError(
                    "robot {} would publish feedback on port {}, which is robot {}'s command "
                    "port on {}; move the command ports or the feedback base ({})".format(
                        robot.id, port, other.id, host, base), path, other.line or None)
            ports[robot.id] = port
    return ports


def on_localhost(robots: Sequence[RobotDefinition],
                 path: str = "robot_definitions.txt") -> List[RobotDefinition]:
    """The same fleet with every host replaced by 127.0.0.1, as the virtual fleet runs it;
    two robots with one command port (on different hosts) cannot both be there."""
    first: Dict[int, RobotDefinition] = {}
    for r in robots:
        other = first.setdefault(r.command_port, r)
        if other is not r:
            raise RobotDefinitionsError(
                "robots {} and {} both use command port {}; on one host (127.0.0.1) every "
                "robot needs its own".format(other.id, r.id, r.command_port), path, r.line or None)
    return [RobotDefinition(r.id, "127.0.0.1", r.command_port, r.ssh_user, r.vicon_name,
                            r.colour, r.line) for r in robots]
