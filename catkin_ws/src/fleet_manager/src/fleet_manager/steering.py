"""What an operator may do to a running fleet, and the manager's answer to each request.

Every action returns (done?, a sentence for the operator): a refusal says why
and what to do instead. The run states:

    waiting --start--> running <--pause/start--> paused
       |                  |  --stop--> stopped --start--> running
       |                  '--(every robot at its goal)--> done
       '--step--> paused (one round released)

`start` from waiting checks that every robot is connected and stands on its
plan start; `halt` stops every robot where it is, now (the robots in a move
hold both cells and finish the move when started again); `stop` sends
nothing new and lets robots finish the move they are making. Strategy
switches, enabling and disabling robots, and the position source apply at
once, whatever the state.
"""
from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING, Any, Callable, Dict, List, Tuple

from fleet_common.errors import FleetError
from fleet_common.execution import (STRATEGIES, Disabled, Pause, Resume, StepRound, SwitchStrategy,
                                    make_strategy)

from .driver import AT_CELL
from .positions import VICON

if TYPE_CHECKING:
    from .manager import Manager

__all__ = ["Steering"]

Answer = Tuple[bool, str]


class Steering:
    def __init__(self, manager: "Manager") -> None:
        self.m = manager
        self._actions: Dict[str, Callable[[Dict[str, Any]], Answer]] = {
            "start": self.start, "pause": self.pause, "stop": self.stop, "step": self.step,
            "halt": self.halt, "strategy": self.strategy, "enable": self.enable,
            "disable": self.disable, "source": self.source, "load": self.load,
            "replan": self.replan, "accept": self.accept, "reject": self.reject,
        }

    def apply(self, action: str, args: Dict[str, Any], who: str) -> Answer:
        handler = self._actions.get(action)
        if handler is None:
            return False, "unknown action {!r}".format(action)
        return handler(args)

    # ---- the run ------------------------------------------------------------------------

    def start(self, args: Dict[str, Any]) -> Answer:
        m = self.m
        if m.replanner.busy or m.replanner.proposal_id is not None:
            return False, "a replan is being made or awaits accept/reject; answer it first"
        if m.run_state == "running":
            return False, "already running"
        if m.run_state == "done":
            return False, "the run is done; load a plan to run again"
        if m.run_state == "waiting":
            problem = self.not_ready()
            if problem:
                return False, problem
            m.started_at = m.now()
        self.resume()
        return True, ""

    def resume(self) -> None:
        m, now = self.m, self.m.now()
        for slot in m.driver.slots:
            if slot.hold == "halted":
                m.driver.enable(slot, now)
                m.note("out", robot=slot.robot_id, why=None, reason="resumed after halt")
        m.set_state("running")
        m.driver.handle(Resume(now), now)

    def not_ready(self) -> str:
        """Why the run cannot start now ("" if it can): robots not connected or not on their starts."""
        m = self.m
        down = [r.id for r in m.robots if m.links[r.id].state != "up"]
        if down:
            return "not connected: robot{} {}".format("s" if len(down) > 1 else "", _ids(down))
        off: List[str] = []
        for slot in m.driver.slots:
            start = m.engine.table.start(slot.agent)
            if m.engine.run.out[slot.agent] is not None:
                continue
            pose = m.positions.pose(slot.robot_id)
            if pose is None:
                off.append("robot {} has not reported a pose".format(slot.robot_id))
            elif math.hypot(pose.x - start[0], pose.y - start[1]) > AT_CELL:
                off.append("robot {} is at ({:.1f}, {:.1f}), its start is {}".format(
                    slot.robot_id, pose.x, pose.y, m.loaded.show(start)))
        if off:
            return "not on their start cells: " + "; ".join(off[:5]) + (
                "; and {} more".format(len(off) - 5) if len(off) > 5 else "")
        return ""

    def pause(self, args: Dict[str, Any]) -> Answer:
        m = self.m
        if m.run_state != "running":
            return False, "not running (the run is {})".format(m.run_state)
        m.driver.handle(Pause(m.now()), m.now())
        m.set_state("paused", "paused by operator")
        return True, ""

    def stop(self, args: Dict[str, Any]) -> Answer:
        m = self.m
        if m.run_state not in ("running", "paused"):
            return False, "not running (the run is {})".format(m.run_state)
        if not m.engine.paused:
            m.driver.handle(Pause(m.now()), m.now())
        m.set_state("stopped", "stopped by operator: robots finish their move")
        return True, ""

    def step(self, args: Dict[str, Any]) -> Answer:
        m = self.m
        if m.run_state == "done":
            return False, "the run is done"
        if m.replanner.busy or m.replanner.proposal_id is not None:
            return False, "a replan is being made or awaits accept/reject; answer it first"
        if m.run_state == "waiting":
            problem = self.not_ready()
            if problem:
                return False, problem
            m.started_at = m.now()
        m.set_state("paused", "one round released (step)")
        m.driver.handle(StepRound(m.now()), m.now())
        return True, ""

    def halt(self, args: Dict[str, Any]) -> Answer:
        m = self.m
        if m.run_state in ("waiting", "done"):
            return False, "nothing is moving (the run is {})".format(m.run_state)
        if not m.engine.paused:
            m.driver.handle(Pause(m.now()), m.now())
        m.driver.halt(m.now())
        m.set_state("paused", "halted by operator: Start drives on")
        return True, ""

    # ---- robots and strategy --------------------------------------------------------------

    def strategy(self, args: Dict[str, Any]) -> Answer:
        m = self.m
        name = args["name"]
        if name not in STRATEGIES:
            return False, "unknown strategy {!r}; strategies: {}".format(name, ", ".join(STRATEGIES))
        settings = {}
        if args.get("lookahead") is not None:
            if "lookahead" not in STRATEGIES[name].SETTINGS:
                return False, "strategy {} has no lookahead".format(name)
            settings["lookahead"] = args["lookahead"]
        try:
            new = make_strategy(name, **settings)
        except FleetError as err:
            return False, str(err)
        old = m.engine.strategy.describe()
        m.driver.handle(SwitchStrategy(new, m.now()), m.now())
        m.settings.strategy = name
        if "lookahead" in settings:
            m.settings.lookahead = settings["lookahead"]
        m.note("strategy", name=name, settings=settings, by="operator")
        m.desk.bump("strategy {} -> {}".format(old, new.describe()))
        m.tell("strategy", None, "strategy switched: {} -> {}".format(old, new.describe()))
        return True, ""

    def _slot(self, robot: int):
        slot = self.m.driver.by_robot.get(robot)
        if slot is None:
            raise FleetError("robot {} is not in this run (robots: {})".format(
                robot, _ids([s.robot_id for s in self.m.driver.slots])))
        return slot

    def enable(self, args: Dict[str, Any]) -> Answer:
        m = self.m
        try:
            slot = self._slot(args["robot"])
        except FleetError as err:
            return False, str(err)
        if m.engine.run.out[slot.agent] is None and slot.hold is None:
            return False, "robot {} is already enabled".format(slot.robot_id)
        m.driver.enable(slot, m.now())
        m.note("out", robot=slot.robot_id, why=None, reason="enabled by operator")
        m.desk.bump("robot {} enabled".format(slot.robot_id), slot.robot_id)
        return True, ""

    def disable(self, args: Dict[str, Any]) -> Answer:
        m = self.m
        try:
            slot = self._slot(args["robot"])
        except FleetError as err:
            return False, str(err)
        if m.engine.run.out[slot.agent] == "disabled":
            return False, "robot {} is already disabled".format(slot.robot_id)
        m.driver.handle(Disabled(slot.agent, m.now()), m.now())
        m.driver.drop_pending(slot)
        m.note("out", robot=slot.robot_id, why="disabled", reason="disabled by operator")
        m.desk.bump("robot {} disabled".format(slot.robot_id), slot.robot_id)
        return True, ""

    def source(self, args: Dict[str, Any]) -> Answer:
        m = self.m
        if args["source"] == VICON and not m.positions.vicon_enabled:
            return False, "no Vicon stream: start the manager with --vicon PORT"
        if args["robot"] is not None:
            try:
                self._slot(args["robot"])
            except FleetError as err:
                return False, str(err)
        changed = m.positions.choose(args["source"], args["robot"])
        if changed:
            m.desk.bump("position source {} for robot{} {}".format(
                args["source"], "s" if len(changed) > 1 else "", _ids(changed)), args["robot"])
        return True, ""

    # ---- plans ----------------------------------------------------------------------------

    def load(self, args: Dict[str, Any]) -> Answer:
        m = self.m
        if m.run_state not in ("waiting", "stopped", "done") or m.driver.moving:
            return False, "load another plan when the run is waiting, stopped or done and no " \
                          "robot moves (it is {})".format(m.run_state)
        from .plan_source import load_plan
        path = Path(args["path"] or args["name"])
        try:
            loaded = load_plan(path, len(m.robots), "the fleet", m.map_dirs, text=args["text"])
        except (FleetError, OSError) as err:
            return False, "cannot load {}: {}".format(path, err)
        m.start_new_run(loaded)
        return True, "{} loaded ({})".format(loaded.name, loaded.note)

    def replan(self, args: Dict[str, Any]) -> Answer:
        m = self.m
        if m.run_state in ("waiting", "done"):
            return False, "replanning is for a run under way (the run is {})".format(m.run_state)
        if m.replanner.busy or m.replanner.proposal_id is not None:
            return False, "a replan is already being made or awaits accept/reject"
        was_running = m.run_state == "running"
        if was_running:
            m.driver.handle(Pause(m.now()), m.now())
            m.set_state("paused", "replanning: waiting for every robot to finish its move")
        m.replanner.request(was_running, args["time_limit"], args["method"])
        m.desk.bump("replan requested")
        return True, "replanning; the proposal follows"

    def accept(self, args: Dict[str, Any]) -> Answer:
        m = self.m
        pending = m.replanner.pending
        if m.replanner.proposal_id is None or pending is None or pending.id != args["proposal"]:
            return False, "no proposal {} awaits an answer".format(args["proposal"])
        m.switch_plan(pending.result.plan, "replan")
        m.replanner.resolved()
        if m.replanner.was_running:
            self.resume()  # a new plan's engine starts paused: otherwise it stays so
        return True, "switched to plan {}".format(m.plan_id)

    def reject(self, args: Dict[str, Any]) -> Answer:
        m = self.m
        if m.replanner.proposal_id is None or m.replanner.proposal_id != args["proposal"]:
            return False, "no proposal {} awaits an answer".format(args["proposal"])
        m.replanner.resolved()
        m.desk.bump("replan rejected")
        if m.replanner.was_running:
            self.resume()
        return True, "kept plan {}".format(m.plan_id)


def _ids(ids: List[int]) -> str:
    return ", ".join(str(i) for i in ids)
