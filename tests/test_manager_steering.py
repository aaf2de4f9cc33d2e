"""Steering a running fleet from consoles: a real manager and virtual fleet, scripted consoles.

Each control is checked by what the next state says and by what the robots do;
refusals (a stale picture, garbage) change nothing. Faults and replanning are
run end to end.
"""
from __future__ import annotations

import re
import signal
from pathlib import Path
from typing import Iterator, Tuple

import pytest
import zmq

from fleet_common.control import decode
from fleet_common.control import messages as m
from fleet_common.lab import lab_instance_path
from fleet_common.runlog import read_run
from helpers import wait_until
from live import Proc, ScriptedConsole, fleet_definitions, start_fleet, start_manager
from virtual_fleet.truth import exec_lines

pytestmark = pytest.mark.slow


@pytest.fixture
def lab_run(tmp_path: Path, request) -> Iterator[Tuple[Proc, Proc, int, Path]]:
    """A virtual fleet of the five lab robots and a manager waiting for Start."""
    fleet_args = getattr(request, "param", ())
    definitions, feedback, port = fleet_definitions(tmp_path, 5)
    fleet = start_fleet(tmp_path, definitions, feedback, "--time-scale", "4", *fleet_args)
    manager = start_manager(tmp_path, lab_instance_path(), definitions, port, "--log",
                            tmp_path / "runs", "--step-time", "0.6", "--until-done",
                            "--time-limit", "200")
    try:
        yield fleet, manager, port, tmp_path
    finally:
        manager.stop()
        fleet.stop()


def ready(console: ScriptedConsole) -> None:
    console.wait_for(lambda c: c.state and all(r.link == "up" and r.age is not None
                                               for r in c.state.robots), why="robots up")


def done_moves(console: ScriptedConsole) -> int:
    return sum(r.done for r in console.state.robots)


def robot(console: ScriptedConsole, rid: int) -> m.RobotState:
    return next(r for r in console.state.robots if r.id == rid)


def test_every_control_shows_in_the_next_state_and_stale_requests_are_refused(lab_run) -> None:
    """Over the real sockets and processes (each control's effect on the robots is tested in
    memory, tests/test_manager_core.py): every request is answered, shows in the next state,
    and a request on a stale picture is refused before it reaches the run."""
    fleet, manager, port, folder = lab_run
    ops, other = ScriptedConsole(port, "ops"), ScriptedConsole(port, "visitor desk")
    try:
        ready(ops)
        other.wait_for(lambda c: c.state is not None)
        assert ops.ask("start").ok
        ops.wait_for(lambda c: c.state.run.state == "running" and done_moves(c) >= 5, why="moving")
        assert ops.ask("pause").ok
        ops.wait_for(lambda c: c.state.run.state == "paused", why="paused")
        held = done_moves(ops)
        assert ops.ask("step").ok
        ops.wait_for(lambda c: done_moves(c) > held, why="a round")
        assert ops.ask("strategy", name="step").ok
        assert ops.wait_for(lambda c: c.state.run.strategy == "step")
        looked_at = other.wait_for(lambda c: c.state.run.strategy == "step" and c.state.version)
        assert ops.ask("disable", robot=2).ok
        assert ops.wait_for(lambda c: robot(c, 2).out == "disabled")
        # the other operator acts on what they looked at, from before the disable: refused, why
        stale = other.ask("enable", robot=2, based_on=looked_at)
        assert not stale.ok and "robot 2 disabled" in stale.reason and "look again" in stale.reason
        assert robot(ops, 2).out == "disabled"
        assert ops.ask("enable", robot=2).ok
        assert ops.wait_for(lambda c: robot(c, 2).out is None)
        refused = ops.ask("disable", robot=99)
        assert not refused.ok and "not in this run" in refused.reason
        assert ops.ask("start").ok
        assert manager.wait(200) == 0, manager.text()[-3000:]
    finally:
        ops.close()
        other.close()
    run = read_run(next((folder / "runs").iterdir()))
    actions = [(r["action"], r["ok"]) for r in run.of("operator")]
    assert ("enable", False) not in actions[:3]  # the stale request never reached the manager
    assert [a for a, ok in actions if ok] == ["start", "pause", "step", "strategy", "disable", "enable",
                                              "start"]


def test_garbage_from_a_console_is_answered_and_changes_nothing(lab_run) -> None:
    fleet, manager, port, _ = lab_run
    ops = ScriptedConsole(port)
    context = zmq.Context()
    raw = context.socket(zmq.DEALER)
    raw.linger = 0
    try:
        ready(ops)
        version = ops.state.version
        raw.connect("tcp://127.0.0.1:{}".format(port))
        for frame in (b"\x00\xff" * 100, b"[" * 50000, b'{"t":"request","v":1,"id":1e999}',
                      b'{"t":"hello","v":1,"name":"' + b"x" * 5000 + b'"}'):
            raw.send(frame)
            assert raw.poll(5000), "no answer to garbage"
            answer = decode(raw.recv(), m.MANAGER_MESSAGES)
            assert isinstance(answer, m.Answer) and not answer.ok and answer.reason
        seq = ops.state.seq
        ops.wait_for(lambda c: c.state.seq > seq + 2, why="states after the garbage")
        assert ops.state.version == version and ops.state.run.state == "waiting"
        assert ops.ask("start").ok  # and it still obeys a proper request
        ops.wait_for(lambda c: done_moves(c) >= 1)
    finally:
        raw.close()
        context.term()
        ops.close()
    assert manager.popen.poll() is None


@pytest.mark.parametrize("lab_run", [("--bump", "2@2")], indirect=True)
def test_a_robot_that_bumps_into_something_is_held_until_enabled(lab_run) -> None:
    fleet, manager, port, folder = lab_run
    ops = ScriptedConsole(port)
    try:
        ready(ops)
        assert ops.ask("start").ok
        ops.wait_for(lambda c: robot(c, 2).out == "failed" and "bumper" in robot(c, 2).faults,
                     timeout=60, why="robot 2 held with its bumper fault")
        assert any(e.kind == "fault" and e.robot == 2 and "bumper" in e.text for e in ops.session.notices)
        done = robot(ops, 2).done
        ops.pump(0.5)  # the foot stays on the bumper for 0.25 s (1 fleet second): enable after it left
        assert ops.ask("enable", robot=2).ok  # a stop clears the fault, then it drives on
        ops.wait_for(lambda c: robot(c, 2).done > done and not robot(c, 2).faults, timeout=60,
                     why="robot 2 moving again")
        assert manager.wait(200) == 0, manager.text()[-3000:]
    finally:
        ops.close()
    out = manager.text()
    assert "arrived: 5/5" in out and "collisions: 0" in out


@pytest.mark.parametrize("lab_run", [("--bump", "2@2")], indirect=True)
def test_no_replan_while_a_robot_stands_between_two_cells_after_a_fault(lab_run) -> None:
    """Robot 2's bumper stops it halfway through a drive. Enabled again while the run is paused,
    it still stands between two cells: a replan (from its cell) is refused, saying why, until
    the run goes on and robot 2 finishes that move."""
    fleet, manager, port, folder = lab_run
    ops = ScriptedConsole(port)
    try:
        ready(ops)
        assert ops.ask("start").ok
        ops.wait_for(lambda c: robot(c, 2).out == "failed", timeout=60, why="robot 2 held with its bumper fault")
        assert ops.ask("pause").ok
        ops.pump(0.5)  # the foot stays on the bumper for 0.25 s (1 fleet second): enable after it left
        assert ops.ask("enable", robot=2).ok
        ops.wait_for(lambda c: not robot(c, 2).out, timeout=10, why="robot 2 enabled")
        answer = ops.ask("replan", time_limit=5.0)
        assert not answer.ok and "robot 2 stopped between two cells after a fault" in answer.reason, answer
        done = robot(ops, 2).done
        assert ops.ask("start").ok
        ops.wait_for(lambda c: robot(c, 2).done > done, timeout=60, why="robot 2 finishing its move")
        proposal = proposed(ops)
        assert ops.ask("reject", proposal=proposal.id).ok
        assert manager.wait(200) == 0, manager.text()[-3000:]
    finally:
        ops.close()
    out = manager.text()
    assert "arrived: 5/5" in out and "collisions: 0" in out


def proposed(ops: ScriptedConsole):
    """The operator asks for a replan; its proposal, once the state names it (answer it only then:
    an answer before it is refused as given on an older picture)."""
    answer = ops.ask("replan", time_limit=5.0)
    assert answer.ok, answer.reason
    proposal = ops.wait_for(lambda c: c.session.proposal, timeout=60, why="a proposal")
    ops.wait_for(lambda c: c.state.run.proposal == proposal.id, timeout=5, why="the state naming the proposal")
    return proposal


def test_replanning_around_a_robot_disabled_for_good(lab_run) -> None:
    fleet, manager, port, folder = lab_run
    ops = ScriptedConsole(port)
    try:
        ready(ops)
        assert ops.ask("start").ok
        ops.wait_for(lambda c: done_moves(c) >= 8)
        assert ops.ask("disable", robot=5).ok
        proposal = proposed(ops)
        assert ops.state.run.state == "paused"
        plan = proposal.plan.positions
        robots = list(proposal.plan.robots)
        stays = plan[:, robots.index(5)]
        assert (stays == stays[0]).all()  # the disabled robot is an obstacle where it stands
        # nobody moved across the switch: every robot stands on the proposal's first cell (as
        # soon as its pose feedback, 10 a second, has caught up with the move it finished)
        def on_first_cells(c: ScriptedConsole) -> bool:
            return all(abs(r.x - plan[0, robots.index(r.id)][0]) < 0.05 and
                       abs(r.y - plan[0, robots.index(r.id)][1]) < 0.05 for r in c.state.robots)
        ops.wait_for(on_first_cells, timeout=3, why="every robot on the proposal's first cell")
        assert ops.state.run.proposal == proposal.id
        assert ops.ask("accept", proposal=proposal.id).ok
        assert manager.wait(200) == 0, manager.text()[-3000:]
    finally:
        ops.close()
    out = manager.text()
    assert "arrived: 4/4 (of 5 robots; 1 out)" in out and "collisions: 0" in out
    run = read_run(next((folder / "runs").iterdir()))
    assert [p.name for p in run.plan_files()] == ["plan-1.txt", "plan-2.txt"]
    assert all(p.is_file() for p in run.plan_files())


def test_an_unattended_run_that_cannot_go_on_says_why(tmp_path: Path) -> None:
    """--until-done with nobody at a console: a robot held by its bumper stops the run, which
    ends with exit 1 naming the robot and who waits for it, robots stopped, the log closed."""
    definitions, feedback, port = fleet_definitions(tmp_path, 5)
    fleet = start_fleet(tmp_path, definitions, feedback, "--time-scale", "4", "--bump", "5@1")
    manager = start_manager(tmp_path, lab_instance_path(), definitions, port, "--start",
                            "--until-done", "--log", tmp_path / "runs", "--time-limit", "200")
    try:
        assert manager.wait(200) == 1, manager.text()[-3000:]
    finally:
        manager.stop()
        fleet.stop()
    out = manager.text()
    assert "the run cannot go on without an operator: robot 5 is held by a fault" in out, out
    arrived = re.search(r"^arrived: (\d)/5$", out, re.M)
    assert arrived and int(arrived.group(1)) < 5, out
    run = read_run(next((tmp_path / "runs").iterdir()))
    assert run.ended and "cannot go on" in run.last("end")["reason"]


def test_ctrl_c_stops_every_robot_and_closes_the_run_log(tmp_path: Path) -> None:
    definitions, feedback, port = fleet_definitions(tmp_path, 5)
    truth = tmp_path / "truth.jsonl"
    fleet = start_fleet(tmp_path, definitions, feedback, "--time-scale", "2", "--truth", truth)
    manager = start_manager(tmp_path, lab_instance_path(), definitions, port, "--start",
                            "--log", tmp_path / "runs")
    ops = ScriptedConsole(port)
    try:
        ops.wait_for(lambda c: c.state and sum(r.done for r in c.state.robots) >= 3, why="moving")
        manager.popen.send_signal(signal.SIGINT)
        assert manager.wait(30) == 130, manager.text()[-2000:]
        wait_until(lambda: {e["robot"] for e in exec_lines(truth) if e["type"] == "stop"} == {1, 2, 3, 4, 5},
                   10, "every robot stopped (the fleet writes what it carried out as it goes)")
    finally:
        ops.close()
        manager.stop()
        fleet.stop()
    run = read_run(next((tmp_path / "runs").iterdir()))
    assert not run.torn and run.last("end")["reason"] == "interrupted (SIGINT)"
    # the summary says the run was cut short, when, and what was executed by then
    line = re.search(r"^interrupted at ([\d.]+) s \(interrupted \(SIGINT\)\): (\d+) of (\d+) moves executed",
                     manager.text(), re.M)
    assert line and float(line.group(1)) > 0 and 3 <= int(line.group(2)) < int(line.group(3)), manager.text()
    assert "executed makespan: 0.00" not in manager.text()
