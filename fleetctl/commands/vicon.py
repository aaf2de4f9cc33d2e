"""`fleetctl vicon listen | calibrate | simulate`: the lab's Vicon system, for lab staff.

The argument parsing is here; the work is in `fleetctl.vicon` (one module each).
"""
from __future__ import annotations

import argparse
from pathlib import Path
from typing import Optional

from fleet_common.arg_types import non_negative, number, port, positive, seed

NAME = "vicon"
HELP = "the Vicon motion-capture stream: listen to it, calibrate it, or simulate Tracker"
DESCRIPTION = (
    "Vicon Tracker's UDP Object Stream. `listen` prints what arrives (each object's base-grid "
    "pose and age, the counters); `calibrate` fits the vicon -> base transform from robots on "
    "known cells and writes it into the frames file; `simulate` plays Tracker for a virtual "
    "run (the virtual fleet's true poses, or a demo pattern).")

DEFAULT_PORT = 51001


def _common(p: argparse.ArgumentParser, frames_help: str) -> None:
    p.add_argument("--definitions", type=Path, default=None, metavar="FILE",
                   help="robot definitions, for the vicon_name column (default: "
                        "$FLEETCONTROL_ROBOTS, else the repository's robot_definitions.txt)")
    p.add_argument("--frames", type=Path, default=None, metavar="FILE", help=frames_help)


def _listener(p: argparse.ArgumentParser, seconds: Optional[float], for_help: str) -> None:
    p.add_argument("--port", type=port, default=DEFAULT_PORT,
                   help="UDP port Tracker streams to (default {})".format(DEFAULT_PORT))
    p.add_argument("--bind", default="0.0.0.0", metavar="ADDRESS",
                   help="local address to listen on (default 0.0.0.0, every interface)")
    p.add_argument("--for", dest="seconds", type=positive, default=seconds, metavar="SECONDS",
                   help=for_help)


def _occlusion(text: str) -> tuple:
    robot, _, window = text.partition(":")
    try:
        start, end = (float(v) for v in window.split("-")) if window else (0.0, float("inf"))
    except ValueError:
        start = end = -1.0
    if not robot or not 0.0 <= start < end:
        raise argparse.ArgumentTypeError(
            "expected ROBOT or ROBOT:FROM-TO (seconds after the start, e.g. 3:2-5), got "
            "'{}'".format(text))
    return robot, start, end


def _probability(text: str) -> float:
    return number(text, lambda v: 0.0 <= v < 1.0, "a probability 0 <= P < 1")


def _rate(text: str) -> float:
    value = positive(text)
    if value > 100.0:
        raise argparse.ArgumentTypeError("at most 100 Hz (Tracker's limit), got {}".format(text))
    return value


def add_arguments(parser: argparse.ArgumentParser) -> None:
    sub = parser.add_subparsers(dest="action", metavar="ACTION")
    sub.required = True
    frames = "frames file holding vicon_to_base (default: the lab's frames.yaml)"

    p = sub.add_parser("listen", help="print each object's base-grid pose, age and the counters",
                       description="Listen to Tracker's stream and print, per object, its pose "
                                   "in base-grid cells, frame and age (STALE when not seen for "
                                   "--stale-after), then the counters. Exit 0.")
    _listener(p, None, "stop after SECONDS and print once (default: print every --every "
                      "seconds until Ctrl-C)")
    p.add_argument("--every", type=positive, default=1.0, metavar="SECONDS",
                   help="print interval without --for (default 1)")
    p.add_argument("--stale-after", type=positive, default=0.5, metavar="SECONDS",
                   help="an object not seen for this long is STALE (default 0.5)")
    _common(p, frames)

    p = sub.add_parser("calibrate", help="fit vicon -> base from robots on known cells",
                       description="Fit the similarity transform Vicon -> base grid (least "
                                   "squares, at least 4 correspondences), print each point's "
                                   "residual and the RMS in cm, and write it into the frames "
                                   "file unless the RMS is above --max-rms (then exit 1).")
    source = p.add_mutually_exclusive_group(required=True)
    source.add_argument("--pairs", type=Path, metavar="FILE",
                        help="correspondences file: lines of cell_x cell_y vicon_x_mm "
                             "vicon_y_mm [label]")
    source.add_argument("--live", action="store_true",
                        help="measure the robots standing on known cells from the stream")
    _listener(p, 3.0, "live: seconds to average each robot's position over (default 3)")
    p.add_argument("--at", action="append", default=[], metavar="ROBOT=X,Y",
                   help="live: robot (id or Vicon name) stands on base cell X,Y (repeatable; "
                        "default: robot i on agent i's start of --instance)")
    p.add_argument("--instance", type=Path, default=None, metavar="FILE",
                   help="live: robots stand on this instance's starts (default: the lab's)")
    p.add_argument("--record", type=Path, default=None, metavar="FILE",
                   help="live: add the measured pairs to this correspondences file and fit "
                        "all of its pairs (move the robots and measure again for more points)")
    p.add_argument("--max-rms", type=positive, default=2.0, metavar="CM",
                   help="refuse to write a fit whose RMS residual is above CM (default 2)")
    p.add_argument("--dry-run", action="store_true", help="fit and print; write nothing")
    _common(p, "frames file to write vicon_to_base into, keeping the rest (default: the "
               "lab's frames.yaml)")

    p = sub.add_parser("simulate", help="stream like Tracker: the virtual fleet's true poses",
                       description="Play Vicon Tracker: stream the true poses of the virtual "
                                   "fleet's robots (or a demo pattern) as UDP Object Stream "
                                   "packets, in Vicon millimetres through the inverse of the "
                                   "frames file's vicon_to_base.")
    truth = p.add_mutually_exclusive_group(required=True)
    truth.add_argument("--truth-port", type=port, action="append", metavar="PORT",
                       help="the virtual fleet's ground-truth port (fleetctl virtual-fleet "
                            "--truth-port PORT); repeatable, for a fleet served by several "
                            "processes (virtual-fleet --robots)")
    truth.add_argument("--demo", choices=["circle", "still"],
                       help="no fleet: robots go round a circle, or stand on the lab "
                            "instance's starts")
    p.add_argument("--to", default="127.0.0.1", metavar="HOST",
                   help="where the stream goes (default 127.0.0.1)")
    p.add_argument("--port", type=port, default=DEFAULT_PORT,
                   help="UDP port (default {})".format(DEFAULT_PORT))
    p.add_argument("--rate", type=_rate, default=100.0, metavar="HZ",
                   help="frames per second, at most 100 (default 100)")
    p.add_argument("--block-size", type=int, choices=[256, 512, 1024], default=1024,
                   help="packet size in bytes (default 1024)")
    p.add_argument("--noise", type=non_negative, default=1.0, metavar="MM",
                   help="standard deviation of each coordinate (default 1 mm)")
    p.add_argument("--heading-noise", type=non_negative, default=0.5, metavar="DEG",
                   help="standard deviation of the heading (default 0.5 degrees)")
    p.add_argument("--loss", type=_probability, default=0.0, metavar="P",
                   help="probability that a packet is lost, 0 <= P < 1 (default 0)")
    p.add_argument("--occlude", action="append", default=[], type=_occlusion,
                   metavar="ROBOT[:FROM-TO]",
                   help="robot (id or Vicon name) not seen, always or FROM-TO seconds after "
                        "the start (repeatable)")
    p.add_argument("--zero-when-occluded", action="store_true",
                   help="send an occluded robot as all zeros instead of leaving it out")
    p.add_argument("--for", dest="seconds", type=positive, default=None, metavar="SECONDS",
                   help="stop after SECONDS (default: run until Ctrl-C)")
    p.add_argument("--seed", type=seed, default=0, help="seed of noise and loss (default 0)")
    p.add_argument("--instance", type=Path, default=None, metavar="FILE",
                   help="--demo still: robots stand on this instance's starts")
    _common(p, frames)


def run(args: argparse.Namespace) -> int:
    if args.action == "listen":
        from ..vicon.listen import listen
        return listen(args)
    if args.action == "calibrate":
        from ..vicon.calibrate import calibrate_command
        return calibrate_command(args)
    from ..vicon.simulate import simulate
    return simulate(args)
