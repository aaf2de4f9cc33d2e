"""Run folders: what the manager and the simulator write is what the tools read back."""
from __future__ import annotations

import json
import math
from pathlib import Path

import pytest
from hypothesis import given
from hypothesis import strategies as st

from fleet_common.errors import FleetError
from fleet_common.runlog import RunLog, new_run_folder, read_run
from fleet_common.runlog.reader import RunLogError
from fleet_common.runlog.writer import cut_torn_tail


class FakeClock:
    def __init__(self) -> None:
        self.now = 100.0

    def __call__(self) -> float:
        return self.now


def started(folder: Path, clock: FakeClock = None) -> RunLog:
    log = RunLog(folder, clock=clock) if clock else RunLog(folder)
    log.run_started(source="manager", time_unit="s", plan="plan-1.txt", robots=[3, 1],
                    strategy="adg")
    return log


def test_records_come_back_in_order_with_their_times(tmp_path: Path) -> None:
    clock = FakeClock()
    with started(tmp_path, clock) as log:
        clock.now += 0.25
        log.record("command", robot=3, id=1, type="drive", x=1.0, y=2.0, time=0.0, action=0)
        clock.now += 0.5
        log.record("reply", robot=3, id=1, type="accepted")
    run = read_run(tmp_path)
    assert [r["k"] for r in run.records] == ["run", "command", "reply"]
    assert [r["t"] for r in run.records] == [0.0, 0.25, 0.75]
    assert run.robots == [3, 1] and not run.torn and not run.ended
    assert run.plan_files() == [tmp_path / "plan-1.txt"]


def test_a_line_is_on_disk_within_a_second_without_close(tmp_path: Path) -> None:
    clock = FakeClock()
    log = started(tmp_path, clock)
    log.record("state", run="running")
    clock.now += 1.0
    log.record("state", run="paused")  # a second later: flushed with it
    text = (tmp_path / "events.jsonl").read_text()
    assert text.count("\n") == 3  # the crash would lose nothing so far
    log.close()


def test_a_torn_last_line_is_dropped_and_reported(tmp_path: Path) -> None:
    with started(tmp_path) as log:
        log.record("state", run="running")
    with open(tmp_path / "events.jsonl", "a") as f:
        f.write('{"t":1.5,"k":"poses","p":[[3,1.0')  # the crash came mid-line
    run = read_run(tmp_path)
    assert run.torn and [r["k"] for r in run.records] == ["run", "state"]


def test_what_a_resumed_manager_needs_is_on_disk_at_once_poses_wait_for_the_flush(tmp_path: Path) -> None:
    clock = FakeClock()
    log = started(tmp_path, clock)
    clock.now += 0.1
    log.record("poses", p=[[3, 1.0, 2.0, 0.0, "robot", 0.05]])
    assert (tmp_path / "events.jsonl").read_text().count("\n") == 1  # a killed writer may lose it
    log.record("command", robot=3, id=7, type="drive", x=1.0, y=2.0, time=0.0, action=0)
    assert (tmp_path / "events.jsonl").read_text().count("\n") == 3  # and the pose before it
    log.close()


def test_a_batch_of_records_is_on_disk_once_the_batch_ends(tmp_path: Path) -> None:
    """The manager writes a batch's records, then sends its commands: when the batch ends, what
    a resumed manager needs of it is on disk (a killed writer loses none of it)."""
    clock = FakeClock()
    log = started(tmp_path, clock)
    with log.batch():
        log.record("poses", p=[[3, 1.0, 2.0, 0.0, "robot", 0.05]])
        log.record("command", robot=3, id=7, type="drive", x=1.0, y=2.0, time=0.0, action=0)
        log.record("reply", robot=3, id=6, type="completed")
    kinds = [json.loads(line)["k"] for line in (tmp_path / "events.jsonl").read_text().splitlines()]
    assert kinds == ["run", "poses", "command", "reply"]
    with log.batch():  # nothing durable: the poses wait for the second's flush, as outside a batch
        log.record("poses", p=[[3, 1.0, 2.0, 0.0, "robot", 0.05]])
    assert (tmp_path / "events.jsonl").read_text().count("\n") == 4
    log.close()


def test_a_torn_tail_is_cut_before_a_resumed_manager_appends(tmp_path: Path) -> None:
    with started(tmp_path) as log:
        log.record("state", run="running")
    with open(tmp_path / "events.jsonl", "a") as f:
        f.write('{"t":1.5,"k":"poses","p":[[3,1.0')  # killed mid-line
    assert cut_torn_tail(tmp_path) == len('{"t":1.5,"k":"poses","p":[[3,1.0')
    assert cut_torn_tail(tmp_path) == 0
    with RunLog(tmp_path) as log:
        log.record("resume", started="now", plan="plan-1.txt")
    run = read_run(tmp_path)
    assert not run.torn and [r["k"] for r in run.records] == ["run", "state", "resume"]


def test_a_damaged_line_in_the_middle_is_an_error_naming_it(tmp_path: Path) -> None:
    with started(tmp_path) as log:
        log.record("state", run="running")
    lines = (tmp_path / "events.jsonl").read_text().splitlines()
    lines.insert(1, "garbage")
    (tmp_path / "events.jsonl").write_text("\n".join(lines) + "\n")
    with pytest.raises(RunLogError, match=r"events\.jsonl:2: damaged line"):
        read_run(tmp_path)


def test_not_a_run_folder(tmp_path: Path) -> None:
    with pytest.raises(RunLogError, match="not a run folder"):
        read_run(tmp_path)
    (tmp_path / "events.jsonl").write_text(json.dumps({"t": 0, "k": "state", "run": "x"}) + "\n")
    with pytest.raises(RunLogError, match=":1: the first line is not"):
        read_run(tmp_path)


def test_a_newer_format_is_refused_not_misread(tmp_path: Path) -> None:
    (tmp_path / "events.jsonl").write_text(json.dumps({"t": 0, "k": "run", "version": 99}) + "\n")
    with pytest.raises(RunLogError, match="version 99"):
        read_run(tmp_path)


def test_writer_refuses_unknown_kinds_and_missing_fields(tmp_path: Path) -> None:
    with started(tmp_path) as log:
        with pytest.raises(ValueError, match="unknown run log kind"):
            log.record("chatter", text="hi")
        with pytest.raises(ValueError, match="lacks robot"):
            log.record("command", id=1, type="drive")


def test_new_run_folders_never_collide(tmp_path: Path) -> None:
    folders = {new_run_folder(tmp_path) for _ in range(5)}
    assert len(folders) == 5 and all(f.is_dir() and f.parent == tmp_path for f in folders)


@given(st.lists(st.tuples(st.integers(0, 10 ** 6), st.floats(allow_nan=True, allow_infinity=True),
                          st.text(max_size=20)), max_size=20))
def test_any_values_round_trip_as_json(values: list) -> None:
    import tempfile
    with tempfile.TemporaryDirectory() as d:
        with started(Path(d)) as log:
            for robot, x, note in values:
                log.record("fault", robot=robot, faults=[note], x=x)
        faults = list(read_run(d).of("fault"))
    assert [(r["robot"], r["faults"][0]) for r in faults] == [(v[0], v[2]) for v in values]
    # non-finite numbers become null rather than an unreadable token
    assert all(r["x"] is None or r["x"] == r["x"] for r in faults)


# ---- what is computed from a run folder -----------------------------------------------

def timed_run(folder: Path, actions: list, starts: list):
    """A manager's run of robots 7 and 9 logged into `folder`, and `at(t, kind, **fields)`, which
    records at `t` seconds into it."""
    clock = FakeClock()
    log = RunLog(folder, clock=clock)
    log.run_started(source="manager", time_unit="s", plan="plan-1.txt", robots=[7, 9],
                    strategy="adg", actions=actions, starts=starts)

    def at(t: float, kind: str, **fields) -> None:
        clock.now = 100.0 + t
        log.record(kind, **fields)
    return log, at


def crossing_run(folder: Path, collide: bool = False) -> None:
    """Two robots in a 3-cell corridor: robot 7 moves (0,0)->(1,0)->(2,0); robot 9 waits at
    (1,1) and enters (1,0) after robot 7 left it (or, with `collide`, while it is still there)."""
    log, at = timed_run(folder, actions=[2, 1], starts=[[0, 0], [1, 1]])
    at(1.0, "state", run="running")
    at(1.0, "command", robot=7, id=1, type="drive", action=0)
    at(1.1, "action", robot=7, index=0, phase="started", src=[0, 0], dst=[1, 0])
    at(3.0, "action", robot=7, index=0, phase="completed", src=[0, 0], dst=[1, 0])
    at(3.0, "command", robot=7, id=2, type="drive", action=1)
    at(3.1, "action", robot=7, index=1, phase="started", src=[1, 0], dst=[2, 0])
    enter = 4.0 if collide else 5.0
    at(enter, "dispatch", robot=9, index=0, step=1, src=[1, 1], dst=[1, 0], waited=enter - 1.0,
       released_by=7)
    at(enter, "command", robot=9, id=1, type="drive", action=0)
    at(enter + 0.1, "action", robot=9, index=0, phase="started", src=[1, 1], dst=[1, 0])
    at(5.0, "action", robot=7, index=1, phase="completed", src=[1, 0], dst=[2, 0])
    at(enter + 2.0, "action", robot=9, index=0, phase="completed", src=[1, 1], dst=[1, 0])
    at(4.0, "poses", p=[[7, 1.5, 0.0, 0.0, "robot", 0.0], [9, 1.0, 0.6, 0.0, "robot", 0.0]])
    at(enter + 2.0, "state", run="done")
    log.close()


def test_the_summary_is_computed_from_the_records_alone(tmp_path: Path) -> None:
    from fleet_common.runlog.summary import SummaryBuilder

    crossing_run(tmp_path)
    builder = SummaryBuilder()
    for record in read_run(tmp_path).records:
        builder.feed(record)
    s = builder.summary()
    assert s.arrived == [7, 9] and s.enabled == 2
    assert s.makespan == pytest.approx(6.0) and s.soc == pytest.approx(4.0 + 6.0)
    assert s.wait == pytest.approx(4.0) and s.collisions == 0
    assert s.min_distance == pytest.approx(math.hypot(0.5, 0.6))
    assert "arrived: 2/2" in s.lines() and "collisions: 0" in s.lines()


def test_a_robot_entering_a_cell_not_yet_left_is_a_collision(tmp_path: Path) -> None:
    from fleet_common.runlog.summary import SummaryBuilder

    crossing_run(tmp_path, collide=True)
    builder = SummaryBuilder()
    for record in read_run(tmp_path).records:
        builder.feed(record)
    assert builder.summary().collisions == 1


def halted_and_replanned_run(folder: Path, enter: float) -> None:
    """Robots as large as a cell: robot 7 sets off (0,0)->(1,0) and is halted near the end of the
    move, which it never completes; at 3 s a replan starts it on (1,0), where it stands. Robot 9
    goes (0,1)->(0,0) at `enter`: after the replan (its plan 2 move), or before it (plan 1)."""
    log, at = timed_run(folder, actions=[1, 1], starts=[[0, 0], [0, 1]])
    at(1.0, "state", run="running")
    at(1.1, "action", robot=7, index=0, phase="started", src=[0, 0], dst=[1, 0])
    if enter < 3.0:
        at(enter, "action", robot=9, index=0, phase="started", src=[0, 1], dst=[0, 0])
        at(enter + 0.5, "action", robot=9, index=0, phase="completed", src=[0, 1], dst=[0, 0])
    at(1.8, "out", robot=7, why="failed", reason="halted: stopped by command 3")
    at(3.0, "plan", file="plan-2.txt", robots=[7, 9], reason="replan", at=None, actions=[0, 1 if enter > 3.0 else 0],
       starts=[[1, 0], [0, 1] if enter > 3.0 else [0, 0]])
    if enter > 3.0:
        at(enter, "action", robot=9, index=0, phase="started", src=[0, 1], dst=[0, 0])
        at(enter + 0.5, "action", robot=9, index=0, phase="completed", src=[0, 1], dst=[0, 0])
    log.close()


@pytest.mark.parametrize("enter,collisions", [(4.0, 0), (2.0, 1)])
def test_a_robot_a_replan_starts_on_the_target_of_a_move_it_never_completed_has_left_its_cell(
        tmp_path: Path, enter: float, collisions: int) -> None:
    """Robot 9 entering (0,0) after the replan started robot 7 on (1,0) is no collision (before,
    the count kept robot 7 on (0,0) for the rest of the run: a collision counted in random operator
    sessions, --wide, seed 382, where the robots never came closer than a cell); entering while
    robot 7 was on its way, before the replan, is one."""
    from fleet_common.runlog.summary import SummaryBuilder

    halted_and_replanned_run(tmp_path, enter)
    builder = SummaryBuilder()
    for record in read_run(tmp_path).records:
        builder.feed(record)
    assert builder.summary().collisions == collisions


def test_the_executed_plan_holds_each_cell_until_the_move_out_completes(tmp_path: Path) -> None:
    from fleet_common.runlog.executed import executed_plan

    crossing_run(tmp_path)
    plan = executed_plan(read_run(tmp_path), 1.0, [(0, 0), (1, 1)])
    rows = [[tuple(c) for c in row] for row in plan.positions.tolist()]
    # rows at t = 1, 2, ..., 7 (begin 1.0, end 7.0)
    assert rows == [[(0, 0), (1, 1)], [(0, 0), (1, 1)], [(1, 0), (1, 1)], [(1, 0), (1, 1)],
                    [(2, 0), (1, 1)], [(2, 0), (1, 1)], [(2, 0), (1, 0)]]
    with pytest.raises(ValueError):
        executed_plan(read_run(tmp_path), 0.0, [(0, 0), (1, 1)])


def test_the_traced_plan_moves_a_robot_one_cell_a_row_when_a_completion_report_came_late(tmp_path: Path) -> None:
    """Robot 7 drives (0,0) -> (3,0), half a second a move; the report of its second move comes
    0.1 s late, so its third comes 0.35 s after it. Rows as long as the quickest move (0.5 s,
    what `fleetctl trace` used) show the robot two cells on in one row, a plan the validator
    refuses (a CI run of the resume test traced one); the traced plan's rows are short enough."""
    from fleet_common.runlog.executed import executed_plan, traced_plan

    log, at = timed_run(tmp_path, actions=[3, 0], starts=[[0, 0], [5, 5]])
    at(1.0, "state", run="running")
    for index, (sent, started, completed) in enumerate([(1.0, 1.0, 1.5), (1.5, 1.5, 2.1), (1.6, 2.0, 2.45)]):
        at(sent, "command", robot=7, id=index + 1, type="drive", action=index)
        at(started, "action", robot=7, index=index, phase="started", src=[index, 0], dst=[index + 1, 0])
        at(completed, "action", robot=7, index=index, phase="completed", src=[index, 0], dst=[index + 1, 0])
    at(3.0, "state", run="done")
    log.close()
    run = read_run(tmp_path)

    def cells_per_row(plan) -> list:
        return [abs(a[0][0] - b[0][0]) for a, b in zip(plan.positions.tolist(), plan.positions.tolist()[1:])]

    assert max(cells_per_row(executed_plan(run, 0.5, [(0, 0), (5, 5)]))) == 2  # the control: rows too long
    plan, dt = traced_plan(run, [(0, 0), (5, 5)])
    assert dt == pytest.approx(0.35) and max(cells_per_row(plan)) == 1
    assert [tuple(c) for c in plan.positions[-1].tolist()] == [(3, 0), (5, 5)]
    assert traced_plan(run, [(0, 0), (5, 5)], 0.25)[1] == 0.25  # a row time given is kept


def test_a_runs_folder_that_is_a_file_is_named_as_such(tmp_path: Path) -> None:
    taken = tmp_path / "runs"
    taken.write_text("not a folder")
    with pytest.raises(FleetError, match=r"runs: it is a file, not a folder"):
        new_run_folder(taken)


def test_the_executed_plan_shows_a_leader_leaving_once_its_follower_is_in(tmp_path: Path) -> None:
    # robots of real size: robot 9 follows robot 7 east along y = 0 and reaches (1, 0) at 2.8,
    # while robot 7 completes its move out of (1, 0) only at 3.0
    from fleet_common.runlog.executed import executed_plan

    clock = FakeClock()
    log = RunLog(tmp_path, clock=clock)
    log.run_started(source="manager", time_unit="s", plan="plan-1.txt", robots=[7, 9],
                    strategy="adg", actions=[1, 1], starts=[[1, 0], [0, 0]])
    for t, kind, fields in [(1.0, "state", dict(run="running")),
                            (1.2, "action", dict(robot=7, index=0, phase="started", src=[1, 0], dst=[2, 0])),
                            (1.2, "action", dict(robot=9, index=0, phase="started", src=[0, 0], dst=[1, 0])),
                            (2.8, "action", dict(robot=9, index=0, phase="completed", src=[0, 0], dst=[1, 0])),
                            (3.0, "action", dict(robot=7, index=0, phase="completed", src=[1, 0], dst=[2, 0])),
                            (4.0, "state", dict(run="done"))]:
        clock.now = 100.0 + t
        log.record(kind, **fields)
    log.close()
    plan = executed_plan(read_run(tmp_path), 0.1, [(1, 0), (0, 0)])
    rows = [[tuple(c) for c in row] for row in plan.positions.tolist()]
    assert all(len(set(row)) == 2 for row in rows)  # never two robots in one cell
    assert rows[17] == [(1, 0), (0, 0)]  # at 2.7 neither has arrived
    assert rows[18] == rows[20] == [(2, 0), (1, 0)]  # at 2.8 the follower is in: its leader on its way out


def test_the_live_count_counts_robots_reported_too_close_and_allows_for_the_time_between_reports() -> None:
    from fleet_common.robot_size import TURTLEBOT2
    from fleet_common.runlog.records import size_fields
    from fleet_common.runlog.summary import SummaryBuilder

    def builder() -> SummaryBuilder:
        b = SummaryBuilder()
        b.feed({"k": "run", "t": 0.0, "robots": [1, 2], "actions": [1, 1], "starts": [[0, 0], [5, 0]],
                "size": size_fields(TURTLEBOT2)})
        return b

    # reported at the same moment, 0.4 cells (0.28 m) apart: too close
    b = builder()
    b.feed({"k": "poses", "t": 1.0, "p": [[1, 3.0, 0.0, 0, "robot", 0.0], [2, 3.4, 0.0, 0, "robot", 0.0]]})
    assert b.collisions == 1
    assert "collisions: 1 (pairs closer than 0.454 m)" in b.summary().lines()
    # robot 2 was seen driving 5 cells a second; its pose is 0.1 s older than robot 1's: it may be
    # 0.5 cells further on, so the pair is not counted (a sampled monitor cannot tell)
    b = builder()
    b.feed({"k": "poses", "t": 0.5, "p": [[1, 0.0, 0.0, 0, "robot", 0.0], [2, 1.0, 0.0, 0, "robot", 0.0]]})
    b.feed({"k": "poses", "t": 1.0, "p": [[1, 3.0, 0.0, 0, "robot", 0.0], [2, 3.4, 0.0, 0, "robot", 0.1]]})
    assert b.collisions == 0 and b.summary().min_distance == pytest.approx(0.4)
    # robots as large as a cell: the cell rule counts, not the distance
    cell = SummaryBuilder()
    cell.feed({"k": "run", "t": 0.0, "robots": [1, 2], "actions": [1, 1], "starts": [[0, 0], [5, 0]]})
    cell.feed({"k": "poses", "t": 1.0, "p": [[1, 3.0, 0.0, 0, "robot", 0.0], [2, 3.4, 0.0, 0, "robot", 0.0]]})
    assert cell.collisions == 0
