"""mapf-IR instance files: shipped files round-trip, y flips, nothing is skipped silently."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, strategies as st

from fleet_common.errors import FormatWarning, InstanceFormatError, MapNotFoundError
from fleet_common.formats.instance import (format_instance, make_instance, parse_instance,
                                           read_instance, write_instance)
from fleet_common.grid import Grid

SHARED = Path(__file__).resolve().parents[2] / "shared" / "data" / "mapf-ir"
SHIPPED = sorted((SHARED / "instances").glob("*.txt"))
PARETO_MAP = "height 4\nwidth 6\nmap\nTTTT.T\n......\n.TT.T.\n..T...\n"


def test_all_shipped_instances_are_found(shared_data):
    assert len(SHIPPED) == len(list((shared_data / "instances").glob("*.txt"))) >= 11


@pytest.mark.parametrize("path", SHIPPED, ids=lambda p: p.name)
def test_shipped_instance_round_trips_byte_for_byte(path, shared_data, tmp_path):
    inst = read_instance(path, map_dirs=[shared_data / "maps"])
    raw = path.read_bytes()
    assert format_instance(inst).encode() == raw
    assert format_instance(inst, orientation="mapf-ir").encode() == raw
    write_instance(inst, tmp_path / path.name)
    assert (tmp_path / path.name).read_bytes() == raw
    # through the base frame and back: same cells, same bytes
    base = parse_instance(format_instance(inst, "base"), grid=inst.grid)
    assert base.orientation == "base" and "orientation=base" in format_instance(inst, "base")
    assert (base.starts, base.goals) == (inst.starts, inst.goals)
    assert format_instance(base, "mapf-ir").encode() == raw
    assert len(inst.starts) == (0 if inst.is_random else inst.num_agents)


def test_orientation_flip_of_a_known_cell(shared_data):
    inst = read_instance(shared_data / "instances" / "makespan-soc-pareto.txt",
                         map_dirs=[shared_data / "maps"])
    # file line "3,1,4,1": goal (4,1) in mapf-IR's frame is base (4,2) on a 4-high map
    assert inst.goals[0] == (4, 2) and inst.starts[0] == (3, 2)
    assert inst.starts[1] == (1, 0)  # "1,3,...": file row 3 is the bottom row
    assert format_instance(inst, "base").splitlines()[-2:] == ["3,2,4,2", "1,0,5,2"]


def test_sample_random_problem_is_readable_with_header_values(shared_data):
    inst = read_instance(shared_data / "instances" / "sample.txt", map_dirs=[shared_data / "maps"])
    assert inst.is_random and inst.random_problem and inst.starts == [] and inst.goals == []
    assert (inst.num_agents, inst.seed, inst.max_timestep, inst.max_comp_time) == (100, 1, 1000, 5000)
    assert inst.well_formed is False and inst.map_file == "arena.map"


def test_map_is_found_beside_the_instance_and_unknown_keys_and_comments_are_kept(tmp_path):
    (tmp_path / "p.map").write_text(PARETO_MAP)
    text = "# made by hand\nmap_file=p.map\nagents=1\nnote=kept\n\n3,1,4,1\n"
    (tmp_path / "i.txt").write_text(text)
    with pytest.warns(FormatWarning, match=r"i.txt:4: warning: unknown key 'note'"):
        inst = read_instance(tmp_path / "i.txt")
    assert inst.header.get("note") == "kept" and inst.header.line_of("note") == 4
    assert format_instance(inst) == text


def test_crlf_instance_is_accepted_and_kept(tmp_path):
    text = "map_file=p.map\r\nagents=1\r\n3,1,4,1\r\n"
    inst = parse_instance(text, grid=Grid.from_rows(PARETO_MAP.split("\n")[3:7]))
    assert inst.goals == [(4, 2)] and format_instance(inst) == text


def test_make_instance_uses_mapf_ir_layout():
    grid = Grid(np.ones((3, 3), dtype=bool))
    inst = make_instance(grid, "g.map", [(0, 0)], [(2, 2)], seed=7)
    assert format_instance(inst) == (
        "map_file=g.map\nagents=1\nseed=7\nrandom_problem=0\nmax_timestep=5000\n"
        "max_comp_time=60000\n0,2,2,0\n")
    with pytest.raises(ValueError, match="share a start"):
        make_instance(grid, "g.map", [(0, 0), (0, 0)], [(1, 1), (2, 2)])


HEAD = "map_file=p.map\nagents=2\n"
BAD = [
    # (text, line, column or None, message fragment)
    ("agents=1\n", 1, None, "missing 'map_file='"),
    ("map_file=p.map\n", 1, None, "missing 'agents='"),
    ("agents=1\n3,1,4,1\n", 2, None, "agent line before 'map_file='"),
    ("map_file=p.map\n3,1,4,1\n", 2, None, "agent line before 'agents='"),
    ("map_file=p.map\nagents=-1\n", 2, None, "'agents=' must be an integer >= 1, got '-1'"),
    ("map_file=p.map\nagents=two\n", 2, None, "'agents=' must be an integer >= 1, got 'two'"),
    ("map_file=p.map\nagents=0\n", 2, None, "'agents=' must be an integer >= 1"),
    ("map_file=\nagents=1\n3,1,4,1\n", 1, None, "'map_file=' is empty"),
    (HEAD + "3,1,4,1\n12, 7,16,18\n", 4, 4, "expected a digit for sy, got ' '"),
    (HEAD + "3,1,4,1\n1,2,3\n", 4, 6, "expected ',' after gx, got the end of the line"),
    (HEAD + "3,1,4,1\n1,2,3,4,5\n", 4, 8, "unexpected ',' after gy"),
    (HEAD + "3,1,4,1\n-1,2,3,4\n", 4, 1, "expected a digit for sx, got '-'"),
    (HEAD + "3,1,4,1\n", 2, None, "agents=2 but 1 agent line(s)"),
    (HEAD + "3,1,4,1\n1,3,5,1\n0,1,0,2\n", 5, None, "more agent lines than agents=2"),
    (HEAD + "3,1,4,1\n9,3,5,1\n", 4, 1, "start (9,3) of agent 1 is off the map (6 wide, 4 high)"),
    (HEAD + "3,1,4,1\n1,3,2,3\n", 4, 5, "goal (2,3) of agent 1 is on a blocked cell"),
    (HEAD + "3,1,4,1\n3,1,5,1\n", 4, 1, "agent 1 starts at (3,1), where agent 0 starts too (line 3)"),
    (HEAD + "3,1,4,1\n1,3,4,1\n", 4, 5, "agent 1 ends at (4,1), where agent 0 ends too"),
    (HEAD + "3,1,4,1\nhello world\n", 4, 1, "expected a comment ('# ...'), a 'key=value' line"),
    (HEAD + "agents=2\n", 3, None, "'agents=' given twice (first on line 2)"),
    (HEAD + "random_problem=1\n3,1,4,1\n1,3,5,1\n", 4, None, "agent line with random_problem=1"),
    ("map_file=p.map\n3,1,4,1\nagents=1\n", 2, None, "agent line before 'agents='"),
    (HEAD + "3,1,4,1\n1,3,5,1\nrandom_problem=1\n", 5, None, "'random_problem=' after the agent"),
    (HEAD + "seed=abc\n", 3, None, "'seed=' must be an integer >= 0"),
    (HEAD + "well_formed=yes\n", 3, None, "'well_formed=' must be 0 or 1"),
    (HEAD + "orientation=sideways\n3,1,4,1\n1,3,5,1\n", 3, None, "'base' or 'mapf-ir'"),
]


@pytest.mark.parametrize("text,line,column,fragment", BAD)
def test_malformed_instance_names_file_line_and_problem(tmp_path, text, line, column, fragment):
    (tmp_path / "p.map").write_text(PARETO_MAP)
    path = tmp_path / "bad.txt"
    path.write_text(text)
    with pytest.raises(InstanceFormatError) as info:
        read_instance(path)
    err = info.value
    assert (err.path, err.line, err.column) == (str(path), line, column)
    assert fragment in err.message
    where = "{}:{}".format(path, line) + ("" if column is None else ":{}".format(column))
    assert str(err).startswith(where + ": ")


def test_missing_map_names_the_map_file_line_and_the_folders(tmp_path):
    path = tmp_path / "i.txt"
    path.write_text("# x\nmap_file=nowhere.map\nagents=1\n0,0,1,1\n")
    elsewhere = tmp_path / "maps"
    with pytest.raises(MapNotFoundError) as info:
        read_instance(path, map_dirs=[elsewhere])
    err = info.value
    assert (err.path, err.line) == (str(path), 2)
    assert "map_file 'nowhere.map' not found; looked in: {}, {}".format(tmp_path, elsewhere) in str(err)


@st.composite
def instances(draw):
    w, h = draw(st.integers(1, 6)), draw(st.integers(1, 6))
    free = np.array(draw(st.lists(st.booleans(), min_size=w * h, max_size=w * h))).reshape(h, w)
    free[0, 0] = True
    cells = [(int(x), int(y)) for y, x in zip(*np.nonzero(free))]
    n = draw(st.integers(1, len(cells)))
    starts = draw(st.permutations(cells))[:n]
    goals = draw(st.permutations(cells))[:n]
    return make_instance(Grid(free), "g.map", starts, goals, seed=draw(st.integers(0, 99)))


@given(inst=instances(), orientation=st.sampled_from(["mapf-ir", "base"]), crlf=st.booleans())
def test_write_read_write_is_the_identity(inst, orientation, crlf):
    inst.newline = "\r\n" if crlf else "\n"
    text = format_instance(inst, orientation)
    back = parse_instance(text, grid=inst.grid)
    assert (back.starts, back.goals) == (inst.starts, inst.goals)
    assert back.orientation == orientation and back.num_agents == len(inst.starts)
    assert format_instance(back) == text
    assert format_instance(back, "mapf-ir") == format_instance(inst, "mapf-ir")
