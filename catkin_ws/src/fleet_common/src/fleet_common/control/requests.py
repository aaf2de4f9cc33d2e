"""What each console action takes: the arguments of a `Request`, checked.

    start, pause, stop, step, halt    {}
    to_starts  {}     every robot drives from where it stands to its start in the plan (planned and
                      run as a run of its own, in its own run folder); then the plan waits for Start
    reset      {}     the plan again from step 0, in a new run folder: the robots drive back to
                      their starts first (as to_starts) if they are not on them
    strategy   {"name": "adg" | "step" | ..., "lookahead": K (adg, optional)}
    reroute    {"mode": "off" | "propose" | "auto"}   rerouting robots a late robot holds up
    enable     {"robot": ID}          disable  {"robot": ID}
    source     {"source": "robot" | "vicon", "robot": ID (optional: every robot)}
    load       {"text": FILE CONTENT, "name": NAME} (at most MAX_PLAN_TEXT characters), or
               {"path": NAME of a file inside a folder the manager serves (--plans DIR)}
    replan     {"time_limit": SECONDS (optional), "method": "pp" | "lacam" (optional)}
    accept     {"proposal": ID}       reject   {"proposal": ID}

`check_args(action, args)` returns the arguments with defaults filled in, or
raises `SchemaError` whose text is the refusal a console shows.
"""
from __future__ import annotations

from typing import Any, Dict

from ..limits import MAX_PLAN_TEXT
from .messages import SOURCES
from ..schema import Bool, Checker, Int, Num, Obj, Opt, SchemaError, Str

__all__ = ["ACTIONS", "ARGS", "RUN_ACTIONS", "STOPPING", "check_args"]

_ROBOT = Int(0, 2 ** 31)
_NONE: Obj = Obj({})


class _Text(Str):
    """A file's content: too long is said by its length, never quoted."""

    def __call__(self, value: Any, path: str) -> str:
        if isinstance(value, str) and len(value) > self.max_len:
            raise SchemaError("is {:,} characters; a plan sent as text may have at most {:,} "
                              "(put a larger one in a folder the manager serves)".format(
                                  len(value), self.max_len), path)
        return super().__call__(value, path)

#: The console's actions (the one list: a `Request` names one of them) and what each takes.
ARGS: Dict[str, Checker] = {
    "start": _NONE, "pause": _NONE, "stop": _NONE, "step": _NONE, "halt": _NONE,
    "to_starts": _NONE, "reset": _NONE,
    "strategy": Obj({"name": Str(40), "lookahead": Opt(Int(1, 100))}, optional={"lookahead": None}),
    "reroute": Obj({"mode": Opt(Str(40)), "scope": Opt(Str(40)), "trim": Opt(Bool())},
                   optional={"mode": None, "scope": None, "trim": None}),
    "enable": Obj({"robot": _ROBOT}),
    "disable": Obj({"robot": _ROBOT}),
    "source": Obj({"source": Str(choices=SOURCES), "robot": Opt(_ROBOT)}, optional={"robot": None}),
    "load": Obj({"path": Opt(Str(1024)), "text": Opt(_Text(MAX_PLAN_TEXT)), "name": Str(200)},
                optional={"path": None, "text": None, "name": "plan"}),
    "replan": Obj({"time_limit": Opt(Num(0.1, 600.0)), "method": Opt(Str(choices=("pp", "lacam")))},
                  optional={"time_limit": None, "method": None}),
    "accept": Obj({"proposal": Int(0, 2 ** 53)}),
    "reject": Obj({"proposal": Int(0, 2 ** 53)}),
}
#: What a console may ask.
ACTIONS = tuple(ARGS)
#: The actions without arguments that act on the run: a State says which of them the manager
#: would carry out now (`RunInfo.allowed`), so that a console greys the others.
RUN_ACTIONS = ("start", "pause", "step", "stop", "halt", "replan", "to_starts", "reset")
#: The actions that only take motion away: an operator may always ask them, on whatever picture
#: (the desk never refuses them as stale: a Halt pressed as an automatic reroute changed the plan
#: must not have to be pressed twice).
STOPPING = ("pause", "stop", "halt")


def check_args(action: str, args: Dict[str, Any]) -> Dict[str, Any]:
    """The checked arguments of `action` (SchemaError says what is wrong)."""
    checker = ARGS.get(action)
    if checker is None:
        raise SchemaError("unknown action {!r}; actions: {}".format(action, ", ".join(ACTIONS)))
    checked = checker(args, "{} arguments".format(action))
    if action == "load" and (checked["path"] is None) == (checked["text"] is None):
        raise SchemaError("load needs either the file's text or the path of a file inside a folder "
                          "the manager serves")
    return checked
