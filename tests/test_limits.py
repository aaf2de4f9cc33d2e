"""The input limits and total decoders of fleet_common.limits: any input gives a value or our
DecodeError, the limits hold, and quotations of bad input stay short and on one line."""
from __future__ import annotations

import json
import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

from fleet_common.errors import FleetError
from fleet_common.limits import (EXCERPT_CHARS, MAX_FRAME_BYTES, MAX_JSON_DEPTH, MAX_NUMBER_CHARS,
                                 DecodeError, excerpt, json_depth, loads_frame, one_line,
                                 parse_float, parse_int)

json_scalars = (st.none() | st.booleans() | st.integers(-2 ** 63, 2 ** 63)
                | st.floats(allow_nan=False, allow_infinity=False) | st.text(max_size=20))
json_values = st.recursive(
    json_scalars, lambda inner: st.lists(inner, max_size=4)
    | st.dictionaries(st.text(max_size=8), inner, max_size=4), max_leaves=20)


def depth_of(value: object) -> int:
    if isinstance(value, list):
        return 1 + max((depth_of(v) for v in value), default=0)
    if isinstance(value, dict):
        return 1 + max((depth_of(v) for v in value.values()), default=0)
    return 0


def no_control_characters(text: str) -> bool:
    return all(ch.isprintable() for ch in text)


@given(st.binary(max_size=400))
def test_any_bytes_give_a_value_or_a_decode_error(data: bytes) -> None:
    try:
        loads_frame(data)
    except DecodeError:
        pass


@given(json_values, st.data())
def test_mutated_json_gives_a_value_or_a_decode_error(value: object, data: st.DataObject) -> None:
    raw = bytearray(json.dumps(value).encode("utf-8"))
    for _ in range(data.draw(st.integers(1, 4))):
        at = data.draw(st.integers(0, len(raw)))
        piece = data.draw(st.sampled_from([b"[", b"]", b"{", b"\"", b"\\", b"9" * 50, b"1e999",
                                           b"NaN", b"-", b"\xff", b",", b":", b"[" * 40]))
        raw[at:at + data.draw(st.integers(0, 2))] = piece
    try:
        loads_frame(bytes(raw))
    except DecodeError:
        pass


@given(json_values)
def test_json_within_the_limits_round_trips(value: object) -> None:
    assert loads_frame(json.dumps(value).encode("utf-8")) == value


@given(json_values)
def test_json_depth_is_the_nesting_depth_whatever_the_strings_hold(value: object) -> None:
    assert json_depth(json.dumps(value).encode("utf-8")) == depth_of(value)


@given(st.integers(0, 3 * MAX_JSON_DEPTH), st.sampled_from(["[", "{\"k\":"]))
def test_nesting_beyond_the_limit_is_refused_and_within_it_accepted(depth: int, opener: str) -> None:
    closer = "]" if opener == "[" else "}"
    frame = (opener * depth + "1" + closer * depth).encode()
    if depth <= MAX_JSON_DEPTH:
        assert depth_of(loads_frame(frame)) == depth
    else:
        with pytest.raises(DecodeError, match="nested {} deep".format(depth)):
            loads_frame(frame)


def test_the_frames_that_killed_the_virtual_fleet_are_refused() -> None:
    big_x = b'{"t":"drive","v":2,"id":1,"x":' + b"1" * 400 + b',"y":0,"time":0}'
    with pytest.raises(DecodeError, match="400 characters"):
        loads_frame(big_x)
    with pytest.raises(DecodeError, match="nested 30,000 deep"):
        loads_frame(b"[" * 30000)
    for bad in (b"[1e400]", b"[-1e400]", b"[NaN]", b"[Infinity]", b"[-Infinity]"):
        with pytest.raises(DecodeError):
            loads_frame(bad)


def test_size_and_duplicate_keys_are_refused_with_the_reason() -> None:
    with pytest.raises(DecodeError, match="65,537 bytes"):
        loads_frame(b" " * (MAX_FRAME_BYTES + 1))
    with pytest.raises(DecodeError, match="'x' appears twice"):
        loads_frame(b'{"x":1,"x":2}')
    with pytest.raises(DecodeError, match="not UTF-8"):
        loads_frame(b'"\xff"')
    assert issubclass(DecodeError, FleetError)


@given(st.text(max_size=60))
def test_parse_int_and_parse_float_give_a_value_or_a_decode_error(text: str) -> None:
    for parse in (parse_int, parse_float):
        try:
            value = parse(text)
        except DecodeError as err:
            assert no_control_characters(str(err)) and len(str(err)) < 200
        else:
            assert math.isfinite(value)


@given(st.integers(-10 ** 18 + 1, 10 ** 18 - 1))
def test_parse_int_reads_every_integer_of_up_to_18_digits(number: int) -> None:
    assert parse_int(str(number)) == number


def test_parse_int_refuses_more_digits_without_reading_them() -> None:
    with pytest.raises(DecodeError, match="5,000 digits"):
        parse_int("7" * 5000)
    with pytest.raises(DecodeError, match="expected a finite number"):
        parse_float("1e999")
    with pytest.raises(DecodeError, match="at most {}".format(MAX_NUMBER_CHARS)):
        parse_float("1" * 400)


@given(st.one_of(st.text(), st.binary(), st.integers(), st.floats(), json_values,
                 st.lists(st.text(min_size=100), max_size=3)))
def test_an_excerpt_is_short_and_on_one_line(value: object) -> None:
    shown = excerpt(value)
    assert no_control_characters(shown)
    assert len(shown) <= EXCERPT_CHARS + 40


def test_an_excerpt_says_how_long_the_value_was() -> None:
    assert excerpt("x" * 3_000_000).endswith("...' (3,000,000 characters)")
    assert excerpt("12\r34") == "'12\\r34'"
    assert excerpt(b"a\xffb") == "'a\\xffb'"
    assert excerpt(10 ** 5000) == "an integer of about 5,001 digits"


@given(st.text(max_size=1000), st.integers(10, 400))
def test_one_line_is_one_line_within_the_limit(text: str, limit: int) -> None:
    line = one_line(text, limit)
    assert no_control_characters(line) and len(line) <= limit
    if len(text) <= limit and no_control_characters(text):
        assert line == text


def test_a_long_message_keeps_its_beginning_and_its_advice():
    """A long path in the middle of a message is what gets cut, not what to do about it."""
    path = "/tmp/" + "deep/" * 80 + "nokeys"
    message = "{}/robot.key_secret not found: make the keys with `fleetctl keys --dir {}`; " \
              "or run the fleet with --no-curve".format(path, path)
    line = one_line(message, 120)
    assert len(line) <= 120 and " ... " in line
    assert line.startswith("/tmp/deep/") and line.endswith("or run the fleet with --no-curve")
