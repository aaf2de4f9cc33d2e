"""mapf-IR solution files: shipped files round-trip, y and headings flip, errors give line:column."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, strategies as st

from fleet_common.errors import FormatWarning, MapNotFoundError, NotConvertibleError, SolutionFormatError
from fleet_common.formats.instance import read_instance
from fleet_common.formats.solution import (format_solution, make_solution, parse_solution,
                                           read_solution, write_solution)
from fleet_common.grid import Grid
from fleet_common.plan import Orientation, Plan

SHARED = Path(__file__).resolve().parents[2] / "shared" / "data" / "mapf-ir"
SHIPPED = sorted((SHARED / "solutions").glob("*.txt"))
PARETO_MAP = "height 4\nwidth 6\nmap\nTTTT.T\n......\n.TT.T.\n..T...\n"


def test_all_shipped_solutions_are_found(shared_data):
    assert len(SHIPPED) == len(list((shared_data / "solutions").glob("*.txt"))) >= 5


@pytest.mark.parametrize("path", SHIPPED, ids=lambda p: p.name)
def test_shipped_solution_round_trips_byte_for_byte(path, shared_data, tmp_path):
    sol = read_solution(path, map_dirs=[shared_data / "maps"])
    raw = path.read_bytes()
    assert format_solution(sol).encode() == raw
    assert format_solution(sol, orientation="mapf-ir").encode() == raw
    write_solution(sol, tmp_path / path.name)
    assert (tmp_path / path.name).read_bytes() == raw
    base = parse_solution(format_solution(sol, "base"), grid=sol.grid)
    assert base.orientation == "base" and base.header.get("orientation") == "base"
    assert (base.starts, base.goals, base.plan) == (sol.starts, sol.goals, sol.plan)
    assert format_solution(base, "mapf-ir").encode() == raw
    if sol.plan is not None:  # mapf-IR's own figures agree with the plan we read
        assert (sol.plan.soc, sol.plan.makespan) == (sol.soc, sol.makespan)
        assert sol.plan.starts == sol.starts and sol.plan.goals == sol.goals


def test_failed_run_has_no_plan(shared_data):
    sol = read_solution(shared_data / "solutions" / "cbs_arena300_1_timeout.txt",
                        map_dirs=[shared_data / "maps"])
    assert sol.plan is None and not sol.solved and sol.makespan == -1 and sol.soc == 0
    assert (sol.agents, sol.lb_soc, sol.lb_makespan, sol.comp_time) == (300, 9722, 80, 502)
    assert len(sol.starts) == 300 and sol.instance == "../instances/arena_300agents_1.txt"


def test_ir_iterations_are_kept_in_order(shared_data):
    sol = read_solution(shared_data / "solutions" / "ir_makespan-soc-pareto.txt",
                        map_dirs=[shared_data / "maps"])
    its = sol.iterations
    assert its[0] == {"iter": 0, "comp_time": 0, "soc": 31, "makespan": 31}
    assert [i["iter"] for i in its] == list(range(len(its))) and len(its) > 10
    assert sol.header.keys()[:4] == ["instance", "agents", "map_file", "solver"]


def test_orientation_flip_matches_the_instance(shared_data):
    maps = [shared_data / "maps"]
    sol = read_solution(shared_data / "solutions" / "cbs_makespan-soc-pareto.txt", map_dirs=maps)
    inst = read_instance(shared_data / "instances" / "makespan-soc-pareto.txt", map_dirs=maps)
    # file goal (4,1) on the 4-high map is base (4,2), in both files
    assert sol.goals[0] == (4, 2) == inst.goals[0]
    assert (sol.starts, sol.goals) == (inst.starts, inst.goals)
    assert sol.plan.config(1) == [(4, 2), (0, 0)]  # file row "1:(4,1),(0,3),"


def test_older_instance_line_with_a_space_is_kept_raw():
    grid = Grid(np.ones((2, 2), dtype=bool))
    text = "instance= x.txt\nagents=1\nmap_file=m.map\nsolved=1\nstarts=(0,0),\ngoals=(0,0),\nsolution=\n0:(0,0),\n"
    sol = parse_solution(text, grid=grid)
    assert sol.instance == "x.txt" and sol.header.get("instance") == " x.txt"
    assert format_solution(sol) == text


def test_headings_flip_with_y_and_survive_both_orientations():
    grid = Grid(np.ones((3, 3), dtype=bool))
    text = ("agents=2\nmap_file=m.map\nstarts=(0,0),(2,2),\ngoals=(0,1),(2,2),\nsolution=\n"
            "0:(0,0,Y_PLUS),(2,2,X_MINUS),\n1:(0,1,Y_PLUS),(2,2,Y_MINUS),\n")
    sol = parse_solution(text, grid=grid)
    # file y points down: Y_PLUS in the file is Y_MINUS in the base frame
    assert sol.plan.orientations[0].tolist() == [Orientation.Y_MINUS, Orientation.X_MINUS]
    assert sol.plan.orientations[1].tolist() == [Orientation.Y_MINUS, Orientation.Y_PLUS]
    assert sol.plan.config(1) == [(0, 1), (2, 0)]
    assert format_solution(sol) == text
    base = format_solution(sol, "base")
    assert "0:(0,2,Y_MINUS),(2,0,X_MINUS),\n" in base
    assert format_solution(parse_solution(base, grid=grid), "mapf-ir") == text


def test_partial_headings_cannot_be_written():
    grid = Grid(np.ones((2, 2), dtype=bool))
    plan = Plan(np.zeros((1, 2, 2)) + [[[0, 0], [1, 1]]], np.array([[0, -1]]))
    sol = make_solution(grid, "m.map", plan, plan.starts, plan.goals, "x", True, 0)
    with pytest.raises(NotConvertibleError, match="headings on every entry or on none"):
        format_solution(sol)


def test_make_solution_writes_mapf_ir_keys_and_failed_runs():
    grid = Grid(np.ones((2, 3), dtype=bool))
    plan = Plan.from_paths([[(0, 0), (1, 0)], [(2, 1)]])
    sol = make_solution(grid, "m.map", plan, plan.starts, plan.goals, "PIBT", True, 12,
                        lb_soc=1, lb_makespan=1, instance="i.txt")
    assert format_solution(sol) == (
        "instance=i.txt\nagents=2\nmap_file=m.map\nsolver=PIBT\nsolved=1\nsoc=1\nlb_soc=1\n"
        "makespan=1\nlb_makespan=1\ncomp_time=12\nstarts=(0,1),(2,0),\ngoals=(1,1),(2,0),\n"
        "solution=\n0:(0,1),(2,0),\n1:(1,1),(2,0),\n")
    failed = make_solution(grid, "m.map", None, plan.starts, plan.goals, "CBS", False, 30000)
    text = format_solution(failed)
    assert "solved=0\nsoc=0\nmakespan=-1\ncomp_time=30000\n" in text and text.endswith("solution=\n")
    assert parse_solution(text, grid=grid).plan is None


def test_large_solution_reads_back_exactly(tmp_path):
    rng = np.random.default_rng(1)
    grid = Grid(np.ones((481, 530), dtype=bool))
    positions = rng.integers(0, 481, size=(301, 1500, 2)).astype(np.int32)
    plan = Plan(positions)
    sol = make_solution(grid, "big.map", plan, plan.starts, plan.goals, "x", True, 0)
    back = parse_solution(format_solution(sol), grid=grid)
    assert back.plan == plan and back.starts == plan.starts


HEAD = "agents=2\nmap_file=p.map\nstarts=(3,1),(1,3),\ngoals=(4,1),(5,1),\nsolution=\n"
BAD = [
    # (text, line, column or None, message fragment)
    ("agents=2\nmap_file p.map\n", 2, 1, "expected a 'key=value' header line"),
    ("agents=2\nmap_file=p.map\n", 2, None, "missing 'starts=' line"),
    ("agents=2\nmap_file=p.map\nstarts=(3,1),(1,3),\nsolution=\n", 4, 1, "expected a 'goals=' line"),
    ("agents=2\nmap_file=p.map\nstarts=(3,1),(1,3),\ngoals=(4,1),(5,1),\n", 4, 1,
     "expected a 'solution=' line"),
    ("agents=2\nmap_file=p.map\nstarts=(3,1),(1,3),\ngoals=(4,1),(5,1),\nsolution=0\n", 5, 10,
     "expected nothing after 'solution='"),
    ("map_file=p.map\nstarts=(3,1),(1,3),\ngoals=(4,1),(5,1),\nsolution=\n", 2, None,
     "missing 'agents='"),
    ("agents=x\nmap_file=p.map\nstarts=(3,1),(1,3),\ngoals=(4,1),(5,1),\nsolution=\n", 1, None,
     "'agents=' must be an integer >= 0, got 'x'"),
    ("agents=2\nmap_file=p.map\nstarts=(3,1),\ngoals=(4,1),(5,1),\nsolution=\n", 3, 14,
     "1 entries, expected 2 (agents=2)"),
    ("agents=2\nmap_file=p.map\nstarts=(3,1),(1,3),\ngoals=(4,1),(5,1),(0,0),\nsolution=\n", 4, 19,
     "more than 2 entries"),
    ("agents=2\nmap_file=p.map\nstarts=(3,1),(1,3,X_PLUS),\ngoals=(4,1),(5,1),\nsolution=\n", 3, 14,
     "starts=/goals= entries carry no heading"),
    (HEAD + "0:(3,1),(1,a),\n", 6, 9, "expected an entry '(x,y),', got '(1,a),'"),
    (HEAD + "0:(3,1),(1,3)\n", 6, 9, "expected an entry '(x,y),'"),
    (HEAD + "0:(3,1),(1,3),\n1:(4,1),\n", 7, 9, "1 entries, expected 2 (agents=2)"),
    (HEAD + "0:(3,1),(1,3),\n1:(4,1),(0,3),(0,2),\n", 7, 15, "more than 2 entries"),
    (HEAD + "0:(3,1),(1,3),\n2:(4,1),(0,3),\n", 7, 1, "expected step 1, got 2"),
    (HEAD + "0:(3,1),(1,3),\n(4,1),(0,3),\n", 7, 1, "expected '1:'"),
    (HEAD + "0:(3,1),(1,3),\n1:(4,1,X_PLUS),(0,3,Y_PLUS),\n", 7, 3, "entry with a heading"),
    (HEAD + "0:(3,1,X_PLUS),(1,3,X_PLUS),\n1:(4,1,X_PLUS),(0,3),\n", 7, 16, "entry without a heading"),
    (HEAD + "0:(3,1),(1,12345678901),\n", 6, 9, "more than 9 digits"),
    ("agents=2\nmap_file=p.map\nsolved=yes\nstarts=(3,1),(1,3),\ngoals=(4,1),(5,1),\nsolution=\n",
     3, None, "'solved=' must be 0 or 1"),
    ("agents=2\nmap_file=p.map\niter=0,soc\nstarts=(3,1),(1,3),\ngoals=(4,1),(5,1),\nsolution=\n",
     3, 8, "expected 'key=value' after ','"),
    ("agents=2\nstarts=(3,1),(1,3),\ngoals=(4,1),(5,1),\nsolution=\n", 2, None, "missing 'map_file='"),
]


@pytest.mark.parametrize("text,line,column,fragment", BAD)
def test_malformed_solution_names_file_line_column_and_problem(tmp_path, text, line, column,
                                                                fragment):
    (tmp_path / "p.map").write_text(PARETO_MAP)
    path = tmp_path / "bad.txt"
    path.write_text(text)
    with pytest.raises(SolutionFormatError) as info:
        read_solution(path)
    err = info.value
    assert (err.path, err.line, err.column) == (str(path), line, column)
    assert fragment in err.message
    where = "{}:{}".format(path, line) + ("" if column is None else ":{}".format(column))
    assert str(err).startswith(where + ": ")


def test_missing_map_names_the_map_file_line(tmp_path):
    path = tmp_path / "s.txt"
    path.write_text(HEAD.replace("p.map", "gone.map"))
    with pytest.raises(MapNotFoundError) as info:
        read_solution(path)
    assert (info.value.path, info.value.line) == (str(path), 2)
    assert "map_file 'gone.map' not found; looked in: {}".format(tmp_path) in str(info.value)


def test_off_map_cells_are_left_to_the_validator():
    grid = Grid(np.ones((2, 2), dtype=bool))
    text = "agents=1\nmap_file=m.map\nstarts=(7,9),\ngoals=(0,0),\nsolution=\n0:(7,9),\n"
    sol = parse_solution(text, grid=grid)
    assert sol.starts == [(7, -8)] and format_solution(sol) == text


@st.composite
def solutions(draw):
    w, h = draw(st.integers(1, 7)), draw(st.integers(1, 7))
    n, steps = draw(st.integers(0, 5)), draw(st.integers(1, 6))
    xs = draw(st.lists(st.integers(0, w - 1), min_size=steps * n, max_size=steps * n))
    ys = draw(st.lists(st.integers(0, h - 1), min_size=steps * n, max_size=steps * n))
    positions = np.stack([np.array(xs), np.array(ys)], axis=-1).reshape(steps, n, 2)
    headings = None
    if n and draw(st.booleans()):  # with no agents a file cannot show headings
        headings = np.array(draw(st.lists(st.integers(0, 3), min_size=steps * n,
                                          max_size=steps * n))).reshape(steps, n)
    plan = Plan(positions, headings)
    failed = draw(st.booleans())
    return make_solution(Grid(np.ones((h, w), dtype=bool)), "g.map", None if failed else plan,
                         plan.starts, plan.goals, "S", not failed, draw(st.integers(0, 10 ** 6)),
                         extra=[("iter", "0,comp_time=1,soc=2,makespan=3")])


@given(sol=solutions(), orientation=st.sampled_from(["mapf-ir", "base"]))
def test_write_read_write_is_the_identity(sol, orientation):
    text = format_solution(sol, orientation)
    back = parse_solution(text, grid=sol.grid)
    assert (back.starts, back.goals, back.plan) == (sol.starts, sol.goals, sol.plan)
    assert back.iterations == [{"iter": 0, "comp_time": 1, "soc": 2, "makespan": 3}]
    assert format_solution(back) == text
    assert format_solution(back, "mapf-ir") == format_solution(sol, "mapf-ir")


def test_header_keeps_order_repeats_and_raw_values():
    text = ("instance= a.txt\nagents=1\nmap_file=m.map\niter=0,soc=1\niter=1,soc=1\nzz=?\n"
            "starts=(0,0),\ngoals=(0,0),\nsolution=\n")
    with pytest.warns(FormatWarning, match=r"<text>:6: warning: unknown key 'zz'"):
        sol = parse_solution(text, grid=Grid(np.ones((1, 1), dtype=bool)))
    h = sol.header
    assert list(h)[:2] == [("instance", " a.txt"), ("agents", "1")]
    assert h.get_all("iter") == ["0,soc=1", "1,soc=1"] and h.keys()[-2:] == ["iter", "zz"]
    assert h.line_of("zz") == 6
    other = h.copy()
    other.set("zz", "!")
    assert other != h and other.get("zz") == "!" and other.line_of("zz") == 6
    other.set("new", 5)
    assert other.keys()[-1] == "new" and other.get("new") == "5"
    with pytest.raises(ValueError, match="orientation must be None, 'mapf-ir' or 'base'"):
        format_solution(sol, orientation="top-left")
