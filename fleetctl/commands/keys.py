"""`fleetctl keys`: make the CurveZMQ keys that decide who may drive the robots.

Writes manager.key / manager.key_secret and robot.key / robot.key_secret into
the key folder (default $FLEETCONTROL_KEYS, else ~/.config/fleetcontrol/keys).
Robots get robot.key_secret and manager.key; the manager machine keeps
manager.key_secret and robot.key. See fleet_common.transport.curve_keys.
"""
from __future__ import annotations

import argparse
from pathlib import Path

NAME = "keys"
HELP = "make the CurveZMQ key pairs of the manager, the robots and the consoles"
DESCRIPTION = (HELP + ". Robots then obey only the manager holding manager.key_secret. "
               "Copy robot.key_secret and manager.key to each robot's key folder.")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--dir", type=Path, default=None, metavar="DIR",
                        help="key folder (default: $FLEETCONTROL_KEYS, else "
                             "~/.config/fleetcontrol/keys)")
    parser.add_argument("--force", action="store_true",
                        help="replace existing keys (every robot then needs the new ones)")


def run(args: argparse.Namespace) -> int:
    from fleet_common.transport.curve_keys import default_keys_dir, make_keys

    folder = args.dir or default_keys_dir()
    written = make_keys(folder, force=args.force)
    print("keys written to {}:".format(folder))
    for path in written:
        print("  {}{}".format(path.name, "  (secret: keep it on this machine or the robots)"
                              if path.name.endswith("_secret") else ""))
    print("robots need robot.key_secret and manager.key; the manager needs manager.key_secret "
          "and robot.key")
    return 0
