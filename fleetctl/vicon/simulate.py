"""`fleetctl vicon simulate`: play Vicon Tracker for a virtual run or a demo."""
from __future__ import annotations

import argparse
import socket
import time

from fleet_common.vicon.base_grid import load_vicon_to_base

from ..options import start_poses
from . import fleet, frames_path, robot_named, stop_on_signals


def simulate(args: argparse.Namespace) -> int:
    import zmq

    from fleet_common.transport.truth_stream import TruthSubscriber
    from virtual_fleet.fleet import row_poses
    from virtual_fleet.truth_sources import CircleTruth, StillTruth, TruthSource
    from virtual_fleet.vicon_tracker import (Occlusion, TrackerSettings, TrackerSimulator,
                                             run_tracker)

    robots = fleet(args)
    base_to_vicon = load_vicon_to_base(frames_path(args)).inverse()
    occlusions = tuple(Occlusion(robot_named(robots, token).vicon_name, start, end)
                       for token, start, end in args.occlude)
    settings = TrackerSettings(rate=args.rate, block_size=args.block_size, noise_mm=args.noise,
                               heading_noise_deg=args.heading_noise, loss=args.loss,
                               occlusions=occlusions,
                               zero_when_occluded=args.zero_when_occluded)
    source: TruthSource
    if args.truth_port is not None:
        source = TruthSubscriber(zmq.Context.instance(), args.truth_port,
                                 {r.id: r.vicon_name for r in robots})
        truth = "the virtual fleet's truth on {}".format(
            ", ".join("tcp://127.0.0.1:{}".format(p) for p in args.truth_port))
    elif args.demo == "circle":
        source = CircleTruth([r.vicon_name for r in robots])
        truth = "robots going round a circle"
    else:
        poses = start_poses(args.instance, robots) or row_poses(robots)
        source = StillTruth({r.vicon_name: poses[r.id] for r in robots})
        truth = "robots standing on their start cells"
    sim = TrackerSimulator(settings, base_to_vicon, seed=args.seed)
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    should_stop = stop_on_signals()
    end = None if args.seconds is None else time.monotonic() + args.seconds
    print("simulated Tracker: {} robots, {} to UDP {}:{} at {:g} Hz in {}-byte packets, noise "
          "{:g} mm, loss {:g}%{}".format(
              len(robots), truth, args.to, args.port, args.rate, args.block_size, args.noise,
              100.0 * args.loss, ", occluded: " + ", ".join(
                  o.name for o in occlusions) if occlusions else ""), flush=True)
    try:
        run_tracker(sim, source, sock, (args.to, args.port),
                    lambda: should_stop() or (end is not None and time.monotonic() >= end))
    finally:
        sock.close()
        source.close()
    c = sim.counters
    print("simulated Tracker stopped: {} frames, {} packets, {} lost on purpose".format(
        c.frames, c.packets, c.lost), flush=True)
    return 0
