"""Entry point of `fleetctl`: argument parsing and the one place errors become exit codes.

Exit statuses: 0 success; 1 the input is well formed but wrong (a plan with
conflicts, a failed run); 2 the input cannot be read (one line `FILE:LINE: message`)
or the command line is wrong; 3 no plan found within the limit (`solve`);
130 interrupted. Users never see a traceback; set FLEETCTL_DEBUG=1 to get one.

Only the chosen command's module is imported (see `commands`), after the
command line names it: `fleetctl --help` imports none.
"""
from __future__ import annotations

import argparse
import importlib
import os
import sys
from types import ModuleType

from .commands import COMMANDS

# no `typing` and no fleet_common here: `fleetctl --help` imports only what it prints


def command_module(name: str) -> ModuleType | None:
    """The module of command `name` (as typed on the command line), imported now; None if unknown."""
    for command, module, _ in COMMANDS:
        if command == name:
            return importlib.import_module("fleetctl.commands." + module)
    return None


def build_parser(chosen: str | None = None) -> argparse.ArgumentParser:
    """The parser of command `chosen` alone, or (None) of all commands with just their help lines."""
    parser = argparse.ArgumentParser(
        prog="fleetctl",
        description="FleetControl: check, convert, solve and run MAPF plans on the lab's robots.",
    )
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


def main(argv: list[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    # the top level has no options but -h, so the first other word names the command
    chosen = next((a for a in argv if not a.startswith("-")), None)
    if chosen is not None and argv.index(chosen) > 0:
        chosen = None  # `fleetctl -h solve`: the top level's help, with every command
    module = command_module(chosen) if chosen is not None else None
    # argparse cannot take `-- OPTIONS` after a positional; a command that sets PASSTHROUGH
    # (solve: options for mapf-IR) gets what follows `--` unparsed, as args.passthrough
    passthrough: list[str] = []
    if module is not None and "--" in argv and getattr(module, "PASSTHROUGH", False):
        cut = argv.index("--")
        argv, passthrough = argv[:cut], argv[cut + 1:]
    args = build_parser(chosen if module is not None else None).parse_args(argv)
    args.passthrough = passthrough
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


def _fail(line: str) -> int:
    if os.environ.get("FLEETCTL_DEBUG"):
        raise
    print(line, file=sys.stderr)
    return 2
