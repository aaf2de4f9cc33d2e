"""Checking decoded JSON against a schema: any value in, a checked value or our error out.

Both protocols, robot <-> manager (`wire`) and manager <-> console (`control`),
declare their messages with these checkers and decode them through them, so a
frame is checked, and a refusal worded, the same way in both. Messages nest (a
state holds a run and robots, a status a pose), so instead of one hand-written
check per field there are small checkers that compose: `Int`, `Num`, `Str`,
`Bool`, `Opt`, `ListOf`, `MapOf`, `Obj`, `AnyObj`, and `Record`, an `Obj` that builds its
dataclass (a message, or a record inside one). Each takes the decoded value and
the path to it (`robots[3].waiting.on[0]`) and returns the value as the program
wants it, or raises `SchemaError` saying where and what was expected. Nothing
else can come out of them, whatever the input: that is what makes the decoders
built on them total. `dump` is the way back, for the fields whose JSON form is
not the value itself (a pose as [x, y, theta]) or that the peer would refuse
(our own texts cut to the length it accepts).
"""
from __future__ import annotations

import dataclasses
import math
from typing import Any, Callable, Dict, Optional, Sequence, Type

from .errors import FleetError

__all__ = ["SchemaError", "Checker", "Int", "Num", "Str", "Bool", "Opt", "ListOf", "MapOf", "Obj", "Record",
           "AnyObj", "short"]


class SchemaError(FleetError, ValueError):
    """A decoded value that does not have the expected shape: `path` says where (empty: the
    value checked as a whole), `problem` what is wrong ("must be a ..., got ...")."""

    def __init__(self, problem: str, path: str = "") -> None:
        super().__init__("{} {}".format(path, problem) if path else problem)
        self.problem = problem
        self.path = path

    def in_message(self, kind: str) -> str:
        """The refusal of a whole `kind` message: which field of it, and what is wrong."""
        if self.path:
            return "field {!r} of a {} message {}".format(self.path, kind, self.problem)
        return "{} message {}".format(kind, self.problem)


def short(value: Any, limit: int = 40) -> str:
    """A short, printable excerpt of `value` for an error message (never megabytes)."""
    text = repr(value) if not isinstance(value, str) else repr(value[:limit + 1])
    text = "".join(c if c.isprintable() else "?" for c in text)
    return text if len(text) <= limit else text[:limit - 3] + "..."


class Checker:
    what = "a value"
    #: True when `dump` gives the value itself (encoders then skip the call)
    plain = True

    def __call__(self, value: Any, path: str) -> Any:
        raise NotImplementedError

    def fail(self, value: Any, path: str) -> SchemaError:
        return SchemaError("must be {}, got {}".format(self.what, short(value)), path)

    def dump(self, value: Any) -> Any:
        """`value` as JSON carries it (for most checkers, the value itself)."""
        return value


class Int(Checker):
    def __init__(self, low: int = 0, high: int = 2 ** 53, what: Optional[str] = None) -> None:
        self.low, self.high = low, high
        self.what = what or "a whole number from {} to {}".format(low, high)

    def __call__(self, value: Any, path: str) -> int:
        if isinstance(value, int) and not isinstance(value, bool) and self.low <= value <= self.high:
            return value
        raise self.fail(value, path)


class Num(Checker):
    """A finite number, as a float; within [low, high] when they are given."""

    def __init__(self, low: float = -1e9, high: float = 1e9, what: Optional[str] = None) -> None:
        self.low, self.high = low, high
        self.what = what or "a finite number from {:g} to {:g}".format(low, high)

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

    plain = False

    def dump(self, value: Any) -> Any:
        return value[:self.max_len]  # a text of ours the peer would refuse is cut instead


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
        self.plain = inner.plain

    def __call__(self, value: Any, path: str) -> Any:
        return None if value is None else self.inner(value, path)

    def dump(self, value: Any) -> Any:
        return None if value is None else self.inner.dump(value)


class ListOf(Checker):
    def __init__(self, inner: Checker, max_len: int = 10000, tuple_out: bool = True,
                 what: Optional[str] = None) -> None:
        self.inner, self.max_len, self.tuple_out = inner, max_len, tuple_out
        self.what = what or "a list of at most {} items".format(max_len)
        self.plain = False  # a tuple becomes a list, and is cut to max_len

    def __call__(self, value: Any, path: str) -> Any:
        if not isinstance(value, list) or len(value) > self.max_len:
            raise self.fail(value, path)
        inner = self.inner
        try:  # each item's path is made only if it is wrong: this runs for every frame
            items = [inner(v, "") for v in value]
        except SchemaError:
            items = [inner(v, "{}[{}]".format(path, i)) for i, v in enumerate(value)]
        return tuple(items) if self.tuple_out else items

    def dump(self, value: Any) -> Any:
        return [self.inner.dump(v) for v in value[:self.max_len]]


class MapOf(Checker):
    """A JSON object of at most `max_len` keys, each checked by `key`, its value by `inner`: a dict
    (reasons by action: the keys are data, not field names as in `Obj`)."""

    plain = False  # values are cut as `inner` cuts them

    def __init__(self, key: Str, inner: Checker, max_len: int = 100) -> None:
        self.key, self.inner, self.max_len = key, inner, max_len
        self.what = "an object of at most {} keys".format(max_len)

    def __call__(self, value: Any, path: str) -> Dict[str, Any]:
        if not isinstance(value, dict) or len(value) > self.max_len:
            raise self.fail(value, path)
        out: Dict[str, Any] = {}
        for name, item in value.items():
            try:
                name = self.key(name, "")
            except SchemaError as err:
                raise SchemaError("has a key that " + err.problem, path) from None
            out[name] = self.inner(item, "{}.{}".format(path, name) if path else name)
        return out

    def dump(self, value: Any) -> Any:
        return {k: self.inner.dump(v) for k, v in list(value.items())[:self.max_len]}


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

    plain = False
    #: what the checked fields become: None, a dict; else this callable's result (`Record`)
    make: Optional[Callable[..., Any]] = None

    def __init__(self, fields: Dict[str, Checker], optional: Optional[Dict[str, Any]] = None) -> None:
        self.fields = fields
        self._items = tuple(fields.items())
        self.optional = dict(optional or {})
        self.what = "an object with fields " + ", ".join(fields) if fields else "an empty object"
        #: (name, its dump, or None where the value is its own JSON form)
        self.dumps = tuple((name, None if c.plain else c.dump) for name, c in fields.items())

    def __call__(self, value: Any, path: str, **extra: Any) -> Any:
        if not isinstance(value, dict):
            raise self.fail(value, path)
        out: Dict[str, Any] = {}
        found = 0
        for name, check in self._items:
            if name in value:
                out[name] = check(value[name], path + "." + name if path else name)
                found += 1
            elif name in self.optional:
                out[name] = self.optional[name]
            else:
                raise SchemaError("lacks field {!r}".format(name), path)
        if found != len(value):  # (counted rather than looked for: this runs for every frame)
            unknown = [k for k in value if k not in self.fields]
            raise SchemaError("has unknown field(s) {}; known: {}".format(
                ", ".join(short(k, 30) for k in unknown[:3]), ", ".join(self.fields) or "none"), path)
        return out if self.make is None else self.make(**out, **extra)

    def dump(self, value: Any) -> Dict[str, Any]:
        return {name: value[name] if dump is None else dump(value[name]) for name, dump in self.dumps}


class Record(Obj):
    """An `Obj` whose fields are those of dataclass `cls` (less `extra`, which the caller gives
    when it checks a value, such as a message's version from its frame), checked into an
    instance of it."""

    def __init__(self, cls: Type, fields: Dict[str, Checker], optional: Optional[Dict[str, Any]] = None,
                 extra: Sequence[str] = ()) -> None:
        super().__init__(fields, optional)
        self.cls = self.make = cls
        declared = [f.name for f in dataclasses.fields(cls) if f.name not in extra]
        if declared != list(fields):  # our own declarations out of step: a bug, found at import
            raise TypeError("schema of {} lists {}, the dataclass {}".format(
                cls.__name__, ", ".join(fields), ", ".join(declared)))

    def dump(self, value: Any) -> Dict[str, Any]:
        out: Dict[str, Any] = {}
        for name, dump in self.dumps:
            v = getattr(value, name)
            out[name] = v if dump is None else dump(v)
        return out
