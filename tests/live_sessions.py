"""Random operator sessions through the real chain: does the run tell the truth over the wire?

`operator_sessions` presses an operator's buttons at random on the in-memory manager, with
a virtual clock. This does the same through the processes a lab runs: `fleetctl
virtual-fleet` and `fleetctl manager` on 127.0.0.1, a scripted console on the real socket
(`live.ScriptedConsole`), wall-clock time (the fleet at four times speed). What only the
chain has is exercised with it: requests and answers racing the States, poses that come when
the sockets deliver them, a manager killed outright (SIGKILL) and started again with
`--resume` on its run folder, bumpers pressed in the virtual robots, one robot losing its
power alone (its own virtual-fleet process: a TurtleBot's laptop that died) and coming
back where it stood; and the fleet may meet a delay model (late starts, stalls, slow drives).

A session: the lab plan under a random strategy, rerouting on or off, bumpers pressed in
some drives; 3-10 random presses (pause, start, step, halt, stop, disable, enable, a
strategy, a replan accepted or rejected, reroute mode, a restart of the manager, Reset, a
power cut of the whole fleet: every robot starts again where it stood, as from `--state`) at
random moments, and among them, by draws of their own, power cuts of one robot; then the clean-up lab staff would do (enable every robot out, answer a proposal,
start, replan if nothing moves). Judged by the virtual fleet's ground truth and the
manager's own words: the run ends done with every robot on its goal, the summary says so
and counts no collision, no two robots really came closer than the safe distance
(continuous time, `approach.judge`), no command ran twice, no robot nobody moved was found
"moved by hand", every request was answered, and neither process printed a traceback.
"""
from __future__ import annotations

import json
import math
import os
import random
import re
import signal
import subprocess
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Dict, List, Optional, Tuple

from fleet_common.execution.approach import judge
from fleet_common.lab import lab_instance_path
from fleet_common.robot_size import TURTLEBOT2
from fleet_common.runlog import read_run
from helpers import free_port_block
from live import Proc, ScriptedConsole, fleet_definitions, fleetctl_args, start_fleet, start_manager
from operator_sessions import lost_in
from test_manager_run import truth_poses
from virtual_fleet.truth import exec_lines, truth_paths

__all__ = ["LiveSession", "live_session", "PRESSES"]

#: the operator's buttons, and waiting (the run goes on)
PRESSES = ("pause", "start", "step", "halt", "stop", "disable", "enable", "strategy", "replan", "reroute",
           "restart", "reset", "reboot", "wait", "wait")
#: the fleet's delay model, one drawn a session (`fleetctl virtual-fleet --delay-model`): none, the
#: League of Robot Runners' delays, stalls anywhere in a move with slow drives
DELAY_MODELS = ("none", "none", "events=bernoulli:0.1:1-5", "stall=0.1:2,slow=0.1:2")
SCALE = 4.0  # the fleet's time scale: a drive of one cell in about half a second
ANSWER = 15.0  # seconds a request may wait for its answer (a manager answers within a loop turn)
AT_GOAL = 0.05  # cells


@dataclass
class LiveSession:
    """What happened (wall seconds since the start, action, arguments, accepted, answer) and
    what was found wrong."""

    seed: int
    log: List[Tuple[float, str, dict, bool, str]] = field(default_factory=list)
    problems: List[str] = field(default_factory=list)


def live_session(seed: int, folder: Path, vicon: bool = False) -> LiveSession:
    """One random session in `folder` (its processes' logs, the truth and the run folders stay
    there). Every process it starts is stopped before it returns. `vicon`: `fleetctl vicon
    simulate` streams what the fleet's truth says (a few packets lost, one or two robots occluded
    for a while), the manager reads it, the run starts on either source and the operator switches
    sources among the presses (draws of their own: the presses stay the seed's)."""
    rng = random.Random(seed)
    eye = random.Random(seed * 7919 + 2)
    out = LiveSession(seed)
    began = time.monotonic()
    cut = random.Random(seed * 6007 + 3)  # the lone robot's power cuts: draws of their own
    definitions, feedback, port = fleet_definitions(folder, 5)
    runs = folder / "runs"
    bumps = {rid: rng.randint(1, 5) for rid in range(1, 6) if rng.random() < 0.3}
    strategy, reroute = rng.choice(["adg", "adg", "step", "reorder"]), rng.choice(["off", "auto"])
    plan = lab_instance_path()
    manager_args = ("--log", runs, "--step-time", str(round(2.5 / SCALE, 3)), "--strategy", strategy,
                    "--reroute", reroute)
    lone = cut.randint(1, 5)
    delays = cut.choice(DELAY_MODELS)
    setup = {"strategy": strategy, "reroute": reroute, "bumps": sorted(bumps), "alone": lone, "delays": delays}
    truth_port = free_port_block(3) if vicon else 0
    udp = truth_port + 2
    fleet = SplitFleet(folder, definitions, feedback, ([r for r in range(1, 6) if r != lone], [lone]), bumps,
                       truth_port, ("--delay-model", delays, "--seed", seed))
    others: List[Proc] = []
    if vicon:
        hidden = [a for rid in eye.sample(range(1, 6), eye.randint(0, 2)) for a in (
            "--occlude", "{}:{:.1f}-{:.1f}".format(rid, *sorted(eye.uniform(0, 40) for _ in range(2))))]
        setup["occluded"] = hidden[1::2]
        others.append(Proc(fleetctl_args("vicon", "simulate", "--truth-port", truth_port,
                                         "--truth-port", truth_port + 1, "--port", udp,
                                         "--loss", eye.choice([0.0, 0.02, 0.1]), "--definitions", definitions,
                                         "--seed", seed, *hidden), folder / "vicon.log"))
        manager_args += ("--vicon", udp, "--vicon-bind", "127.0.0.1")
    out.log.append((0.0, "setup", setup, True, ""))
    managers: List[Proc] = [start_manager(folder, plan, definitions, port, *manager_args)]
    consoles: List[ScriptedConsole] = []
    try:
        consoles.append(ScriptedConsole(port, "ops"))
        console = consoles[-1]
        console.wait_for(lambda c: c.state and all(r.link == "up" and r.age is not None for r in c.state.robots),
                         timeout=30, why="every robot connected and seen")

        def press(action: str, **args: object) -> bool:
            try:
                answer = consoles[-1].ask(action, timeout=ANSWER, **args)
            except AssertionError:
                out.problems.append("no answer to {} {} within {:g} s".format(action, args, ANSWER))
                out.log.append((round(time.monotonic() - began, 1), action, dict(args), False, "no answer"))
                return False
            out.log.append((round(time.monotonic() - began, 1), action, dict(args), answer.ok, answer.reason))
            return answer.ok

        def run_info():
            with consoles[-1].lock:
                state = consoles[-1].state
            return None if state is None else state.run

        def answer_proposal(choice: str) -> None:
            try:  # the State after the request says it is replanning (or already has a proposal)
                consoles[-1].wait_for(lambda c: c.state.run.proposal is not None or c.state.run.replanning,
                                      timeout=5, why="the replan under way")
            except AssertionError:
                pass  # (given up at once: the next wait returns at once)
            chosen: set = set()
            ends = time.monotonic() + 30
            while True:  # a replan waiting for Vicon to see a robot again: its own pose, as told
                info = run_info()
                if info is not None and (info.proposal is not None or not info.replanning):
                    break
                if time.monotonic() > ends:
                    out.problems.append("a replan neither proposed nor ended within 30 s")
                    return
                for rid in sorted(set(lost_in(info.reason if info else "")) - chosen):
                    chosen.add(rid)
                    press("source", source="robot", robot=rid)
                time.sleep(0.2)
            info = run_info()
            if info is not None and info.proposal is not None:
                press(choice, proposal=info.proposal)

        def restart() -> None:
            managers[-1].kill()  # SIGKILL: a power cut, no goodbye
            consoles[-1].close()
            time.sleep(rng.uniform(0.2, 2.0))
            folders = sorted(p for p in runs.iterdir() if p.is_dir()) if runs.exists() else []
            args = ("--resume", folders[-1]) if folders else ()
            managers.append(start_manager(folder, plan, definitions, port, *manager_args, *args,
                                          name="manager-{}".format(len(managers))))
            consoles.append(ScriptedConsole(port, "ops"))
            try:
                consoles[-1].wait_for(lambda c: c.state is not None and c.state.run.reason and
                                      "checking where the robots are" not in c.state.run.reason,
                                      timeout=30, why="the new manager's first State")
            except AssertionError:
                out.problems.append("the manager started again sent no State within 30 s")
                return
            info = run_info()
            out.log.append((round(time.monotonic() - began, 1), "restart", {}, True, info.reason if info else ""))
            if info is not None and (info.replanning or info.proposal is not None):
                answer_proposal("accept")

        def switch_source() -> None:
            press("source", source=eye.choice(["robot", "vicon"]), robot=eye.choice([None, eye.randint(1, 5)]))

        if vicon:
            switch_source()
        press("start")
        for _ in range(rng.randint(3, 10)):
            time.sleep(rng.uniform(0.2, 3.0))
            if vicon and eye.random() < 0.3:
                switch_source()
            action = rng.choice(PRESSES)
            if action == "wait":
                continue
            if action == "restart":
                restart()
                continue
            if cut.random() < 0.15:  # robot `lone` alone loses power, for a moment or past the link's patience
                fleet.power_cut(out, 1, cut.uniform(0.2, 6.0))
                out.log.append((round(time.monotonic() - began, 1), "power cut", {"robot": lone}, True, ""))
            if action == "reboot":  # every robot loses power at once and starts again where it stood
                fleet.power_cut(out, None, rng.uniform(0.2, 3.0))
                out.log.append((round(time.monotonic() - began, 1), "reboot", {}, True, ""))
                continue
            args: dict = {}
            if action in ("disable", "enable"):
                args["robot"] = rng.randint(1, 5)
            elif action == "strategy":
                args["name"] = rng.choice(["adg", "step", "reorder"])
            elif action == "reroute":
                args.update(mode=rng.choice(["off", "propose", "auto"]), scope=rng.choice(["held", "all"]))
            if press(action, **args) and action == "replan":
                answer_proposal(rng.choice(["accept", "accept", "reject"]))
        _clean_up(out, press, run_info, answer_proposal)
        info = run_info()
        if info is None or info.state != "done":
            out.problems.append("not done: {} ({})".format(info and info.state, info and info.reason))
    except AssertionError as err:  # a wait of the harness that was not met: the session says what
        out.problems.append(str(err).splitlines()[0])
    finally:
        for console in consoles:
            console.close()
        for proc in managers + others:
            proc.stop()
        fleet.stop()
    _judge(out, managers, others + fleet.procs, fleet.truths, runs)
    return out


class SplitFleet:
    """Five virtual robots served by two `fleetctl virtual-fleet` processes (`--robots`), so that
    one part can lose its power alone. Each part keeps its own state file; each start of a part
    writes a truth file of its own (`truths`: part, path; the parts' clocks are both wall time)."""

    def __init__(self, folder: Path, definitions: Path, feedback: int, parts: Tuple[List[int], ...],
                 bumps: Dict[int, int], truth_port: int, extra: Tuple[object, ...] = ()) -> None:
        self.folder, self.definitions, self.feedback = folder, definitions, feedback
        self.parts, self.bumps, self.truth_port, self.extra = parts, bumps, truth_port, extra
        self.procs: List[Proc] = []
        self.truths: List[Tuple[int, Path]] = []
        self.running: Dict[int, Proc] = {}
        try:
            for part in range(len(parts)):
                self._start(part)
        except BaseException:
            self.stop()
            raise

    def _start(self, part: int) -> None:
        truth = self.folder / "truth-{}.jsonl".format(len(self.truths))
        ids = self.parts[part]
        args: List[object] = ["--robots", ",".join(map(str, ids)), "--truth", truth, "--time-scale", SCALE,
                              "--state", self.folder / "fleet-state-{}.json".format(part), *self.extra]
        args += [a for rid in ids if rid in self.bumps for a in ("--bump", "{}@{}".format(rid, self.bumps[rid]))]
        if self.truth_port:
            args += ["--truth-port", self.truth_port + part]
        self.running[part] = start_fleet(self.folder, self.definitions, self.feedback, *args,
                                         name="fleet-{}".format(len(self.procs)))
        self.procs.append(self.running[part])
        self.truths.append((part, truth))

    def power_cut(self, out: LiveSession, part: Optional[int], seconds: float) -> None:
        """Part `part` (None: both) loses power (SIGUSR1: every robot stops where it stands, the
        state file exact; a SIGKILL would leave it 0.2 s old) and starts again `seconds` later."""
        chosen = list(self.running) if part is None else [part]
        for p in chosen:
            os.kill(self.running[p].popen.pid, signal.SIGUSR1)
        for p in chosen:
            try:
                self.running[p].popen.wait(10)
            except subprocess.TimeoutExpired:
                out.problems.append("fleet part {} did not lose power within 10 s of SIGUSR1".format(p))
                self.running[p].kill()
        time.sleep(seconds)
        for p in chosen:
            self._start(p)

    def stop(self) -> None:
        for proc in self.procs:
            proc.stop()


def _clean_up(out: LiveSession, press, run_info, answer_proposal) -> None:
    """What lab staff do to finish: every robot out enabled, a proposal answered, Start; a
    replan when nothing moves; a way to the starts when Start says so."""
    for _ in range(8):
        time.sleep(1.0)  # a bumper is released after 1 s
        info = run_info()
        if info is None:
            return
        if info.state == "done" and info.arrived == info.robots:
            return
        for rid in range(1, 6):
            press("enable", robot=rid)  # (refused for a robot taking part: harmless)
        if run_info().proposal is not None:
            press("accept", proposal=run_info().proposal)
        if not press("start"):
            reason = out.log[-1][4]
            if "Go to starts" in reason:
                press("to_starts")
            for rid in lost_in(reason):
                press("source", source="robot", robot=rid)  # Vicon does not see it: its own pose, as told
        deadline = time.monotonic() + 60
        moved_at, done = time.monotonic(), None
        while time.monotonic() < deadline:
            info = run_info()
            if info.state in ("done", "waiting"):
                break
            if info.proposal is not None:
                press("accept", proposal=info.proposal)
            if done != info.arrived:
                done, moved_at = info.arrived, time.monotonic()
            if info.reason.startswith("the run cannot go on") or time.monotonic() - moved_at > 30:
                break  # it says it is stuck, or nothing arrived for 30 s
            time.sleep(0.2)
        info = run_info()
        if info.state == "done" and info.arrived == info.robots:
            return
        if info.state in ("running", "paused", "stopped") and press("replan"):
            answer_proposal("accept")


def _judge(out: LiveSession, managers: List[Proc], others: List[Proc], truths: List[Tuple[int, Path]],
           runs: Path) -> None:
    for proc in managers + others:
        if "Traceback" in proc.text():
            out.problems.append("{} printed a traceback".format(proc.log.name))
    said = "".join(proc.text() for proc in managers)
    if re.search(r"away from .{1,40}? where the run has it", said):
        out.problems.append("a robot nobody moved was found moved by hand")
    last = managers[-1].text()
    arrived = re.findall(r"^arrived: (\d+)/(\d+)", last, re.M)
    collisions = re.findall(r"^collisions: (\d+)", last, re.M)
    if not arrived:
        out.problems.append("the last manager printed no summary")
    elif arrived[-1][0] != arrived[-1][1] or arrived[-1][1] != "5":
        out.problems.append("the summary says arrived {}/{}".format(*arrived[-1]))
    if collisions and collisions[-1] != "0":
        out.problems.append("the summary counts {} collisions".format(collisions[-1]))
    if not all(truth.exists() for _, truth in truths):
        out.problems.append("no ground truth")
        return
    knots: Dict[int, list] = {}  # each robot's whole path: its parts' starts one after another
    for _, truth in truths:
        for rid, path in truth_paths(truth).items():
            knots.setdefault(rid, []).extend(path)  # (while a part was down its robots stood still)
        ran = [(e["robot"], e["epoch"], e["id"]) for e in exec_lines(truth)]
        twice = sorted({r for r in ran if ran.count(r) > 1})
        if twice:  # (a command sent again to a robot started afresh runs again: it forgot it)
            out.problems.append("commands started twice: {}".format(twice[:3]))
    verdict = judge([sorted(knots[r]) for r in sorted(knots)], TURTLEBOT2.safe_cells)
    if not verdict.safe_run:
        out.problems.append("robots closer than the safe distance: {}".format(verdict.violations[:2]))
    final: Dict[int, Tuple[float, float]] = {}
    for part in sorted({p for p, _ in truths}):
        starts = [truth for p, truth in truths if p == part]
        for before, after in zip(starts, starts[1:]):  # a power cut moves no robot
            last = truth_poses(before)[-1] if truth_poses(before) else {}
            start = next((json.loads(line) for line in after.open() if '"k":"start"' in line), {})
            moved = sorted(r for r, (x, y, *_) in start.get("robots", {}).items()
                           if int(r) in last and math.hypot(x - last[int(r)][0], y - last[int(r)][1]) > 1e-3)
            if moved:
                out.problems.append("robots {} started again away from where the power cut left them".format(moved))
        poses = truth_poses(starts[-1])
        final.update(poses[-1] if poses else {})
    folders = sorted(p for p in runs.iterdir() if p.is_dir()) if runs.exists() else []
    if len(final) == 5 and folders:
        run = read_run(folders[-1])
        goals = {r: tuple(g) for r, g in zip(run.robots, run.run["goals"])}
        away = [r for r, g in goals.items() if math.hypot(final[r][0] - g[0], final[r][1] - g[1]) > AT_GOAL]
        if away:
            out.problems.append("robots {} are not on their goals".format(away))
