"""MovingAI `.scen` files: read, turned into instances on their map, bad lines named."""
from __future__ import annotations

import pytest

from fleet_common.errors import ScenFormatError
from fleet_common.formats.instance import format_instance, parse_instance
from fleet_common.formats.mapfile import parse_map
from fleet_common.formats.scen import parse_scen, read_scen, scen_to_instance

PARETO = parse_map("height 4\nwidth 6\nmap\nTTTT.T\n......\n.TT.T.\n..T...\n").grid


def line(sx, sy, gx, gy, w=6, h=4, bucket=0, length="2.00000000"):
    return "\t".join(str(v) for v in (bucket, "p.map", w, h, sx, sy, gx, gy, length))


SCEN = "version 1\n" + line(3, 1, 4, 1) + "\n" + line(1, 3, 5, 1, bucket=1, length="7") + "\n"


def test_scen_is_read_as_written():
    scen = parse_scen(SCEN)
    assert len(scen) == 2
    e = scen.entries[1]
    assert (e.bucket, e.map_name, e.width, e.height) == (1, "p.map", 6, 4)
    assert (e.start, e.goal, e.optimal_length, e.line) == ((1, 3), (5, 1), 7.0, 3)


def test_scen_becomes_the_instance_mapf_ir_would_read():
    inst = scen_to_instance(parse_scen(SCEN), PARETO, "p.map")
    # scen coordinates are top-left like mapf-IR's: the instance file shows the same numbers
    assert format_instance(inst).splitlines()[-2:] == ["3,1,4,1", "1,3,5,1"]
    assert inst.goals[0] == (4, 2)  # base frame
    again = parse_instance(format_instance(inst), grid=PARETO)
    assert (again.starts, again.goals, again.map_file) == (inst.starts, inst.goals, "p.map")


def test_first_n_entries_become_the_agents():
    inst = scen_to_instance(parse_scen(SCEN), PARETO, "p.map", agents=1)
    assert inst.num_agents == 1 and inst.starts == [(3, 2)]


def test_crlf_scen_and_trailing_blank_lines_are_fine():
    scen = parse_scen(SCEN.replace("\n", "\r\n") + "\r\n")
    assert [e.start for e in scen.entries] == [(3, 1), (1, 3)]


BAD = [
    # (text, line, column or None, message fragment)
    ("", 1, None, "expected 'version 1' on the first line, got an empty file"),
    (line(3, 1, 4, 1) + "\n", 1, None, "expected 'version 1' on the first line"),
    ("version 2\n" + line(3, 1, 4, 1) + "\n", 1, None, "got 'version 2'"),
    ("version 1\n" + line(3, 1, 4, 1) + "\t9\n", 2, 1, "expected 9 tab-separated fields"),
    ("version 1\n0 p.map 6 4 3 1 4 1 2.0\n", 2, 1, "(fields are separated by tabs)"),
    ("version 1\n" + line(3, 1, 4, 1) + "\n\n" + line(1, 3, 5, 1) + "\n", 3, 1, "got 1"),
    ("version 1\n" + line("x", 1, 4, 1) + "\n", 2, 13, "start x must be an integer of at most 9 digits, got 'x'"),
    ("version 1\n" + line(3, 1, 4, 1, length="far") + "\n", 2, 21, "optimal length must be a finite number"),
    ("version 1\n" + line(3, -1, 4, 1) + "\n", 2, 15, "start y must not be negative"),
]


@pytest.mark.parametrize("text,lineno,column,fragment", BAD)
def test_malformed_scen_names_file_line_and_problem(tmp_path, text, lineno, column, fragment):
    path = tmp_path / "bad.scen"
    path.write_text(text)
    with pytest.raises(ScenFormatError) as info:
        read_scen(path)
    err = info.value
    assert (err.path, err.line, err.column) == (str(path), lineno, column)
    assert fragment in err.message
    where = "{}:{}".format(path, lineno) + ("" if column is None else ":{}".format(column))
    assert str(err).startswith(where + ": ")


CONVERT_BAD = [
    (line(3, 1, 4, 1) + "\n" + line(1, 3, 5, 1, w=32, h=32), 3, 9,
     "the scen is for a 32x32 map, but the map is 6x4"),
    (line(3, 1, 4, 1) + "\n" + line(1, 3, 2, 3), 3, 17, "goal (2,3) is on a blocked cell"),
    (line(3, 1, 4, 1) + "\n" + line(7, 3, 5, 1), 3, 13, "start (7,3) is off the map"),
    (line(3, 1, 4, 1) + "\n" + line(1, 3, 4, 1), 3, 17, "goal (4,1) is also the goal on line 2"),
]


@pytest.mark.parametrize("body,lineno,column,fragment", CONVERT_BAD)
def test_scen_that_does_not_fit_the_map_is_refused_with_its_line(tmp_path, body, lineno, column,
                                                                 fragment):
    path = tmp_path / "p.scen"
    path.write_text("version 1\n" + body + "\n")
    with pytest.raises(ScenFormatError) as info:
        scen_to_instance(read_scen(path), PARETO, "p.map")
    err = info.value
    assert (err.path, err.line, err.column) == (str(path), lineno, column)
    assert fragment in err.message


def test_asking_for_more_agents_than_entries_is_refused(tmp_path):
    path = tmp_path / "p.scen"
    path.write_text(SCEN)
    with pytest.raises(ScenFormatError) as info:
        scen_to_instance(read_scen(path), PARETO, "p.map", agents=3)
    assert (info.value.path, info.value.line) == (str(path), 3)
    assert "asked for 3 agents; the scen has 2 entries" in str(info.value)
