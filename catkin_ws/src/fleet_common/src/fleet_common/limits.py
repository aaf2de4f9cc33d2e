"""Every limit on what FleetControl reads, in one place, and the total decoders that keep them.

Whatever arrives (a frame from a peer, a file from a user) becomes a value or
a `DecodeError` (ours, a `FleetError`), whatever its size, depth, digits or
bytes; never a RecursionError, OverflowError, MemoryError or a 4,300-digit
ValueError from deep inside the standard library. Each limit is checked
before the expensive work it protects: a frame's size and nesting before
`json` sees it, a number's length before `int()` or `float()` does, a file's
size before it is read.

Messages for people quote bad input through `excerpt` (short, escaped, one
line) and never whole; `one_line` is the last guard for a finished message.

Python 3.8, standard library only: the robots import this too.
"""
from __future__ import annotations

import json
import math
import re
import reprlib
from itertools import accumulate
from typing import Any, Dict, List, Tuple

from .errors import FleetError

__all__ = [
    "DecodeError", "MAX_FRAME_BYTES", "MAX_JSON_DEPTH", "MAX_NUMBER_CHARS", "MAX_WIRE_TEXT",
    "MAX_WIRE_LIST", "MAX_REQUEST_BYTES", "MAX_MANAGER_BYTES", "MAX_PLAN_TEXT", "MAX_FILE_BYTES", "MAX_LINE_CHARS", "MAX_INT_DIGITS", "MAX_CELL_DIGITS",
    "MAX_AGENTS", "MAX_GRID_SIDE", "MAX_GRID_CELLS", "MAX_PLAN_STEPS", "MAX_XML_BYTES", "MAX_XML_DEPTH", "MAX_YAML_BYTES", "MAX_DEFINITIONS_BYTES",
    "MAX_NAME_CHARS", "EXCERPT_CHARS", "MAX_MESSAGE_CHARS",
    "VICON_BLOCK_SIZES", "VICON_NAME_BYTES", "VICON_MAX_ABS_MM", "VICON_MAX_FRAME_GAP",
    "VICON_MAX_OBJECTS", "VICON_MAX_REMEMBERED_GAPS", "VICON_MAX_DATAGRAMS",
    "VICON_MAX_PAIRS_BYTES",
    "loads_frame", "json_depth", "parse_int", "parse_float", "excerpt", "one_line",
]

# ---- frames from peers (wire protocol, console channel) ---------------------------------
#: Largest frame a peer may send; libzmq drops a peer that sends more (ZMQ_MAXMSGSIZE).
MAX_FRAME_BYTES = 64 * 1024
#: Deepest nesting of JSON arrays and objects in a frame (the wire protocol uses 2).
MAX_JSON_DEPTH = 16
#: Longest number token, in characters (2**63 has 19 digits, a float's repr at most 24).
MAX_NUMBER_CHARS = 32
#: Longest text field of a wire message (reasons, epochs, fault names), in characters.
MAX_WIRE_TEXT = 1000
#: Most items in a list field of a wire message (faults).
MAX_WIRE_LIST = 32
#: Largest frame a manager reads from a console (a plan's text may be sent with `load`).
MAX_REQUEST_BYTES = 32 * 1024 * 1024
#: Largest frame a console reads from a manager (a scene carries a whole plan).
MAX_MANAGER_BYTES = 256 * 1024 * 1024
#: Largest plan or instance a console may have the manager load, sent as text or named in a
#: served folder (a 1,500-agent x 1,000-step solution is 13 MB).
MAX_PLAN_TEXT = 16 * 1024 * 1024

# ---- files from users ---------------------------------------------------------------------
#: Largest map, instance, solution or scen file (a 1,500-agent x 1,000-step solution is 13 MB).
MAX_FILE_BYTES = 256 * 1024 * 1024
#: Longest line of those files (a 10,000-agent solution row with headings is 180,000).
MAX_LINE_CHARS = 4 * 1024 * 1024
#: Most digits of an integer in a file (an int64 holds every such number).
MAX_INT_DIGITS = 18
#: Most digits of a cell coordinate in a file (keeps every coordinate inside int32).
MAX_CELL_DIGITS = 9
#: Most agents an instance or solution may declare.
MAX_AGENTS = 1000000
#: Largest grid built from coordinates (legacy node maps): cells a side, and cells in all.
MAX_GRID_SIDE = 65536
MAX_GRID_CELLS = 1 << 24
#: Most time steps of a plan built from durations (legacy plans).
MAX_PLAN_STEPS = 100000
#: Largest legacy XML file, and deepest element nesting in one.
MAX_XML_BYTES = 64 * 1024 * 1024
MAX_XML_DEPTH = 256
#: Largest YAML file (frames, node tables, settings).
MAX_YAML_BYTES = 1024 * 1024
#: Largest robot definitions file.
MAX_DEFINITIONS_BYTES = 1024 * 1024
#: Longest name in a file (a map_file=, a host, a Vicon name).
MAX_NAME_CHARS = 255

# ---- Vicon Tracker's UDP stream (fleet_common.vicon) ---------------------------------------
#: Tracker's block sizes; a datagram of any other length is refused ("size").
VICON_BLOCK_SIZES = (256, 512, 1024)
#: Bytes of an object's name (NUL-padded UTF-8); robot definitions' vicon_name keeps to it.
VICON_NAME_BYTES = 24
#: Largest believable coordinate: 1 km from the Vicon origin, in millimetres.
VICON_MAX_ABS_MM = 1.0e6
#: A FrameNumber jump larger than this (a minute at Tracker's 100 Hz) is a restart.
VICON_MAX_FRAME_GAP = 6000
#: Distinct object names kept; more are dropped ("too-many") so junk cannot fill memory.
VICON_MAX_OBJECTS = 1000
#: Lost frame numbers remembered, so that a late arrival is taken off the lost count.
VICON_MAX_REMEMBERED_GAPS = 4096
#: Datagrams the manager reads per wake-up at most, so one flood cannot stall its loop.
VICON_MAX_DATAGRAMS = 512
#: Largest calibration correspondences file (a line a measured point).
VICON_MAX_PAIRS_BYTES = 1024 * 1024

# ---- messages for people ------------------------------------------------------------------
#: Characters of a bad value quoted in a message.
EXCERPT_CHARS = 40
#: Longest one-line message the command line prints.
MAX_MESSAGE_CHARS = 299


class DecodeError(FleetError, ValueError):
    """Input a total decoder refused: not well formed, or beyond one of the limits here."""


# ---- JSON frames --------------------------------------------------------------------------

# A JSON string, or an unterminated one up to the end: removed before counting brackets.
# The closing quote is optional so that a bad string never makes the search start over.
_STRING = re.compile(rb'"(?:[^"\\]+|\\.)*"?', re.DOTALL)
_NOT_BRACKETS = bytes(b for b in range(256) if b not in b"[]{}")
_STEP = [0] * 256
_STEP[ord("[")] = _STEP[ord("{")] = 1
_STEP[ord("]")] = _STEP[ord("}")] = -1


def json_depth(data: bytes) -> int:
    """The deepest nesting of arrays and objects in JSON text `data` (brackets inside
    strings do not count). Linear time, no recursion, whatever `data` is."""
    brackets = _STRING.sub(b"", bytes(data)).translate(None, _NOT_BRACKETS)
    return max(accumulate(map(_STEP.__getitem__, brackets)), default=0)


def _number_token(text: str) -> None:
    if len(text) > MAX_NUMBER_CHARS:
        raise DecodeError("number of {:,} characters; at most {} are allowed".format(
            len(text), MAX_NUMBER_CHARS))


def _json_int(text: str) -> int:
    _number_token(text)
    return int(text)


def _json_float(text: str) -> float:
    _number_token(text)
    value = float(text)
    if not math.isfinite(value):
        raise DecodeError("number {} is out of range (beyond a double)".format(text))
    return value


def _json_constant(name: str) -> float:
    raise DecodeError("{} is not a number JSON allows".format(name))


def _json_object(pairs: List[Tuple[str, Any]]) -> Dict[str, Any]:
    out = dict(pairs)
    if len(out) != len(pairs):
        seen = set()
        for key, _ in pairs:
            if key in seen:
                raise DecodeError("key {} appears twice in one object".format(excerpt(key)))
            seen.add(key)
    return out


_DECODER = json.JSONDecoder(parse_int=_json_int, parse_float=_json_float,
                            parse_constant=_json_constant, object_pairs_hook=_json_object)


def loads_frame(data: bytes, *, max_bytes: int = MAX_FRAME_BYTES,
                max_depth: int = MAX_JSON_DEPTH) -> Any:
    """The JSON value in frame `data` (UTF-8); DecodeError if it is not one or breaks a
    limit: more than `max_bytes`, nesting deeper than `max_depth`, a number token longer
    than MAX_NUMBER_CHARS or beyond a double, NaN or Infinity, a key twice in an object."""
    if not isinstance(data, (bytes, bytearray, memoryview)):
        raise DecodeError("a frame is bytes, got {}".format(type(data).__name__))
    if len(data) > max_bytes:
        raise DecodeError("frame of {:,} bytes; the limit is {:,}".format(len(data), max_bytes))
    data = bytes(data)
    # counting openers is cheap and bounds the depth; scan only when it could be too deep
    if data.count(b"[") + data.count(b"{") > max_depth:
        depth = json_depth(data)
        if depth > max_depth:
            raise DecodeError("JSON nested {:,} deep; the limit is {}".format(depth, max_depth))
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as err:
        raise DecodeError("frame is not UTF-8 text (byte {} at offset {})".format(
            excerpt(data[err.start:err.start + 1]), err.start)) from None
    try:
        return _DECODER.decode(text)
    except DecodeError:
        raise
    except RecursionError:  # cannot happen after the depth check; never let it out
        raise DecodeError("JSON nested too deep") from None
    except ValueError as err:  # json.JSONDecodeError and int()/float() refusals
        raise DecodeError("frame is not JSON text: {}".format(one_line(str(err), 120))) from None


# ---- numbers in text ----------------------------------------------------------------------

_INT_TEXT = re.compile(r"[-+]?[0-9]+")


def parse_int(text: str, max_digits: int = MAX_INT_DIGITS) -> int:
    """`text` (an optional sign, then ASCII digits) as an int of at most `max_digits`
    digits; DecodeError saying which of the two it is not."""
    if _INT_TEXT.fullmatch(text) is None:
        raise DecodeError("expected an integer, got {}".format(excerpt(text)))
    digits = len(text) - (text[0] in "+-")
    if digits > max_digits:
        raise DecodeError("integer of {:,} digits; at most {} are allowed".format(
            digits, max_digits))
    return int(text)


def parse_float(text: str, max_chars: int = MAX_NUMBER_CHARS) -> float:
    """`text` as a finite float; DecodeError for anything else (NaN, inf, 1e999, words,
    more than `max_chars` characters). Surrounding spaces are allowed, as float() allows."""
    if len(text) > max_chars:
        raise DecodeError("number of {:,} characters; at most {} are allowed".format(
            len(text), max_chars))
    try:
        value = float(text)
    except ValueError:
        raise DecodeError("expected a number, got {}".format(excerpt(text))) from None
    if not math.isfinite(value):
        raise DecodeError("expected a finite number, got {}".format(excerpt(text)))
    return value


# ---- messages for people ------------------------------------------------------------------

_ESCAPES = {"\n": "\\n", "\r": "\\r", "\t": "\\t", "\\": "\\\\"}


def _escape_char(ch: str) -> str:
    if ch in _ESCAPES:
        return _ESCAPES[ch]
    code = ord(ch)
    if 0xDC80 <= code <= 0xDCFF:  # a byte that was not UTF-8 (surrogateescape)
        return "\\x{:02x}".format(code - 0xDC00)
    if ch.isprintable():
        return ch
    if code < 0x100:
        return "\\x{:02x}".format(code)
    return "\\u{:04x}".format(code) if code < 0x10000 else "\\U{:08x}".format(code)


def _escaped(text: str, limit: int, backslash: bool = True) -> Tuple[str, int]:
    """(escaped text of at most about `limit` characters, how many characters it covers);
    `backslash`: escape backslashes too (in quotations, so that escapes are unambiguous)."""
    out: List[str] = []
    size = used = 0
    for ch in text[:limit]:
        plain = ch.isprintable() and (ch != "\\" or not backslash)
        piece = ch if plain else _escape_char(ch)
        if size + len(piece) > limit:
            break
        out.append(piece)
        size += len(piece)
        used += 1
    return "".join(out), used


def excerpt(value: Any, limit: int = EXCERPT_CHARS) -> str:
    """A short, one-line quotation of `value` for a message: text in quotes with control
    characters and undecodable bytes escaped, cut after about `limit` characters with its
    full length said; numbers and other values by a bounded repr. Never fails."""
    if isinstance(value, (bytes, bytearray, memoryview)):
        value = bytes(value).decode("utf-8", "surrogateescape")
    if isinstance(value, str):
        shown, used = _escaped(value, limit)
        if used < len(value):
            return "'{}...' ({:,} characters)".format(shown, len(value))
        return "'{}'".format(shown)
    if isinstance(value, int) and not isinstance(value, bool) and value.bit_length() > 3 * limit:
        return "an integer of about {:,} digits".format(int(value.bit_length() * 0.30103) + 1)
    try:
        shown_repr = reprlib.Repr()
        shown_repr.maxstring = shown_repr.maxother = limit
        text = shown_repr.repr(value)
    except Exception:  # a value whose repr fails still gets a message
        text = "<{}>".format(type(value).__name__)
    shown, used = _escaped(text, limit)
    return shown if used == len(text) else shown + "..."


def one_line(text: str, limit: int = MAX_MESSAGE_CHARS) -> str:
    """`text` as one line of at most `limit` characters: control characters escaped
    (backslashes are left alone: quotations in it are escaped already), the middle cut out
    with " ... " if it is longer: a message says what failed first and what to do last (a
    long path in between must not push the advice off the line)."""
    shown, used = _escaped(text, limit, backslash=False)
    if used == len(text):
        return shown
    gap = " ... "
    if limit < 3 * len(gap):
        shown, _ = _escaped(text, max(limit - 3, 0), backslash=False)
        return shown + "..."
    pieces = [ch if ch.isprintable() else _escape_char(ch) for ch in text]
    tail_room = (limit - len(gap)) // 3
    tail: List[str] = []
    size = 0
    for piece in reversed(pieces):
        if size + len(piece) > tail_room:
            break
        tail.append(piece)
        size += len(piece)
    head, _ = _escaped(text[:len(pieces) - len(tail)], limit - len(gap) - size, backslash=False)
    return head + gap + "".join(reversed(tail))
