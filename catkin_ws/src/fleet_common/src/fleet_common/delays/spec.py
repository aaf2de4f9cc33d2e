"""The delay-model language: command-line terms, presets and YAML/JSON files.

On the command line a model is comma-separated `name=value` terms, presets
and files, read left to right (a later term replaces an earlier one of the
same name; `robot=` terms add up; `none` clears everything before it):

    factor=LOW-HIGH   delay=D   slow=P:F   stall=P:S   dropout=P:S   robot=R:F
    events=MODEL:P:MIN-MAX[:DURATION[:MEAN:STD]]   prone=FRACTION:P:S   seed=N
    none | moderate | btpg | FILE.yaml | FILE.json

(times S, D, MIN, MAX in nominal moves; see `model` for what each does). A
file is a mapping of the same names to the same values, or to mappings
(`stall: {p: 0.05, moves: 3}`, `events: {model: poisson, p: 0.01, min: 1,
max: 5}`); a League of Robot Runners problem file, or any mapping with a
`delayConfig` key, is read by LoRR's own field names. The simulator's first
spellings (`random:LOW-HIGH`, `stall:P:LENGTH`, `slow:ROBOT:FACTOR`) are read
as `factor=`, `stall=` and `robot=`.
"""
from __future__ import annotations

import dataclasses
import re
from pathlib import Path
from typing import Any, Callable, Dict, List, Optional, Sequence, Union

from ..yaml_lines import load_marked, read_yaml_text, where
from .model import DURATION_MODELS, EVENT_MODELS, DelayModel, DelayModelError, EventDelays, ProneDelays

FORMS = ("factor=LOW-HIGH, delay=D, slow=P:F, stall=P:S, dropout=P:S, robot=R:F, "
         "events=bernoulli|poisson:P:MIN-MAX[:uniform|gaussian], prone=FRACTION:P:S, seed=N "
         "(comma-separated; times in nominal moves, P per move), none, moderate, btpg, or a "
         ".yaml/.json file")

PRESETS: Dict[str, str] = {
    "none": "",
    "moderate": "factor=0.8-1.5,stall=0.02:3",
    "btpg": "prone=0.1:0.3:5",
}

_OLD = [(re.compile(r"random:(.*)$"), "factor={}"), (re.compile(r"stall:(.*)$"), "stall={}"),
        (re.compile(r"slow:(\d+):(.*)$"), "robot={}:{}")]
_LORR = {"seed": "seed", "minDelay": "min", "maxDelay": "max", "eventModel": "model",
         "pDelay": "p", "durationModel": "duration", "gaussMeanRatio": "mean", "gaussStdRatio": "std"}

Fields = Dict[str, Any]


class _Bad(Exception):
    """A term's value is wrong: `expected` says what it should be."""

    def __init__(self, expected: str) -> None:
        super().__init__(expected)
        self.expected = expected


def _num(text: Any, what: str, low: float = 0.0, high: Optional[float] = None) -> float:
    try:
        value = float(text)
    except (TypeError, ValueError):
        raise _Bad(what) from None
    if isinstance(text, bool) or value != value or value < low or (high is not None and value > high):
        raise _Bad(what)
    return value


def _prob(text: Any) -> float:
    return _num(text, "a probability 0..1", 0.0, 1.0)


def _parts(value: Any, names: Sequence[str], form: str) -> List[Any]:
    """`value` as 'A:B' text or a mapping {names[0]: A, ...}; missing trailing parts are None."""
    if isinstance(value, dict):
        unknown = [k for k in value if k not in names]
        if unknown:
            raise _Bad("{} (keys {}), not {!r}".format(form, ", ".join(names), unknown[0]))
        return [value.get(n) for n in names]
    parts = str(value).split(":")
    if len(parts) > len(names):
        raise _Bad(form)
    return parts + [None] * (len(names) - len(parts))


def _range(value: Any, form: str) -> List[float]:
    if isinstance(value, list) and len(value) == 2:
        low, high = value
    else:
        low, _, high = str(value).partition("-")
    a, b = _num(low, form), _num(high or low, form)
    if not 0 < a <= b:
        raise _Bad(form + " with 0 < LOW <= HIGH")
    return [a, b]


def _factor(v: Any, m: Fields) -> None:
    m["factor"] = tuple(_range(v, "LOW-HIGH"))


def _delay(v: Any, m: Fields) -> None:
    m["delay"] = _num(v, "D, a non-negative number of moves")


def _pair(field_p: str, field_x: str, names: Sequence[str], form: str, at_least: float = 0.0) -> Callable:
    def parse(v: Any, m: Fields) -> None:
        p, x = _parts(v, names, form)
        try:
            m[field_p], m[field_x] = _prob(p), _num(x, "", at_least)
        except _Bad:
            raise _Bad(form + " with P a probability 0..1 and {} >= {:g}".format(names[1], at_least)) from None
    return parse


def _robot(v: Any, m: Fields) -> None:
    robot, factor = _parts(v, ("robot", "factor"), "R:F")
    r = _num(robot, "R:F with R a 0-based robot index and F > 0")
    f = _num(factor, "R:F with R a 0-based robot index and F > 0")
    if r != int(r) or f <= 0:
        raise _Bad("R:F with R a 0-based robot index and F > 0")
    robots = dict(m.get("robots", ()))
    robots[int(r)] = f
    m["robots"] = tuple(sorted(robots.items()))


def _events(v: Any, m: Fields) -> None:
    form = "MODEL:P:MIN-MAX[:DURATION[:MEAN:STD]] (MODEL bernoulli|poisson, DURATION uniform|gaussian)"
    if isinstance(v, dict):
        known = ("model", "p", "min", "max", "duration", "mean", "std")
        model, p, low, high, duration, mean, std = _parts(v, known, form)
        low = 1 if low is None else low
        high = low if high is None else high
    else:
        model, p, span, duration, mean, std = _parts(v, ("model", "p", "span", "d", "mean", "std"), form)
        low, _, high = str(span or "").partition("-")
        high = high or low
    model, duration = model or "bernoulli", duration or "uniform"
    if model not in EVENT_MODELS:
        raise _Bad("MODEL bernoulli or poisson, not {!r}".format(model))
    if duration not in DURATION_MODELS:
        raise _Bad("DURATION uniform or gaussian, not {!r}".format(duration))
    lo, hi = _num(low, "MIN a whole number of moves >= 1", 1), _num(high, "MAX a whole number >= MIN", 1)
    if lo != int(lo) or hi != int(hi) or hi < lo:
        raise _Bad("MIN-MAX whole numbers of moves with 1 <= MIN <= MAX")
    m["events"] = EventDelays(model, _prob(p), int(lo), int(hi), duration,
                              0.5 if mean is None else _num(mean, "MEAN a fraction 0..1", 0, 1),
                              0.25 if std is None else _num(std, "STD a non-negative fraction"))


def _prone(v: Any, m: Fields) -> None:
    fraction, p, moves = _parts(v, ("fraction", "p", "moves"), "FRACTION:P:S")
    m["prone"] = ProneDelays(_num(fraction, "FRACTION of robots 0..1", 0, 1), _prob(p),
                             _num(moves, "S, a non-negative number of moves"))


def _seed(v: Any, m: Fields) -> None:
    s = _num(v, "a whole number >= 0")
    if s != int(s):
        raise _Bad("a whole number >= 0")
    m["seed"] = int(s)


TERMS: Dict[str, Callable[[Any, Fields], None]] = {
    "factor": _factor, "delay": _delay,
    "slow": _pair("slow_p", "slow_factor", ("p", "factor"), "P:F", 1.0),
    "stall": _pair("stall_p", "stall_moves", ("p", "moves"), "P:S"),
    "dropout": _pair("dropout_p", "dropout_moves", ("p", "moves"), "P:S"),
    "robot": _robot, "events": _events, "prone": _prone, "seed": _seed,
}


def parse_delay_model(specs: Union[str, Sequence[str], None], default: str = "none") -> DelayModel:
    """The model of one spec or several (combined left to right); none given means `default`."""
    if isinstance(specs, str):
        specs = [specs]
    fields: Fields = {}
    for spec in list(specs or []) or [default]:
        _apply_text(spec.strip(), fields)
    return DelayModel(**fields)


def _apply_text(spec: str, fields: Fields) -> None:
    for term in [t.strip() for t in spec.split(",")] if spec else []:
        if not term:
            continue
        for pattern, new in _OLD:
            old = pattern.match(term)
            if old and "=" not in term:
                term = new.format(*old.groups())
        name, eq, value = term.partition("=")
        name = name.strip()
        if eq and name in TERMS:
            try:
                TERMS[name](value.strip(), fields)
            except _Bad as bad:
                raise DelayModelError("{}: expected {}=".format(term, name) + bad.expected,
                                      "delay model {!r}".format(spec)) from None
        elif not eq and name in PRESETS:
            if name == "none":
                fields.clear()
            _apply_text(PRESETS[name], fields)
        elif not eq and (name.endswith((".yaml", ".yml", ".json")) or Path(name).is_file()):
            _merge(read_delay_file(name), fields)
        else:
            raise DelayModelError("unknown term {!r}; expected {}".format(term, FORMS),
                                  "delay model {!r}".format(spec))


def _merge(model: DelayModel, fields: Fields) -> None:
    """Put what `model` says (its terms that are not the defaults) over `fields`."""
    plain = DelayModel()
    for f in dataclasses.fields(model):
        value = getattr(model, f.name)
        if f.name == "robots":
            fields["robots"] = tuple(sorted({**dict(fields.get("robots", ())), **dict(value)}.items()))
        elif value != getattr(plain, f.name):
            fields[f.name] = value


def read_delay_file(path: Union[str, Path]) -> DelayModel:
    """The model in a YAML or JSON file; errors name the file, line and key."""
    path = str(path)
    data = load_marked(read_yaml_text(path, DelayModelError), path, DelayModelError)
    return delay_model_from_mapping(data, path)


def delay_model_from_mapping(data: Any, path: Optional[str] = None) -> DelayModel:
    """The model a mapping says (a file's content, or an entry of an experiment spec)."""
    if not isinstance(data, dict):
        raise DelayModelError("expected a mapping of delay terms ({})".format(", ".join(TERMS)),
                              path, *where(data))
    if "delayConfig" in data:
        return _lorr(data["delayConfig"], path)
    fields: Fields = {}
    for key, value in data.items():
        if key in PRESETS and value is True:
            _apply_text(key, fields)
            continue
        if key not in TERMS:
            raise DelayModelError("unknown key {!r}; expected one of {}".format(key, ", ".join(TERMS)),
                                  path, *where(data, key))
        values = value if key == "robot" and isinstance(value, list) else [value]
        for one in values:
            try:
                TERMS[key](one, fields)
            except _Bad as bad:
                raise DelayModelError("{}: expected {}, got {!r}".format(key, bad.expected, one),
                                      path, *where(data, key)) from None
    return DelayModel(**fields)


def _lorr(config: Any, path: Optional[str]) -> DelayModel:
    if not isinstance(config, dict):
        raise DelayModelError("delayConfig: expected a mapping of {}".format(", ".join(_LORR)),
                              path, *where(config))
    ours: Dict[str, Any] = {}
    for key, value in config.items():
        if key not in _LORR:
            raise DelayModelError("delayConfig: unknown key {!r}; expected one of {}".format(
                key, ", ".join(_LORR)), path, *where(config, key))
        ours[_LORR[key]] = value
    seed = ours.pop("seed", None)
    fields: Fields = {}
    try:
        _events(ours, fields)
        if seed is not None:
            _seed(seed, fields)
    except _Bad as bad:
        raise DelayModelError("delayConfig: expected " + bad.expected, path, *where(config)) from None
    return DelayModel(**fields)
