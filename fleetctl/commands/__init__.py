"""One module per `fleetctl` subcommand.

Each module defines `NAME`, `HELP` (one line), `add_arguments(parser)` and
`run(args) -> int` (the exit status). Adding a subcommand is one module and one
entry in `COMMANDS`.
"""
from __future__ import annotations

COMMANDS = ("info", "validate", "repair", "convert", "solve", "demo", "keys", "virtual_fleet",
            "console", "simulate", "manager", "trace", "experiment", "report", "vicon")
