"""`fleetctl vicon listen`: what Tracker's stream says, as the manager would read it."""
from __future__ import annotations

import argparse
import math
import time
from typing import TYPE_CHECKING, List

from . import fleet, open_provider, stop_on_signals, watch

if TYPE_CHECKING:
    from fleet_manager.vicon_provider import ViconProvider


def listen(args: argparse.Namespace) -> int:
    robots = fleet(args)
    provider = open_provider(args, robots, args.stale_after)
    should_stop = stop_on_signals()
    started = time.monotonic()
    try:
        watch(provider, args.every if args.seconds is None else args.seconds, should_stop)
        while args.seconds is None and not should_stop():  # until Ctrl-C: every interval
            print("\n".join(report(provider, time.monotonic() - started)), flush=True)
            watch(provider, args.every, should_stop)
        print("\n".join(report(provider, time.monotonic() - started)), flush=True)
    finally:
        provider.close()
    return 0


def report(provider: ViconProvider, elapsed: float) -> List[str]:
    host, port = provider.address
    c = provider.counters
    if not c.packets:
        return ["nothing received on UDP {}:{} in {:.1f} s (is Tracker streaming to this "
                "machine and port?)".format(host, port, elapsed)]
    fixes = provider.objects()
    lines = ["UDP {}:{} after {:.1f} s: {} objects".format(host, port, elapsed, len(fixes)),
             "{:<24} {:>5} {:>8} {:>8} {:>8} {:>10} {:>9}".format(
                 "object", "robot", "x", "y", "heading", "frame", "age")]
    for f in fixes:
        lines.append("{:<24} {:>5} {:>8.2f} {:>8.2f} {:>7.1f}d {:>10} {:>7.2f} s{}".format(
            f.name, "-" if f.robot_id is None else f.robot_id, f.pose.x, f.pose.y,
            math.degrees(f.pose.theta), f.frame, f.age, "  STALE" if f.stale else ""))
    missing = sorted(set(provider.ids) - {f.name for f in fixes})
    if missing:
        lines.append("never seen: " + ", ".join(missing))
    lines.append("counters: " + c.summary())
    return lines
