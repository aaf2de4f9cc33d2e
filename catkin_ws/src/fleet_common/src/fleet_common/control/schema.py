"""Checking decoded JSON against a schema: any value in, a checked value or our error out.

The console channel's messages nest (a state holds a list of robots, each with
a pose, waits, an action), so instead of one hand-written check per field
there are small checkers that compose: `Int`, `Num`, `Str`, `Bool`, `Opt`,
`ListOf`, `Cell`, `Obj`. Each takes the decoded value and the path to it
(for the message: `robots[3].waiting.on[0]`) and returns the value as the
program wants it, or raises `SchemaError` saying what was expected. Nothing
else can come out of them, whatever the input: that is what makes the
decoders built on them total.
"""
from __future__ import annotations

import base64
import binascii
import math
from typing import Any, Dict, Optional, Sequence, Tuple

import numpy as np

from ..errors import FleetError

__all__ = ["SchemaError", "Checker", "Int", "Num", "Str", "Bool", "Opt", "ListOf", "Cell", "Obj",
           "OneOf", "AnyObj", "Positions", "short"]


class SchemaError(FleetError, ValueError):
    """A decoded value that does not have the expected shape."""


def short(value: Any, limit: int = 40) -> str:
    """A short, printable excerpt of `value` for an error message (never megabytes)."""
    text = repr(value) if not isinstance(value, str) else repr(value[:limit + 1])
    text = "".join(c if c.isprintable() else "?" for c in text)
    return text if len(text) <= limit else text[:limit - 3] + "..."


class Checker:
    what = "a value"

    def __call__(self, value: Any, path: str) -> Any:
        raise NotImplementedError

    def fail(self, value: Any, path: str) -> SchemaError:
        return SchemaError("{} must be {}, got {}".format(path, self.what, short(value)))


class Int(Checker):
    def __init__(self, low: int = 0, high: int = 2 ** 53) -> None:
        self.low, self.high = low, high
        self.what = "a whole number from {} to {}".format(low, high)

    def __call__(self, value: Any, path: str) -> int:
        if isinstance(value, int) and not isinstance(value, bool) and self.low <= value <= self.high:
            return value
        raise self.fail(value, path)


class Num(Checker):
    def __init__(self, low: float = -1e9, high: float = 1e9) -> None:
        self.low, self.high = low, high
        self.what = "a finite number from {:g} to {:g}".format(low, high)

    def __call__(self, value: Any, path: str) -> float:
        if isinstance(value, (int, float)) and not isinstance(value, bool):
            try:
                f = float(value)
            except OverflowError:  # an int too large for a float
                raise self.fail(value, path) from None
            if math.isfinite(f) and self.low <= f <= self.high:
                return f
        raise self.fail(value, path)


class Str(Checker):
    def __init__(self, max_len: int = 200, choices: Optional[Sequence[str]] = None) -> None:
        self.max_len = max_len
        self.choices = tuple(choices) if choices is not None else None
        self.what = ("one of " + ", ".join(repr(c) for c in self.choices) if self.choices
                     else "a string of at most {} characters".format(max_len))

    def __call__(self, value: Any, path: str) -> str:
        if isinstance(value, str) and len(value) <= self.max_len and (
                self.choices is None or value in self.choices):
            return value
        raise self.fail(value, path)


class Bool(Checker):
    what = "true or false"

    def __call__(self, value: Any, path: str) -> bool:
        if isinstance(value, bool):
            return value
        raise self.fail(value, path)


class Opt(Checker):
    def __init__(self, inner: Checker) -> None:
        self.inner = inner
        self.what = inner.what + " or null"

    def __call__(self, value: Any, path: str) -> Any:
        return None if value is None else self.inner(value, path)


class ListOf(Checker):
    def __init__(self, inner: Checker, max_len: int = 10000, tuple_out: bool = True) -> None:
        self.inner, self.max_len, self.tuple_out = inner, max_len, tuple_out
        self.what = "a list of at most {} items".format(max_len)

    def __call__(self, value: Any, path: str) -> Any:
        if not isinstance(value, list) or len(value) > self.max_len:
            raise self.fail(value, path)
        items = [self.inner(v, "{}[{}]".format(path, i)) for i, v in enumerate(value)]
        return tuple(items) if self.tuple_out else items


class Cell(Checker):
    """A base-grid cell [x, y] of whole numbers."""

    what = "a cell [x, y] of whole numbers"

    def __call__(self, value: Any, path: str) -> Tuple[int, int]:
        if (isinstance(value, list) and len(value) == 2
                and all(isinstance(v, int) and not isinstance(v, bool) and -2 ** 31 <= v < 2 ** 31
                        for v in value)):
            return (value[0], value[1])
        raise self.fail(value, path)


class Positions(Checker):
    """A plan's cells as an int32 array of shape (steps, agents, 2), sent as
    `{"shape": [steps, agents, 2], "b64": <base64 of the little-endian int32 cells>}`.

    JSON lists would be 10x larger and 20x slower to read for a plan of 1,500
    agents and 1,000 steps (1.5 M cells); this is checked in one pass: the
    shape, then the decoded length against it."""

    what = 'an object {"shape": [steps, agents, 2], "b64": base64 of int32 cells}'

    def __init__(self, max_cells: int = 50_000_000) -> None:
        self.max_cells = max_cells

    def __call__(self, value: Any, path: str) -> "np.ndarray":
        if not (isinstance(value, dict) and set(value) == {"shape", "b64"}
                and isinstance(value["b64"], str) and isinstance(value["shape"], list)
                and len(value["shape"]) == 3 and value["shape"][2] == 2
                and all(isinstance(v, int) and not isinstance(v, bool) and 0 <= v <= self.max_cells
                        for v in value["shape"])):
            raise self.fail(value, path)
        steps, agents, _ = value["shape"]
        cells = steps * agents
        if steps < 1 or cells > self.max_cells or len(value["b64"]) != 4 * ((8 * cells + 2) // 3):
            raise SchemaError("{} must hold {} steps of {} agents, got {} base64 characters".format(
                path, steps, agents, len(value["b64"])))
        try:
            raw = base64.b64decode(value["b64"], validate=True)
        except (ValueError, binascii.Error):
            raise SchemaError("{} is not valid base64".format(path)) from None
        if len(raw) != cells * 8:
            raise SchemaError("{} decodes to {} bytes, expected {}".format(path, len(raw), cells * 8))
        return np.frombuffer(raw, dtype="<i4").reshape(steps, agents, 2).astype(np.int32)

    @staticmethod
    def encode(positions: "np.ndarray") -> Dict[str, Any]:
        arr = np.ascontiguousarray(positions, dtype="<i4")
        return {"shape": list(arr.shape), "b64": base64.b64encode(arr.tobytes()).decode("ascii")}


class OneOf(Checker):
    """The first checker that accepts the value."""

    def __init__(self, *options: Checker) -> None:
        self.options = options
        self.what = " or ".join(o.what for o in options)

    def __call__(self, value: Any, path: str) -> Any:
        for option in self.options:
            try:
                return option(value, path)
            except SchemaError:
                continue
        raise self.fail(value, path)


class AnyObj(Checker):
    """A JSON object of at most `max_keys` keys, values unchecked (checked later by whom it concerns)."""

    def __init__(self, max_keys: int = 32) -> None:
        self.max_keys = max_keys
        self.what = "an object of at most {} keys".format(max_keys)

    def __call__(self, value: Any, path: str) -> Dict[str, Any]:
        if isinstance(value, dict) and len(value) <= self.max_keys:
            return value
        raise self.fail(value, path)


class Obj(Checker):
    """An object with these fields; `optional` ones may be missing (then None or their default)."""

    def __init__(self, fields: Dict[str, Checker], optional: Optional[Dict[str, Any]] = None) -> None:
        self.fields = fields
        self.optional = dict(optional or {})
        self.what = "an object with fields " + ", ".join(fields)

    def __call__(self, value: Any, path: str) -> Dict[str, Any]:
        if not isinstance(value, dict):
            raise self.fail(value, path)
        unknown = [k for k in value if k not in self.fields]
        if unknown:
            raise SchemaError("{} has unknown field(s) {}; known: {}".format(
                path, ", ".join(short(k, 30) for k in unknown[:3]), ", ".join(self.fields)))
        out: Dict[str, Any] = {}
        for name, check in self.fields.items():
            where = "{}.{}".format(path, name) if path else name
            if name in value:
                out[name] = check(value[name], where)
            elif name in self.optional:
                out[name] = self.optional[name]
            else:
                raise SchemaError("{} lacks field {!r}".format(path or "message", name))
        return out
