"""Benchmark: the Vicon path, decoder throughput and UDP-to-pose latency on 127.0.0.1.

1. Decoding: `ViconStream.receive` on Tracker packets (30 objects a frame in
   256- and 1024-byte blocks), packets and objects per second.
2. Latency: a simulated Tracker in its own process (`run_tracker`, 100 Hz, 20 %
   packet loss, robots going round a circle) sends to the manager's
   `ViconProvider`, polled with zmq.Poller as the manager polls it. For every
   robot pose the provider returns: time returned - time Tracker began to send
   that frame (CLOCK_MONOTONIC is one clock for all processes on Linux).
   Prints p50 / p95 / p99 / max, and the receiver's CPU share.

    .venv/bin/python bench/vicon.py [--seconds 5]
"""
from __future__ import annotations

import argparse
import multiprocessing
import os
import socket
import sys
import time
from pathlib import Path
from typing import Dict, List, Tuple

import zmq

# bench/virtual_fleet.py would shadow the virtual_fleet package: drop this script's folder
sys.path[:] = [p for p in sys.path if Path(p or ".").resolve() != Path(__file__).resolve().parent]

from fleet_common.lab import lab_transforms
from fleet_common.robots import parse_robot_definitions
from fleet_common.vicon import ViconObject, ViconStream, encode_frame
from fleet_common.vicon.base_grid import vicon_to_base
from fleet_manager.vicon_provider import ViconProvider
from virtual_fleet.truth_sources import CircleTruth
from virtual_fleet.vicon_tracker import TrackerSettings, TrackerSimulator, run_tracker


def percentile(values: List[float], q: float) -> float:
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, int(q * len(ordered)))]


def decode_rate(block: int, frames: int = 2000) -> Tuple[float, float]:
    objects = [ViconObject("turtlebot{}".format(i), (100.0 * i + 1, 2000.0, 400.0),
                           (0.0, 0.0, 0.1 * i)) for i in range(30)]
    packets = [p for f in range(1, frames + 1) for p in encode_frame(f, objects, block)]
    stream = ViconStream()
    start = time.perf_counter()
    for p in packets:
        stream.receive(p, 0.0)
    took = time.perf_counter() - start
    return len(packets) / took, 30 * frames / took


def tracker(port: int, names: List[str], block: int, seconds: float,
            out: "multiprocessing.Queue[Dict[int, float]]") -> None:
    sim = TrackerSimulator(TrackerSettings(rate=100.0, block_size=block, noise_mm=1.0, loss=0.2),
                           vicon_to_base(lab_transforms()).inverse(), seed=1)
    sent: Dict[int, float] = {}
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    end = time.monotonic() + seconds
    run_tracker(sim, CircleTruth(names), sock, ("127.0.0.1", port),
                lambda: time.monotonic() >= end, sent=sent.__setitem__)
    sock.close()
    out.put(sent)


def latency(robots: int, block: int, seconds: float) -> None:
    fleet = parse_robot_definitions("".join(
        "{0} 127.0.0.1 {1} u tb{0} red\n".format(i, 20000 + i) for i in range(1, robots + 1)))
    provider = ViconProvider(fleet, vicon_to_base(lab_transforms()), port=0, bind="127.0.0.1")
    results: "multiprocessing.Queue[Dict[int, float]]" = multiprocessing.Queue()
    proc = multiprocessing.Process(target=tracker, args=(
        provider.address[1], [r.vicon_name for r in fleet], block, seconds, results))
    poller = zmq.Poller()
    poller.register(provider, zmq.POLLIN)
    got: List[Tuple[int, float]] = []  # (frame, time the provider returned the pose)
    proc.start()
    cpu0, wall0 = time.process_time(), time.monotonic()
    while proc.is_alive() or results.empty():
        if poller.poll(100):
            fixes = provider.handle_readable()
            now = time.monotonic()
            got += [(f.frame, now) for f in fixes]
        if not proc.is_alive() and time.monotonic() - wall0 > seconds + 5:
            break
    cpu = (time.process_time() - cpu0) / (time.monotonic() - wall0)
    sent = results.get(timeout=10)
    proc.join()
    provider.close()
    lat = [1000.0 * (when - sent[frame]) for frame, when in got if frame in sent]
    c = provider.counters
    print("{:>3} robots, {:>4}-byte packets: {:>6} poses, latency ms p50 {:.2f}  p95 {:.2f}  "
          "p99 {:.2f}  max {:.2f}; frames {} lost {} ({:.0f} %); receiver CPU {:.1f} % of a "
          "core".format(robots, block, len(lat), percentile(lat, 0.5), percentile(lat, 0.95),
                        percentile(lat, 0.99), max(lat), c.frames, c.frames_lost,
                        100.0 * c.frames_lost / max(1, c.frames + c.frames_lost), 100.0 * cpu))


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=5.0)
    args = parser.parse_args()
    print("load average at start: {:.2f} {:.2f} {:.2f}".format(*os.getloadavg()))
    for block in (256, 1024):
        packets, objects = decode_rate(block)
        print("decode, 30 objects a frame in {:>4}-byte packets: {:,.0f} packets/s, "
              "{:,.0f} objects/s".format(block, packets, objects))
    for robots, block in ((5, 1024), (30, 1024), (30, 256)):
        latency(robots, block, args.seconds)
    print("load average at end: {:.2f} {:.2f} {:.2f}".format(*os.getloadavg()))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
