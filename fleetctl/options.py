"""Options shared by several subcommands, defined once."""
from __future__ import annotations

import argparse
from pathlib import Path
from typing import List

from fleet_common.formats.mapsearch import default_map_dirs


def add_map_dir(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--map-dir", metavar="D", action="append", default=[], type=Path,
        help="folder to search for map_file= (repeatable); searched after the file's own "
             "folder and before the defaults ($FLEETCONTROL_MAP_PATH, the shared mapf-IR maps, the lab)",
    )


def map_dirs(args: argparse.Namespace) -> List[Path]:
    return list(args.map_dir) + default_map_dirs()
