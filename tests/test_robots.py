"""robot_definitions.txt: the shipped fleet, the file format, and errors a lab person can fix."""
from __future__ import annotations

from pathlib import Path

import pytest
from hypothesis import given
from hypothesis import strategies as st

from fleet_common.errors import RobotDefinitionsError
from fleet_common.robots import (
    RobotDefinition,
    colour_to_rgb,
    default_definitions_path,
    format_robot_definitions,
    parse_robot_definitions,
    read_robot_definitions,
)

GOOD = "1 192.168.2.11 10001 turtlebot turtlebot1 red\n"


def test_shipped_fleet_is_the_five_lab_robots(repo_root: Path) -> None:
    robots = read_robot_definitions(repo_root / "robot_definitions.txt")
    assert [r.id for r in robots] == [1, 2, 3, 4, 5]
    assert [r.host for r in robots] == ["192.168.2.{}".format(11 + i) for i in range(5)]
    # Distinct ports, so the virtual fleet can run all five on 127.0.0.1.
    assert [r.command_port for r in robots] == [10001, 10002, 10003, 10004, 10005]
    assert {r.ssh_user for r in robots} == {"turtlebot"}
    assert [r.vicon_name for r in robots] == ["turtlebot{}".format(i) for i in range(1, 6)]
    assert [r.colour for r in robots] == ["red", "green", "blue", "orange", "magenta"]


def test_default_path_is_the_repository_file_unless_the_environment_says_otherwise(
    repo_root: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.delenv("FLEETCONTROL_ROBOTS", raising=False)
    assert default_definitions_path() == repo_root / "robot_definitions.txt"
    other = tmp_path / "fleet.txt"
    other.write_text("7 localhost 9000 me bot7 #0f0\n")
    monkeypatch.setenv("FLEETCONTROL_ROBOTS", str(other))
    assert default_definitions_path() == other
    assert read_robot_definitions()[0].id == 7


def test_comments_blank_lines_and_hex_colours() -> None:
    text = (
        "# the fleet\n"
        "\n"
        "1 192.168.2.11 10001 turtlebot tb1 #ff8800   # orange-ish, hex\n"
        "   2\tlab-bot-2.local 10002 turtlebot tb2 DarkOrange # named\n"
        "3 10.0.0.3 22 pi tb3 blue#not-a-comment\n"
    )
    with pytest.raises(RobotDefinitionsError) as err:
        parse_robot_definitions(text, "fleet.txt")
    assert (err.value.line, err.value.column) == (5, 22)
    assert "bad colour 'blue#not-a-comment'" in str(err.value)
    robots = parse_robot_definitions(text.rsplit("3 10", 1)[0])
    assert [(r.id, r.host, r.colour, r.line) for r in robots] == [
        (1, "192.168.2.11", "#ff8800", 3),
        (2, "lab-bot-2.local", "DarkOrange", 4),
    ]


def test_trailing_comment_token_does_not_count_as_a_field() -> None:
    robots = parse_robot_definitions("4 host4 10004 tb tb4 blue #comment here\n")
    assert robots[0].colour == "blue"


@pytest.mark.parametrize(
    "text, line, column, fragment",
    [
        ("1 192.168.2.11 10001 turtlebot turtlebot1\n", 1, None,
         "expected 6 fields (id host command_port ssh_user vicon_name colour), found 5"),
        ("# header\n" + GOOD.strip() + " extra\n", 2, 47, "expected 6 fields"),
        ("-1 192.168.2.11 10001 turtlebot tb1 red\n", 1, 1, "bad id '-1': expected a non-negative"),
        ("one 192.168.2.11 10001 turtlebot tb1 red\n", 1, 1, "bad id 'one'"),
        (GOOD + "\n1 192.168.2.12 10002 turtlebot tb2 red\n", 3, 1,
         "robot id 1 is already used by robot 1 on line 1"),
        ("1 256.1.1.1 10001 turtlebot tb1 red\n", 1, 3, "bad host '256.1.1.1': expected an IPv4"),
        ("1 192.168.2 10001 turtlebot tb1 red\n", 1, 3, "bad host '192.168.2'"),
        ("1 x192.168.2.11 10001 turtlebot tb1 red\n", 1, 3, "bad host 'x192.168.2.11'"),
        ("1 -robot.lab 10001 turtlebot tb1 red\n", 1, 3, "bad host '-robot.lab'"),
        ("1 robot_1 10001 turtlebot tb1 red\n", 1, 3, "bad host 'robot_1'"),
        ("1 192.168.2.11 0 turtlebot tb1 red\n", 1, 16, "bad command_port '0': expected a port"),
        ("1 192.168.2.11 65536 turtlebot tb1 red\n", 1, 16, "bad command_port '65536'"),
        (GOOD + "2 192.168.2.11 10001 turtlebot tb2 red\n", 2, 3,
         "address 192.168.2.11:10001 is already used by robot 1 on line 1"),
        ("1 192.168.2.11 10001 -root tb1 red\n", 1, 22, "bad ssh_user '-root'"),
        ("1 192.168.2.11 10001 tu@rtle tb1 red\n", 1, 22, "bad ssh_user 'tu@rtle'"),
        (GOOD + "2 192.168.2.12 10002 turtlebot turtlebot1 red\n", 2, 32,
         "Vicon name turtlebot1 is already used by robot 1 on line 1"),
        ("1 192.168.2.11 10001 turtlebot " + "t" * 25 + " red\n", 1, 32,
         "bad vicon_name '" + "t" * 25 + "': expected a name of at most 24 bytes"),
        ("1 192.168.2.11 10001 turtlebot tb1 reddish\n", 1, 36,
         "bad colour 'reddish': expected a Tk colour name"),
        ("1 192.168.2.11 10001 turtlebot tb1 #ffff\n", 1, 36, "bad colour '#ffff'"),
        ("1 192.168.2.11 10001 turtlebot tb1 #ggg\n", 1, 36, "bad colour '#ggg'"),
        ("# only comments\n\n", None, None, "no robot defined"),
    ],
)
def test_malformed_definitions_name_file_line_column(
    text: str, line: int, column: int, fragment: str
) -> None:
    with pytest.raises(RobotDefinitionsError) as err:
        parse_robot_definitions(text, "robot_definitions.txt")
    assert err.value.path == "robot_definitions.txt"
    assert (err.value.line, err.value.column) == (line, column)
    assert fragment in err.value.message
    assert str(err.value).startswith("robot_definitions.txt:")


def test_unreadable_file_is_reported_with_its_path(tmp_path: Path) -> None:
    missing = tmp_path / "nope.txt"
    with pytest.raises(RobotDefinitionsError) as err:
        read_robot_definitions(missing)
    assert err.value.path == str(missing)
    assert "cannot read" in str(err.value)


_names = st.from_regex(r"[a-z][a-z0-9]{0,7}", fullmatch=True)
_robot = st.builds(
    RobotDefinition,
    id=st.integers(0, 10**6),
    host=st.one_of(
        st.tuples(*[st.integers(0, 255)] * 4).map(lambda q: ".".join(map(str, q))),
        st.lists(_names, min_size=1, max_size=3).map(".".join).filter(lambda h: not h.isdigit()),
    ),
    command_port=st.integers(1, 65535),
    ssh_user=st.from_regex(r"[a-z_][a-z0-9_.-]{0,15}", fullmatch=True),
    vicon_name=_names,
    colour=st.sampled_from(["red", "SkyBlue", "gray50", "#abc", "#a1b2c3", "#123456789"]),
)


@given(st.lists(_robot, min_size=1, max_size=8, unique_by=(
    lambda r: r.id, lambda r: (r.host, r.command_port), lambda r: r.vicon_name)))
def test_format_then_parse_gives_the_same_fleet(robots: list) -> None:
    text = format_robot_definitions(robots)
    assert text.startswith("# id")
    assert parse_robot_definitions(text) == robots


@pytest.mark.parametrize(
    "colour, rgb",
    [
        ("red", (255, 0, 0)),
        ("DarkOrange", (255, 140, 0)),
        ("dark orange", (255, 140, 0)),
        ("gray50", (127, 127, 127)),
        ("#f80", (255, 136, 0)),
        ("#FF8800", (255, 136, 0)),
        ("#fff000888", (255, 0, 136)),
    ],
)
def test_colour_to_rgb_matches_tk(colour: str, rgb: tuple) -> None:
    # Values as Tk 8.6 reports them (`winfo rgb`, 16-bit, top byte kept).
    assert colour_to_rgb(colour) == rgb


def test_colour_to_rgb_rejects_unknown_colours() -> None:
    with pytest.raises(ValueError, match="unknown colour 'blurple'"):
        colour_to_rgb("blurple")


def test_the_size_line_gives_the_fleets_robot_size_and_a_file_without_one_a_turtlebot(tmp_path: Path) -> None:
    from fleet_common.robots import parse_robot_size, read_robot_size
    from fleet_common.robot_size import TURTLEBOT2

    line = "1 127.0.0.1 9001 u tb1 red\n"
    assert parse_robot_size(line) == TURTLEBOT2
    size = parse_robot_size("size diameter=0.7 margin=0\n" + line)
    assert size.cell_sized and parse_robot_definitions("size diameter=0.7 margin=0\n" + line)[0].id == 1
    small = parse_robot_size("# the lab's\nsize  diameter=0.2  margin=0.05  # small robots\n" + line)
    assert (small.diameter, small.margin, small.safe) == (0.2, 0.05, 0.25) and not small.cell_sized
    assert read_robot_size(None) == TURTLEBOT2  # the shipped file: a TurtleBot 2


@pytest.mark.parametrize("text, line, column, expected", [
    ("size diameter=0\n", 1, 6, "bad diameter '0': expected metres"),
    ("size margin=0.1\n", 1, None, "a size line needs diameter=METRES"),
    ("size diameter=0.3 width=2\n", 1, 19, "bad size term 'width=2'"),
    ("size diameter=0.3 diameter=0.4\n", 1, 19, "once each"),
    ("size diameter=nan\n", 1, 6, "bad diameter 'nan'"),
    ("1 127.0.0.1 9001 u tb1 red\nsize diameter=0.3\nsize diameter=0.4\n", 3, None, "a second size line"),
])
def test_a_bad_size_line_names_file_line_column(text: str, line: int, column, expected: str) -> None:
    from fleet_common.robots import parse_robot_size

    with pytest.raises(RobotDefinitionsError) as err:
        parse_robot_size(text, "fleet.txt")
        parse_robot_definitions(text, "fleet.txt")
    assert err.value.line == line and expected in str(err.value) and "fleet.txt" in str(err.value)
    if column is not None:
        assert err.value.column == column
