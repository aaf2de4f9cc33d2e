"""The work behind `fleetctl vicon ...` (arguments: fleetctl/commands/vicon.py).

`listen` and `calibrate --live` read the stream through the manager's own
`ViconProvider`, so lab staff check exactly what the manager will see;
`simulate` runs `virtual_fleet.vicon_tracker`. Shared here: the fleet, the
frames file, opening the provider, and reading it for a while.
"""
from __future__ import annotations

import argparse
import select
import signal
import time
from pathlib import Path
from typing import TYPE_CHECKING, Callable, List, Sequence

from fleet_common.errors import FleetError
from fleet_common.robots import RobotDefinition, default_definitions_path, read_robot_definitions

if TYPE_CHECKING:
    from fleet_common.vicon.base_grid import ViconFix
    from fleet_manager.vicon_provider import ViconProvider

__all__ = ["fleet", "frames_path", "robot_named", "open_provider", "watch", "stop_on_signals"]


def fleet(args: argparse.Namespace) -> List[RobotDefinition]:
    return read_robot_definitions(args.definitions or default_definitions_path())


def frames_path(args: argparse.Namespace) -> Path:
    from fleet_common.lab import lab_frames_path
    return args.frames or lab_frames_path()


def robot_named(robots: Sequence[RobotDefinition], token: str) -> RobotDefinition:
    """The robot whose id or Vicon name is `token`."""
    for robot in robots:
        if token == robot.vicon_name or (token.isdigit() and int(token) == robot.id):
            return robot
    raise FleetError("no robot {!r}: expected a robot id or Vicon name ({})".format(
        token, ", ".join("{} {}".format(r.id, r.vicon_name) for r in robots)))


def open_provider(args: argparse.Namespace, robots: Sequence[RobotDefinition],
                  stale_after: float = 0.5) -> ViconProvider:
    from fleet_common.vicon.base_grid import load_vicon_to_base
    from fleet_manager.vicon_provider import ViconProvider

    return ViconProvider(robots, load_vicon_to_base(frames_path(args)), port=args.port,
                         bind=args.bind, stale_after=stale_after)


def watch(provider: ViconProvider, seconds: float, should_stop: Callable[[], bool],
          on_fixes: Callable[[List[ViconFix]], None] = lambda fixes: None) -> None:
    """Read the provider for `seconds` (or until `should_stop()`), handing on each batch."""
    deadline = time.monotonic() + seconds
    while not should_stop():
        left = deadline - time.monotonic()
        if left <= 0:
            return
        readable, _, _ = select.select([provider], [], [], min(left, 0.1))
        if readable:
            on_fixes(provider.handle_readable())


def stop_on_signals() -> Callable[[], bool]:
    """Ctrl-C and SIGTERM end the command's loop (which then reports) instead of killing it."""
    stopping: List[bool] = []
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, lambda *_: stopping.append(True))
    return lambda: bool(stopping)
