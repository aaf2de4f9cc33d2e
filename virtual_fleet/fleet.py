"""Many virtual robots in one process: one ZeroMQ context, one ZAP handler, one loop.

Each robot definition becomes a `RobotEndpoint` on 127.0.0.1 (its own command
port; feedback ports from fleet_common.wire.ports: base, base + 1, ... in
definition order) driving a `VirtualNavigator`. A fleet may serve a part of
the definitions (`serve`), so that several processes, or hosts, serve one
fleet: ports and delays are those of the whole file, so a robot has the same
ones whichever process serves it. With `on_hosts` each robot listens on the
address its definition names, as a real robot does (robots sharing a host
count feedback ports up from the base among themselves). Dropouts from the delay model
are carried out here: the robot's sockets close without a goodbye, as at a
power cut, and after the model's pause a new endpoint (new session, empty
command memory) comes up where the robot stopped.

Each robot checks commands against `check` (its map and limits: see
fleet_common.wire.command_check), as a TurtleBot does. The loop never dies of
one robot, one peer or one scheduled call: whatever raises is logged and the
fleet serves on.
"""
from __future__ import annotations

import collections
import logging
import random
import threading
import time
from pathlib import Path
from typing import Callable, Dict, List, Optional, Sequence, Tuple


from fleet_common.errors import FleetError
from fleet_common.robots import RobotDefinition
from fleet_common.transport.context import fleet_context
from fleet_common.transport.curve_keys import RobotKeys
from fleet_common.wire.messages import Pose
from fleet_common.wire.ports import FEEDBACK_PORT, feedback_ports, on_localhost
from fleet_common.transport.robot_endpoint import RobotEndpoint
from fleet_common.transport.robot_loop import RobotLoop
from fleet_common.transport.truth_stream import TruthPublisher
from fleet_common.transport.zap import ZapHandler
from fleet_common.wire.command_check import CommandCheck

from .delays import FleetDelays
from .kinematics import SPEED, TURN_SPEED, VirtualNavigator
from .stalls import Stall, stalls_by_robot
from .truth import TruthRecorder, load_state

__all__ = ["VirtualFleet", "FleetThread", "row_poses"]

_DROPOUT_CHECK = 0.05  # wall seconds between looks for robots due to drop out


def row_poses(robots: Sequence[RobotDefinition], width: int = 32) -> Dict[int, Pose]:
    """Start poses when no instance is given: rows of `width` cells from (0, 0), facing +x."""
    return {r.id: Pose(float(i % width), float(i // width), 0.0) for i, r in enumerate(robots)}


class VirtualFleet:
    """Serves one virtual robot per definition until closed."""

    def __init__(self, robots: Sequence[RobotDefinition], *, keys: Optional[RobotKeys] = None,
                 feedback_base: int = FEEDBACK_PORT, time_scale: float = 1.0,
                 model: Optional[FleetDelays] = None, seed: int = 0, speed: float = SPEED,
                 turn_speed: float = TURN_SPEED, start_poses: Optional[Dict[int, Pose]] = None,
                 path: str = "robot_definitions.txt", feedback_rate: float = 10.0,
                 clock: Callable[[], float] = time.monotonic,
                 log: Optional[logging.Logger] = None,
                 check: Optional[CommandCheck] = None, truth: Optional[Path] = None,
                 state: Optional[Path] = None, truth_port: Optional[int] = None,
                 drift: Optional[Dict[int, float]] = None,
                 bumps: Sequence[Tuple[int, int]] = (), stalls: Sequence[Stall] = (),
                 serve: Optional[Sequence[int]] = None, on_hosts: bool = False) -> None:
        fleet = list(robots) if on_hosts else on_localhost(robots, path)
        ports = feedback_ports(fleet, feedback_base, path)  # the whole file's: the same in every process
        index = {r.id: i for i, r in enumerate(fleet)}
        chosen = set(serve) if serve is not None else set(index)
        self.robots = [r for r in fleet if r.id in chosen]
        self.check = check or CommandCheck()
        self.ports = {r.id: ports[r.id] for r in self.robots}
        for option, named in (("--drift", set(drift or {})), ("--bump", {r for r, _ in bumps}),
                              ("--stall", {s.robot for s in stalls})):
            unknown = sorted(named - {r.id for r in self.robots})
            if unknown:
                raise FleetError("{} names robot {}, which is not in {}".format(option, unknown[0], path)
                                 if unknown[0] not in index else
                                 "{} names robot {}, which this fleet does not serve (--robots)".format(
                                     option, unknown[0]))
        self.keys = keys
        self.model = model or FleetDelays()
        self.clock = clock
        self.feedback_rate = feedback_rate
        self.log = log or logging.getLogger("virtual_fleet")
        self.context = fleet_context(len(self.robots))
        self.zap = ZapHandler(self.context, self.log, clock) if keys is not None else None
        self.loop = RobotLoop(self.zap, clock, self.log)
        poses = dict(start_poses or row_poses(fleet))
        resumed = load_state(state) if state is not None else {}
        poses.update({r: p for r, p in resumed.items() if r in poses})
        self.publisher: Optional[TruthPublisher] = None
        try:
            self.publisher = TruthPublisher(self.context, truth_port) if truth_port else None
            self.recorder = TruthRecorder(truth, state, self.publisher.publish if self.publisher else None)
        except BaseException:
            if self.publisher is not None:
                self.publisher.close()
            self.context.destroy(linger=0)
            raise
        self.navigators: Dict[int, VirtualNavigator] = {
            r.id: VirtualNavigator(poses[r.id], speed=speed, turn_speed=turn_speed,
                                   time_scale=time_scale, model=self.model.for_robot(index[r.id]),
                                   rng=random.Random("{}/{}".format(seed, r.id)), clock=clock)
            for r in self.robots}
        for robot_id, rate in (drift or {}).items():
            self.navigators[robot_id].start_drifting(rate)
        for robot_id, drive in bumps:
            self.navigators[robot_id].bumps.add(drive)
        for robot_id, planned in stalls_by_robot(stalls).items():
            self.navigators[robot_id].stalls.update(planned)
        self.recorder.started({r: n.true_pose() for r, n in self.navigators.items()}, bool(resumed))
        self.endpoints: Dict[int, RobotEndpoint] = {}
        self.away: Dict[int, float] = {}  # robot id -> wall time it comes back
        self.dropouts = 0
        self._next_check = clock()
        self._next_truth = clock()
        self._calls: "collections.deque[Callable[[], None]]" = collections.deque()
        try:
            for robot in self.robots:
                self._start(robot)
        except BaseException:
            self.close()
            raise

    def _start(self, robot: RobotDefinition) -> None:
        endpoint = RobotEndpoint(self.context, robot.id, self.navigators[robot.id],
                                 robot.command_port, self.ports[robot.id], bind=robot.host,
                                 keys=self.keys, zap=self.zap, clock=self.clock,
                                 log=self.log, feedback_rate=self.feedback_rate,
                                 check=self.check,
                                 on_execute=lambda epoch, command, rid=robot.id:
                                 self.recorder.executed(rid, epoch, command))
        self.endpoints[robot.id] = endpoint
        self.loop.add(endpoint)

    def call_soon(self, fn: Callable[[], None]) -> None:
        """Run `fn` in the fleet's thread at its next turn (sockets belong to that thread)."""
        self._calls.append(fn)

    def run_once(self, max_wait: float = 0.1) -> None:
        while self._calls:
            call = self._calls.popleft()
            try:
                call()
            except Exception:  # a caller's mistake, not the fleet's end
                self.log.exception("virtual fleet: a scheduled call failed; serving on")
        if self.model.dropout_p or self.away:
            max_wait = min(max_wait, _DROPOUT_CHECK)
        if self.recorder.active:
            max_wait = min(max_wait, max(0.0, self._next_truth - self.clock()))
        self.loop.run_once(max_wait)
        now = self.clock()
        if self.recorder.active and now >= self._next_truth:
            self._next_truth = self.recorder.tick(self.true_poses, now, self.knots)
        if now >= self._next_check:
            self._next_check = now + _DROPOUT_CHECK
            try:
                self._dropouts(now)
            except Exception:
                self.loop.failures.event(logging.ERROR, "dropouts", "failures", "virtual fleet: "
                                         "carrying out dropouts failed; serving on", exc_info=True)

    def run(self, should_stop: Callable[[], bool], max_wait: float = 0.1) -> None:
        while not should_stop():
            self.run_once(max_wait)

    def drop_out(self, robot_id: int, seconds: float) -> None:
        """Cut robot `robot_id` off now; it restarts `seconds` (wall) later. From another
        thread, go through `call_soon`."""
        endpoint = self.endpoints.pop(robot_id)
        self.loop.remove(endpoint)
        endpoint.close(send_bye=False)  # also halts its navigator where it is
        self.away[robot_id] = self.clock() + seconds
        self.dropouts += 1
        self.log.info("robot %s dropped out; back in %.1f s", robot_id, seconds)

    def true_poses(self) -> Dict[int, Pose]:
        return {r: n.true_pose() for r, n in self.navigators.items()}

    def knots(self, wall: float) -> Dict[int, List[Tuple[float, float, float]]]:
        """Each robot's exact path since the last call, its times on the wall clock `wall`."""
        out = {}
        for r, n in self.navigators.items():
            now = n.now()
            knots = n.drain_knots()
            if knots:  # a robot at rest has none
                out[r] = [(wall - (now - t) / n.time_scale, x, y) for t, x, y in knots]
        return out

    def close(self, power_cut: bool = False) -> None:
        """Stop every robot and close; `power_cut`: as when the fleet loses power (SIGUSR1 to
        `fleetctl virtual-fleet`): each robot halts where it is and its sockets close without a
        goodbye, and the state file (`--state`) holds exactly where (a SIGKILL leaves it up to
        `STATE_PERIOD` of driving old: a robot started again from it jumps back along its path,
        towards a robot following it, which no real robot does)."""
        for endpoint in self.endpoints.values():
            self.loop.remove(endpoint)
            endpoint.close(send_bye=not power_cut)
        self.endpoints.clear()
        self.recorder.close(self.true_poses())
        if self.publisher is not None:
            self.publisher.close()
        if self.zap is not None:
            self.zap.socket.close(linger=0)
        self.context.destroy(linger=0)  # also what a robot that failed to start left open

    def _dropouts(self, now: float) -> None:
        by_id = {r.id: r for r in self.robots}
        for robot_id, back in list(self.away.items()):
            if now >= back:
                del self.away[robot_id]
                self._start(by_id[robot_id])
                self.log.info("robot %s is back (restarted)", robot_id)
        if not self.model.dropout_p:
            return
        due: List[Tuple[int, VirtualNavigator]] = [
            (rid, nav) for rid, nav in self.navigators.items()
            if rid in self.endpoints and nav.dropout_time is not None
            and nav.now() >= nav.dropout_time]
        for robot_id, nav in due:
            self.drop_out(robot_id, self.model.dropout_s / nav.time_scale)


class FleetThread:
    """Runs a fleet in a background thread for the `with` block; stops and closes it after,
    whatever happens (tests, benchmarks)."""

    def __init__(self, fleet: VirtualFleet, max_wait: float = 0.05) -> None:
        self.fleet = fleet
        self._stop = threading.Event()
        self._thread = threading.Thread(target=fleet.run, args=(self._stop.is_set, max_wait),
                                        name="virtual-fleet", daemon=True)

    def __enter__(self) -> VirtualFleet:
        self._thread.start()
        return self.fleet

    def __exit__(self, *exc: object) -> None:
        self._stop.set()
        self._thread.join(timeout=10.0)
        self.fleet.close()
