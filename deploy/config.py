"""deploy.yaml: where the code comes from and where it goes, read once and checked whole.

The file sits next to robot_definitions.txt (the robots come from there). Paths
on this machine may start with `~`; relative ones start at the file's folder.
Paths and commands on the server and the robots are run by bash in the
checkout; `{id}`, `{host}` and `{user}` in them become the robot's values.
Every key is known: a misspelt or unexpected one (a `password`, say) is an
error naming its line, so nothing in the file is silently ignored.
"""
from __future__ import annotations

import errno
import os
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Optional, Tuple, Union

from fleet_common.robots import ENV_VAR as ROBOTS_ENV_VAR
from fleet_common.robots import default_definitions_path
from fleet_common.yaml_lines import load_marked, read_yaml_text, where

from .errors import DeployConfigError

__all__ = ["DeployConfig", "Side", "ServerSide", "Timeouts", "read_config", "default_config_path"]

FILE_NAME = "deploy.yaml"
ENV_VAR = "FLEETCONTROL_DEPLOY"
_SESSION = re.compile(r"[A-Za-z0-9_-]{1,40}\Z")


@dataclass(frozen=True)
class Timeouts:
    """Seconds. `command` bounds each remote step (a robot's catkin_make takes minutes);
    `stop` is how long a process has to exit after Ctrl-C before its session is killed;
    `start_check` is how long a started process must keep running to count as started."""

    connect: float = 10.0
    command: float = 900.0
    stop: float = 10.0
    start_check: float = 1.0


@dataclass(frozen=True)
class Side:
    """What is the same on every machine of one side: the checkout, the build, the processes
    (tmux session name -> command), the SSH port."""

    path: str
    build: str
    processes: Tuple[Tuple[str, str], ...]
    port: int


@dataclass(frozen=True)
class ServerSide(Side):
    host: str = ""
    user: str = ""


@dataclass(frozen=True)
class DeployConfig:
    path: Path
    repository: str
    branch: str
    known_hosts: Path
    login_key: Optional[Path]
    deploy_key: Optional[Path]
    git_known_hosts: Optional[Path]
    tmux_socket: str
    log_dir: Path
    timeouts: Timeouts
    robots: Side
    server: Optional[ServerSide]


def default_config_path() -> Path:
    """$FLEETCONTROL_DEPLOY if set, else deploy.yaml beside the robot definitions."""
    env = os.environ.get(ENV_VAR)
    return Path(env) if env else default_definitions_path().parent / FILE_NAME


class _Reader:
    """Typed look-ups in one mapping of the file, each error naming the line."""

    def __init__(self, data: Any, where_: str, path: str) -> None:
        self.path = path
        self.where = where_
        if not isinstance(data, dict):  # only the whole file gets here otherwise (sub checks)
            raise DeployConfigError("expected a mapping of keys to values (see the shipped "
                                    "deploy.yaml)", path, *where(data))
        self.data = data

    def fail(self, key: str, message: str) -> DeployConfigError:
        return DeployConfigError("{}: {}".format(self.name(key), message),
                                 self.path, *where(self.data, key))

    def name(self, key: str) -> str:
        return "{}.{}".format(self.where, key) if self.where else key

    def check_keys(self, known: Tuple[str, ...]) -> None:
        for key in self.data:
            if key not in known:
                hint = (" (key authentication only: no password belongs in any file)"
                        if "pass" in str(key).lower() else "")
                raise self.fail(str(key), "unknown key{}; expected one of: {}".format(
                    hint, ", ".join(known)))

    def text(self, key: str, default: Optional[str] = None) -> str:
        value = self.data.get(key, default)
        if value is None:
            raise self.fail(key, "missing; expected a text value")
        if not isinstance(value, str) or not value.strip():
            raise self.fail(key, "expected a non-empty text value, got {!r}".format(value))
        return value.strip()

    def seconds(self, key: str, default: float) -> float:
        value = self.data.get(key, default)
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not value > 0:
            raise self.fail(key, "expected a positive number of seconds, got {!r}".format(value))
        return float(value)

    def port(self, key: str) -> int:
        value = self.data.get(key, 22)
        if isinstance(value, bool) or not isinstance(value, int) or not 1 <= value <= 65535:
            raise self.fail(key, "expected a port number 1..65535, got {!r}".format(value))
        return value

    def local_path(self, key: str, default: Optional[str] = None) -> Optional[Path]:
        if self.data.get(key, default) is None:
            return None
        path = Path(self.text(key, default)).expanduser()
        return path if path.is_absolute() else Path(self.path).resolve().parent / path

    def sub(self, key: str) -> "_Reader":
        value = self.data.get(key, {})
        if not isinstance(value, dict):
            raise self.fail(key, "expected a mapping of keys to values, got {!r}".format(value))
        return _Reader(value, self.name(key), self.path)


def _side(reader: _Reader, cls: type, **extra: Any) -> Any:
    processes = reader.sub("processes")
    names = []
    for name, command in processes.data.items():
        if not isinstance(name, str) or not _SESSION.match(name):
            raise processes.fail(str(name), "a process name is a tmux session name: letters, "
                                 "digits, '_' and '-', at most 40")
        names.append((name, processes.text(name)))
    return cls(path=reader.text("path", "~/fleetcontrol"), build=reader.text("build"),
               processes=tuple(names), port=reader.port("port"), **extra)


def parse_config(text: str, path: str) -> DeployConfig:
    """The configuration in `text` (the file at `path`); DeployConfigError if malformed."""
    top = _Reader(load_marked(text, path, DeployConfigError), "", path)
    top.check_keys(("repository", "branch", "known_hosts", "login_key", "deploy_key",
                    "git_known_hosts", "tmux_socket", "log_dir", "timeouts", "server", "robots"))
    times = top.sub("timeouts")
    times.check_keys(("connect", "command", "stop", "start_check"))
    robots = top.sub("robots")
    robots.check_keys(("port", "path", "build", "processes"))
    server = None
    if "server" in top.data:
        side = top.sub("server")
        side.check_keys(("host", "user", "port", "path", "build", "processes"))
        server = _side(side, ServerSide, host=side.text("host"), user=side.text("user"))
    socket = top.text("tmux_socket", "fleetcontrol")
    if not _SESSION.match(socket):
        raise top.fail("tmux_socket", "expected letters, digits, '_' and '-', got {!r}".format(
            socket))
    return DeployConfig(
        path=Path(path), repository=top.text("repository"), branch=top.text("branch", "main"),
        known_hosts=top.local_path("known_hosts", "~/.ssh/known_hosts") or Path(),
        login_key=top.local_path("login_key"), deploy_key=top.local_path("deploy_key"),
        git_known_hosts=top.local_path("git_known_hosts"), tmux_socket=socket,
        log_dir=top.local_path("log_dir", "logs/deploy") or Path(),
        timeouts=Timeouts(times.seconds("connect", 10.0), times.seconds("command", 900.0),
                          times.seconds("stop", 10.0), times.seconds("start_check", 1.0)),
        robots=_side(robots, Side), server=server)


def read_config(path: Union[str, Path, None] = None) -> DeployConfig:
    """Read and check deploy.yaml (default: `default_config_path()`)."""
    path = Path(path) if path is not None else default_config_path()
    if not path.exists():
        raise DeployConfigError("cannot read: {} (deploy.yaml sits beside robot_definitions.txt; "
                                "--config FILE, ${} or ${} choose another)".format(
                                    os.strerror(errno.ENOENT), ENV_VAR, ROBOTS_ENV_VAR), str(path))
    return parse_config(read_yaml_text(str(path), DeployConfigError), str(path))

