"""Entry point of `fleetctl`: argument parsing and the one place errors become exit codes.

Exit statuses: 0 success; 1 the input is well formed but wrong (a plan with
conflicts, a failed run); 2 the input cannot be read (one line `FILE:LINE: message`,
at most 299 characters, control characters escaped) or the command line is
wrong; 3 no plan found within the limit (`solve`); 70 a bug of ours (one line
too); 130 interrupted. Users never see a traceback; set FLEETCTL_DEBUG=1 to get
one. What a reader doubts (`FormatWarning`: an unknown header key) is printed
as `FILE:LINE: warning: ...` on stderr and leaves the exit status alone.
"""
from __future__ import annotations

import argparse
import importlib
import os
import sys
import warnings
from typing import Any, List, Optional

from fleet_common.errors import FleetError, FormatError, FormatWarning
from fleet_common.limits import one_line

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
    with warnings.catch_warnings():
        warnings.simplefilter("always", FormatWarning)
        warnings.showwarning = _show_warning
        return _run(args)


def _run(args: argparse.Namespace) -> int:
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
    print(one_line(line), file=sys.stderr)
    return status


def _show_warning(message: Any, category: Any, filename: str, lineno: int, file: Any = None,
                  line: Optional[str] = None) -> None:
    """FormatWarnings as `FILE:LINE: warning: ...`; others as Python prints them."""
    if isinstance(message, FormatWarning):
        print(one_line(str(message)), file=sys.stderr)
    else:
        sys.stderr.write(warnings.formatwarning(message, category, filename, lineno, line))
