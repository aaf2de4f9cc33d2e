"""Entry point of `fleetctl`: argument parsing and the one place errors become exit codes.

Exit statuses: 0 success; 1 the input is well formed but wrong (a plan with
conflicts, a failed run); 2 the input cannot be read (one line `FILE:LINE: message`)
or the command line is wrong; 3 no plan found within the limit (`solve`);
130 interrupted. Users never see a traceback; set FLEETCTL_DEBUG=1 to get one.
"""
from __future__ import annotations

import argparse
import importlib
import os
import sys
from typing import List, Optional

from fleet_common.errors import FleetError, FormatError

from .commands import COMMANDS


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="fleetctl",
        description="FleetControl: check, convert, solve and run MAPF plans on the lab's robots.",
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True
    for name in COMMANDS:
        module = importlib.import_module("fleetctl.commands." + name)
        p = sub.add_parser(module.NAME, help=module.HELP, description=getattr(module, "DESCRIPTION", module.HELP))
        module.add_arguments(p)
        p.set_defaults(_run=module.run)
    return parser


def main(argv: Optional[List[str]] = None) -> int:
    parser = build_parser()
    argv = list(sys.argv[1:] if argv is None else argv)
    # argparse cannot take `-- OPTIONS` after a positional; a command that sets PASSTHROUGH
    # (solve: options for mapf-IR) gets what follows `--` unparsed, as args.passthrough
    passthrough: List[str] = []
    if argv and argv[0] in COMMANDS and "--" in argv and getattr(
            importlib.import_module("fleetctl.commands." + argv[0]), "PASSTHROUGH", False):
        cut = argv.index("--")
        argv, passthrough = argv[:cut], argv[cut + 1:]
    args = parser.parse_args(argv)
    args.passthrough = passthrough
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
