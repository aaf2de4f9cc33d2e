"""A part of the fleet by ids and ranges (`--robots 1-150,300`): read, taken from the file, said back."""
from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st

from fleet_common.errors import RobotDefinitionsError
from fleet_common.robot_ids import describe_ids, parse_robot_ids, select_robots
from fleet_common.robots import parse_robot_definitions

FLEET = parse_robot_definitions("".join("{} 10.0.0.{} 10001 u tb{} red\n".format(i, i, i)
                                        for i in (1, 2, 3, 5, 8, 9, 10)))


def test_ids_and_ranges_pick_robots_in_file_order() -> None:
    assert parse_robot_ids("8-10, 1,3") == [(8, 10), (1, 1), (3, 3)]
    assert [r.id for r in select_robots(FLEET, parse_robot_ids("8-10,1,3"))] == [1, 3, 8, 9, 10]
    assert [r.id for r in select_robots(FLEET, parse_robot_ids("4-7"))] == [5]  # a range needs one robot


@pytest.mark.parametrize("text, message", [
    ("", "expected robot ids and ranges separated by commas, e.g. 1-150,300, got ''"),
    ("1-", "got '1-' in '1-'"),
    ("1,,2", "got '' in '1,,2'"),
    ("a-3", "got 'a-3'"),
    ("-3", "got '-3'"),
    ("5-2", "range '5-2' runs backwards"),
    ("1" * 30, "got '" + "1" * 30),
    ("1," * 6000, "got 12000 characters (at most 10000)"),
])
def test_a_bad_list_says_what_was_expected(text: str, message: str) -> None:
    with pytest.raises(ValueError) as err:
        parse_robot_ids(text)
    assert message in str(err.value) and "\n" not in str(err.value)


@pytest.mark.parametrize("text, message", [
    ("4", "robot 4 is not defined (this file defines 1-3,5,8-10)"),
    ("1,11-20", "no robot of 11-20 is defined (this file defines 1-3,5,8-10)"),
])
def test_robots_the_file_does_not_define_are_named(text: str, message: str) -> None:
    with pytest.raises(RobotDefinitionsError) as err:
        select_robots(FLEET, parse_robot_ids(text), "robots.txt")
    assert str(err.value) == "robots.txt: " + message


@given(st.sets(st.integers(0, 400), min_size=1))
def test_described_ids_read_back_as_the_same_robots(ids) -> None:
    text = describe_ids(sorted(ids))
    back = {i for first, last in parse_robot_ids(text) for i in range(first, last + 1)}
    assert back == ids
    assert len(text.split(",")) == sum(1 for i in ids if i - 1 not in ids)  # one part per run of ids
