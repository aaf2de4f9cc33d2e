"""The one message-schema mechanism of both protocols (fleet_common.schema): each refusal says
which field and what was expected, worded the same way for robot and console messages, and
our own declarations cannot drift from the dataclasses they build."""
from __future__ import annotations

import json
from dataclasses import dataclass
from typing import Tuple

import pytest

from fleet_common.control import ControlProtocolError, RunInfo, State
from fleet_common.control import decode as decode_console
from fleet_common.control import encode as encode_console
from fleet_common.control import messages as m
from fleet_common.schema import Int, ListOf, Obj, Record, SchemaError, Str
from fleet_common.wire import MalformedFrameError
from fleet_common.wire.codec import decode as decode_wire


@dataclass(frozen=True)
class Pair:
    name: str
    sizes: Tuple[int, ...]


PAIR = Record(Pair, {"name": Str(10), "sizes": ListOf(Int(0, 9), 4)})


def test_a_record_is_checked_into_its_dataclass() -> None:
    assert PAIR({"name": "a", "sizes": [1, 2]}, "") == Pair("a", (1, 2))
    assert PAIR.dump(Pair("a" * 20, (1, 2, 3, 4, 5))) == {"name": "a" * 10, "sizes": [1, 2, 3, 4]}


@pytest.mark.parametrize("value, path, problem", [
    ({"name": "a", "sizes": [1, 12]}, "sizes[1]", "must be a whole number from 0 to 9, got 12"),
    ({"name": "a"}, "", "lacks field 'sizes'"),
    ({"name": "a", "sizes": [], "colour": 1}, "", "has unknown field(s) 'colour'; known: name, sizes"),
    ({"name": 7, "sizes": []}, "name", "must be a string of at most 10 characters, got 7"),
    ([1], "", "must be an object with fields name, sizes, got [1]"),
])
def test_a_refusal_names_the_path_and_what_was_expected(value: object, path: str, problem: str) -> None:
    with pytest.raises(SchemaError) as err:
        PAIR(value, "")
    assert (err.value.path, err.value.problem) == (path, problem)
    where = "field {!r} of a pair message ".format(path) if path else "pair message "
    assert err.value.in_message("pair") == where + problem


def test_nested_paths_run_through_objects_and_lists() -> None:
    outer = Obj({"pairs": ListOf(PAIR)})
    with pytest.raises(SchemaError) as err:
        outer({"pairs": [{"name": "a", "sizes": []}, {"name": "b", "sizes": ["x"]}]}, "")
    assert str(err.value) == "pairs[1].sizes[0] must be a whole number from 0 to 9, got 'x'"


def test_a_declaration_out_of_step_with_its_dataclass_is_refused_at_once() -> None:
    with pytest.raises(TypeError, match="schema of Pair lists name, the dataclass name, sizes"):
        Record(Pair, {"name": Str()})


def test_both_protocols_word_a_bad_field_alike() -> None:
    with pytest.raises(MalformedFrameError) as robot:
        decode_wire(b'{"t":"turn","v":2,"id":1,"angle":"north"}')
    assert str(robot.value) == "field 'angle' of a turn message must be a finite number, got 'north'"
    run = RunInfo("running", "", "adg", 1, 3.5, 1.4, 1, 2, 0, None, 0, None)
    frame = json.loads(encode_console(State(7, 1, run, ())))
    frame["run"]["state"] = "flying"
    with pytest.raises(ControlProtocolError) as console:
        decode_console(json.dumps(frame).encode(), m.MANAGER_MESSAGES)
    assert str(console.value).startswith("field 'run.state' of a state message must be one of 'waiting', ")
    assert str(console.value).endswith(", got 'flying'")
    with pytest.raises(ControlProtocolError, match="^request message lacks field 'based_on'$"):
        decode_console(b'{"t":"request","v":1,"id":1,"action":"start","args":{}}', m.CONSOLE_MESSAGES)
