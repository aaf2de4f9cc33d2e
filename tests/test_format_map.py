"""`.map` files: every shipped map round-trips byte for byte, bad maps name line and column."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, strategies as st

from fleet_common.errors import MapFormatError
from fleet_common.formats.mapfile import (format_map, map_from_grid, parse_map, read_map,
                                          write_map)
from fleet_common.grid import Grid

SHARED = Path(__file__).resolve().parents[2] / "shared" / "data" / "mapf-ir"
SHIPPED_MAPS = sorted((SHARED / "maps").glob("*.map"))


def test_all_shipped_maps_are_found(shared_data):
    # guards the parametrised test below against silently running on nothing
    assert len(SHIPPED_MAPS) == len(list((shared_data / "maps").glob("*.map"))) >= 14


@pytest.mark.parametrize("path", SHIPPED_MAPS, ids=lambda p: p.name)
def test_shipped_map_round_trips_byte_for_byte(path, tmp_path):
    m = read_map(path)
    raw = path.read_bytes()
    assert format_map(m).encode() == raw
    write_map(m, tmp_path / path.name)
    assert (tmp_path / path.name).read_bytes() == raw
    assert m.grid.height == len(m.rows) and m.grid.width == len(m.rows[0])


def test_rows_are_top_to_bottom_and_the_grid_is_bottom_up(shared_data):
    m = read_map(shared_data / "maps" / "makespan-soc-pareto.map")
    # top row "TTTT.T": only x=4 free; it is base row height-1 = 3
    assert m.rows[0] == "TTTT.T"
    assert [m.grid.is_free((x, 3)) for x in range(6)] == [False] * 4 + [True, False]
    # bottom row "..T..." is base row 0
    assert [m.grid.is_free((x, 0)) for x in range(6)] == [True, True, False, True, True, True]
    assert m.grid.name == "makespan-soc-pareto.map"


def test_crlf_map_is_accepted_and_written_back_with_crlf():
    text = "type octile\r\nheight 2\r\nwidth 3\r\nmap\r\n.@.\r\n..T\r\n"
    m = parse_map(text)
    assert m.newline == "\r\n" and m.rows == [".@.", "..T"]
    assert m.grid.is_free((0, 1)) and not m.grid.is_free((1, 1)) and not m.grid.is_free((2, 0))
    assert format_map(m) == text


def test_a_map_mixing_lf_and_crlf_line_endings_is_read_as_mapf_ir_reads_it(tmp_path):
    # an editor or a copy across systems leaves some lines with CRLF and some with LF
    path = tmp_path / "mixed.map"
    path.write_bytes(b"type octile\nheight 3\r\nwidth 3\nmap\r\n.@.\n..T\r\n...\n")
    m = read_map(path)
    assert m.rows == [".@.", "..T", "..."] and m.grid == Grid.from_rows([".@.", "..T", "..."])
    assert m.newline == "\n" and format_map(m) == "type octile\nheight 3\nwidth 3\nmap\n.@.\n..T\n...\n"


def test_missing_final_newline_is_kept():
    text = "height 1\nwidth 2\nmap\n.@"
    m = parse_map(text)
    assert not m.final_newline and format_map(m) == text


def test_mapf_ir_rule_frees_water_and_out_of_bounds_but_strict_movingai_blocks_them():
    text = "height 1\nwidth 5\nmap\n.WOT@\n"
    loose = parse_map(text).grid
    strict = parse_map(text, strict=True).grid
    assert [loose.is_free((x, 0)) for x in range(5)] == [True, True, True, False, False]
    assert [strict.is_free((x, 0)) for x in range(5)] == [True, False, False, False, False]


def test_map_from_grid_writes_a_fresh_mapf_ir_map(tmp_path):
    free = np.array([[True, False, True], [True, True, True]])  # row 0 = bottom
    m = map_from_grid(Grid(free))
    assert format_map(m) == "type octile\nheight 2\nwidth 3\nmap\n...\n.@.\n"
    write_map(m, tmp_path / "g.map")
    assert read_map(tmp_path / "g.map").grid == Grid(free)


BAD_MAPS = [
    # (text, line, column or None, message fragment)
    ("", 1, None, "empty file"),
    ("width 3\nmap\n...\n", 2, None, "'height N' missing"),
    ("height 1\nmap\n...\n", 2, None, "'width N' missing"),
    ("height x\nwidth 3\nmap\n...\n", 1, None, "expected 'height N'"),
    ("height 1\nwidth 3.5\nmap\n...\n", 2, None, "expected 'width N'"),
    ("height 0\nwidth 3\nmap\n", 1, None, "positive integer"),
    ("height 1\nheight 1\nwidth 3\nmap\n...\n", 2, None, "given twice (first on line 1)"),
    ("height 1\nwidth 3\n...\n", 3, None, "'map' line missing"),
    ("height 2\nwidth 3\nmap\n...\n..\n", 5, 3, "row too short: 2 cells, expected 3"),
    ("height 2\nwidth 3\nmap\n....\n...\n", 4, 4, "row too long: 4 cells"),
    ("height 3\nwidth 3\nmap\n...\n...\n", 5, None, "too few rows: 2"),
    ("height 1\nwidth 3\nmap\n...\n...\n", 5, None, "too many rows"),
    ("height 1\nwidth 3\nmap\n.\t.\n", 4, 2, "a tab"),
    ("height 1\nwidth 3\nmap\n..\x07\n", 4, 3, "control character"),
    ("height 1\nwidth 3\nmap\n.\u00e9.\n", 4, 2, "non-ASCII character"),
    ("height 1\nwidth 3\nmap\n.\r.\n", 4, 2, "carriage return"),
]


@pytest.mark.parametrize("text,line,column,fragment", BAD_MAPS)
def test_malformed_map_names_file_line_and_problem(tmp_path, text, line, column, fragment):
    path = tmp_path / "bad.map"
    path.write_bytes(text.encode("utf-8"))
    with pytest.raises(MapFormatError) as info:
        read_map(path)
    err = info.value
    assert err.path == str(path) and err.line == line and err.column == column
    assert fragment in err.message
    where = "{}:{}".format(path, line) + ("" if column is None else ":{}".format(column))
    assert str(err).startswith(where + ": ")


rows_strategy = st.integers(1, 6).flatmap(
    lambda w: st.lists(st.text(alphabet=".@TWOSG ", min_size=w, max_size=w), min_size=1,
                       max_size=6))


@given(rows=rows_strategy, crlf=st.booleans(), final=st.booleans(),
       extra=st.lists(st.sampled_from(["type octile", "name x", "# note"]), max_size=2))
def test_any_map_text_round_trips_and_matches_its_rows(rows, crlf, final, extra):
    nl = "\r\n" if crlf else "\n"
    lines = extra + ["height {}".format(len(rows)), "width {}".format(len(rows[0])), "map"] + rows
    text = nl.join(lines) + (nl if final else "")
    m = parse_map(text)
    assert format_map(m) == text
    assert m.grid == Grid.from_rows(rows)
    again = parse_map(format_map(map_from_grid(m.grid)))
    assert again.grid == m.grid
