"""Entry point of `fleetctl`: argument parsing and the one place errors become exit codes.

Exit statuses: 0 success; 1 the input is well formed but wrong (a plan with
conflicts, a failed run); 2 the input cannot be read (one line `FILE:LINE: message`,
at most 299 characters, control characters escaped) or the command line is
wrong; 3 no plan found within the limit (`solve`); 70 a bug of ours (one line
too); 130 interrupted. Users never see a traceback; set FLEETCTL_DEBUG=1 to get
one. What a reader doubts (`FormatWarning`: an unknown header key) is printed
as `FILE:LINE: warning: ...` on stderr and leaves the exit status alone.

Only the chosen command's module is imported (see `commands`), after the
command line names it: `fleetctl --help` imports none. The `fleetctl` program is
`entry`: `main`, and for the one-shot file commands a start and an end without
what they do not need (`one_shot`); tests call `main`.
"""
from __future__ import annotations

import argparse
import importlib
import os
import sys
import warnings
from types import ModuleType
from typing import Any

from fleet_common.arg_types import Parser

from .commands import COMMANDS, ONE_SHOT

# no more of fleet_common here: `fleetctl --help` imports only what it prints (the rest comes in main)


def command_module(name: str) -> ModuleType | None:
    """The module of command `name` (as typed on the command line), imported now; None if unknown."""
    for command, module, _ in COMMANDS:
        if command == name:
            return importlib.import_module("fleetctl.commands." + module)
    return None


def build_parser(chosen: str | None = None) -> Parser:
    """The parser of command `chosen` alone, or (None) of all commands with just their help lines."""
    parser = Parser(
        prog="fleetctl",
        description="FleetControl: check, convert, solve and run MAPF plans on the lab's robots.",
    )
    if chosen is not None:
        parser.see = "fleetctl " + chosen
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True
    for name, _, help_line in COMMANDS:
        if chosen is not None and name != chosen:
            continue  # argparse makes a parser per command; the others cost start-up for nothing
        p = sub.add_parser(name, help=help_line, description=help_line)
        if name == chosen:
            module = command_module(name)
            p.description = getattr(module, "DESCRIPTION", help_line)
            module.add_arguments(p)  # type: ignore[union-attr]
            p.set_defaults(_run=module.run)  # type: ignore[union-attr]
    return parser


def chosen_command(argv: list[str]) -> str | None:
    """The command word of `argv` (unchecked), or None."""
    # the top level has no options but -h, so the first other word names the command
    chosen = next((a for a in argv if not a.startswith("-")), None)
    if chosen is not None and argv.index(chosen) > 0:
        return None  # `fleetctl -h solve`: the top level's help, with every command
    return chosen


def entry() -> int:
    """The `fleetctl` program: `main`, then for a one-shot command the end without teardown."""
    status = main()
    if chosen_command(sys.argv[1:]) in ONE_SHOT:
        from . import one_shot

        if one_shot.alone():
            one_shot.exit_now(status)
    return status


def main(argv: list[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    chosen = chosen_command(argv)
    if chosen in ONE_SHOT:
        from . import one_shot

        with one_shot.numpy_parts_on_first_use():
            return _main(argv, chosen)
    return _main(argv, chosen)


def _main(argv: list[str], chosen: str | None) -> int:
    module = command_module(chosen) if chosen is not None else None
    # argparse cannot take `-- OPTIONS` after a positional; a command that sets PASSTHROUGH
    # (solve: options for mapf-IR) gets what follows `--` unparsed, as args.passthrough
    passthrough: list[str] = []
    if module is not None and "--" in argv and getattr(module, "PASSTHROUGH", False):
        cut = argv.index("--")
        argv, passthrough = argv[:cut], argv[cut + 1:]
    args = build_parser(chosen if module is not None else None).parse_args(argv)
    args.passthrough = passthrough
    from fleet_common.errors import FormatWarning

    with warnings.catch_warnings():
        warnings.simplefilter("always", FormatWarning)
        warnings.showwarning = _show_warning
        return _run(args)


def _run(args: argparse.Namespace) -> int:
    from fleet_common.errors import FleetError, FormatError

    try:
        return int(args._run(args))
    except FormatError as err:
        return _fail(str(err))
    except FleetError as err:
        return _fail("fleetctl {}: {}".format(args.command, err))
    except BrokenPipeError:
        # the reader went away (`fleetctl info x | head`): stop quietly, like other tools
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 141
    except OSError as err:
        where = err.filename if err.filename is not None else ""
        return _fail("{}: {}".format(where, err.strerror or err) if where else str(err))
    except KeyboardInterrupt:
        return 130
    except Exception as err:  # a bug of ours: still one line, no traceback
        return _fail("fleetctl {}: internal error: {}: {} (FLEETCTL_DEBUG=1 shows the traceback; "
                     "please report it)".format(args.command, type(err).__name__, err), status=70)


def _fail(line: str, status: int = 2) -> int:
    if os.environ.get("FLEETCTL_DEBUG"):
        raise
    from fleet_common.limits import one_line

    print(one_line(line), file=sys.stderr)
    return status


def _show_warning(message: Any, category: Any, filename: str, lineno: int, file: Any = None,
                  line: str | None = None) -> None:
    """FormatWarnings as `FILE:LINE: warning: ...`; others as Python prints them."""
    from fleet_common.errors import FormatWarning
    from fleet_common.limits import one_line

    if isinstance(message, FormatWarning):
        print(one_line(str(message)), file=sys.stderr)
    else:
        sys.stderr.write(warnings.formatwarning(message, category, filename, lineno, line))
