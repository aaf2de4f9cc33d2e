"""`fleetctl manager`: drive the fleet (real or virtual robots) through a plan (thesis 5.3).

The options and the run live in fleet_manager.main, which the lab PC's
`fleet_manager` node (catkin_ws/src/fleet_manager/nodes) runs as well.
"""
from __future__ import annotations

import argparse

NAME = "manager"
HELP = "execute a plan on the robots (real or virtual), steered from consoles"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    from fleet_manager.main import DESCRIPTION, add_arguments as manager_arguments

    parser.description = DESCRIPTION
    manager_arguments(parser)


def run(args: argparse.Namespace) -> int:
    from fleet_manager.main import run as run_manager

    return run_manager(args)
