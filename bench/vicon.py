"""Benchmark: the Vicon path, decoder throughput and UDP-to-pose latency on 127.0.0.1.

1. Decoding: `ViconStream.receive` on Tracker packets (30 objects a frame in
   256- and 1024-byte blocks), packets and objects per second.
2. Latency: a simulated Tracker in its own process (`run_tracker`, 100 Hz, 20 %
   packet loss, robots going round a circle) sends to the manager's
   `ViconProvider`, polled with zmq.Poller as the manager polls it. For every
   robot pose the provider returns: time returned - time Tracker began to send
   that frame (CLOCK_MONOTONIC is one clock for all processes on Linux).
   Prints p50 / p95 / p99 / max, and the receiver's CPU share.
3. Vicon-to-state: the same Tracker (robot 1 jumping between two cells about
   every 0.1 s, at random) streams to `fleetctl manager --vicon` (with `fleetctl virtual-fleet`
   for the robots); this process is a console that chose Vicon as the source.
   For every jump: the first state showing robot 1 on its new cell, received
   here, minus the time Tracker began sending the first frame with it. At
   several --state-rate settings (the state period bounds the latency).

    .venv/bin/python bench/vicon.py [--seconds 5] [--state-seconds 15]
"""
from __future__ import annotations

import argparse
import bisect
import itertools
import multiprocessing
import os
import random
import signal
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Dict, List, Tuple

import zmq

# a script here named like a package (bench/console.py) would shadow it: drop this folder
sys.path[:] = [p for p in sys.path if Path(p or ".").resolve() != Path(__file__).resolve().parent]

from fleet_common.control import messages as m  # noqa: E402 (after the sys.path fix)
from fleet_common.control.session import ConsoleSession
from fleet_common.lab import lab_instance_path, lab_transforms
from fleet_common.robots import parse_robot_definitions
from fleet_common.transport.console_channel import ConsoleClient
from fleet_common.vicon import ViconObject, ViconStream, encode_frame
from fleet_common.vicon.base_grid import vicon_to_base
from fleet_common.wire.messages import Pose
from fleet_manager.vicon_provider import ViconProvider
from virtual_fleet.truth_sources import CircleTruth
from virtual_fleet.vicon_tracker import TrackerSettings, TrackerSimulator, run_tracker

JUMP = 0.1             # s between robot 1's jumps in the Vicon-to-state case, on average
CELLS = (3.0, 5.0)     # the two cells (x) it jumps between, on row 6


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


class JumpTruth:
    """Robot 1 alternates between two cells, JUMP seconds apart on average (at random, so
    that the jumps do not lock to the manager's state period); the others stand still."""

    def __init__(self, names: List[str]) -> None:
        rng = random.Random(3)
        self.jumps = list(itertools.accumulate(rng.uniform(0.6 * JUMP, 1.4 * JUMP)
                                               for _ in range(100000)))
        self.names, self.t0, self.phase = names, time.monotonic(), 0

    def poses(self, now: float) -> Dict[str, Pose]:
        self.phase = bisect.bisect(self.jumps, now - self.t0)
        out = {n: Pose(1.0 + 2.0 * i, 1.0, 0.0) for i, n in enumerate(self.names)}
        out[self.names[0]] = Pose(CELLS[self.phase % 2], 6.0, 0.0)
        return out

    def close(self) -> None:
        pass


def jump_tracker(port: int, names: List[str], seconds: float,
                 out: "multiprocessing.Queue[Dict[int, float]]") -> None:
    sim = TrackerSimulator(TrackerSettings(rate=100.0, loss=0.2),
                           vicon_to_base(lab_transforms()).inverse(), seed=2)
    source = JumpTruth(names)
    first: Dict[int, float] = {}  # phase -> when its first frame began to go out
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    end = time.monotonic() + seconds
    run_tracker(sim, source, sock, ("127.0.0.1", port), lambda: time.monotonic() >= end,
                sent=lambda frame, when: first.setdefault(source.phase, when))
    sock.close()
    out.put(first)


def free_udp_tcp(n: int) -> List[int]:
    socks = [socket.socket() for _ in range(n)]
    for s in socks:
        s.bind(("127.0.0.1", 0))
    ports = [s.getsockname()[1] for s in socks]
    for s in socks:
        s.close()
    return ports


def vicon_to_state(state_rate: float, seconds: float) -> None:
    work = Path(tempfile.mkdtemp(prefix="vicon-bench-"))
    ports = free_udp_tcp(8)
    command, (feedback, udp, console) = ports[:5], ports[5:]
    defs = work / "robots.txt"
    defs.write_text("".join("{0} 127.0.0.1 {1} u turtlebot{0} red\n".format(i + 1, p)
                            for i, p in enumerate(command)))
    endpoint = "tcp://127.0.0.1:{}".format(console)
    fleetctl = [sys.executable, "-m", "fleetctl"]
    procs = [subprocess.Popen(fleetctl + args, stdout=subprocess.DEVNULL) for args in (
        ["virtual-fleet", "--definitions", str(defs), "--no-curve", "--feedback-base",
         str(feedback), "--log-level", "error"],
        ["manager", str(lab_instance_path()), "--definitions", str(defs), "--no-curve",
         "--no-log", "--bind", endpoint, "--vicon", str(udp), "--vicon-bind", "127.0.0.1",
         "--state-rate", str(state_rate), "--log-level", "error"])]
    context = zmq.Context()
    client = ConsoleClient(context, endpoint)
    session = ConsoleSession("bench", time.monotonic())
    seen: List[Tuple[float, int]] = []  # (when received, which cell robot 1 is on)
    results: "multiprocessing.Queue[Dict[int, float]]" = multiprocessing.Queue()
    tracker_proc = None
    try:
        deadline = time.monotonic() + 30.0
        while session.state is None and time.monotonic() < deadline:
            client.send(session.hello(time.monotonic()))
            time.sleep(0.2)
            for frame in client.receive():
                session.receive(frame, time.monotonic())
        client.send(session.request("source", time.monotonic(), source="vicon")[1])
        tracker_proc = multiprocessing.Process(target=jump_tracker, args=(
            udp, ["turtlebot{}".format(i) for i in range(1, 6)], seconds, results))
        tracker_proc.start()
        poller = zmq.Poller()
        poller.register(client.socket, zmq.POLLIN)
        while tracker_proc.is_alive():
            if poller.poll(100):
                for frame in client.receive():
                    now = time.monotonic()
                    message = session.receive(frame, now)
                    if isinstance(message, m.State):
                        one = next(r for r in message.robots if r.id == 1)
                        if one.source == "vicon" and one.x is not None and abs(one.y - 6.0) < 0.1:
                            seen.append((now, 0 if abs(one.x - CELLS[0]) < 0.1 else 1))
            beat = session.heartbeat(time.monotonic())
            if beat is not None:
                client.send(beat)
        first = results.get(timeout=10)
    finally:
        if tracker_proc is not None:
            tracker_proc.join(timeout=10)
        client.close()
        context.term()
        for proc in procs:
            proc.send_signal(signal.SIGINT)
            proc.wait(timeout=20)
    lat = []
    for (_, before), (when, cell) in zip(seen, seen[1:]):
        if cell != before:  # robot 1 moved in this state: the newest jump sent before it
            phase = max(k for k, t in first.items() if t <= when and k % 2 == cell)
            lat.append(1000.0 * (when - first[phase]))
    print("state rate {:>4g} Hz: {:>4} jumps, Vicon-to-state ms p50 {:.1f}  p95 {:.1f}  "
          "max {:.1f}".format(state_rate, len(lat), percentile(lat, 0.5), percentile(lat, 0.95),
                              max(lat)))


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=5.0)
    parser.add_argument("--state-seconds", type=float, default=15.0)
    args = parser.parse_args()
    print("load average at start: {:.2f} {:.2f} {:.2f}".format(*os.getloadavg()))
    for block in (256, 1024):
        packets, objects = decode_rate(block)
        print("decode, 30 objects a frame in {:>4}-byte packets: {:,.0f} packets/s, "
              "{:,.0f} objects/s".format(block, packets, objects))
    for robots, block in ((5, 1024), (30, 1024), (30, 256)):
        latency(robots, block, args.seconds)
    for rate in (20.0, 50.0, 100.0):
        vicon_to_state(rate, args.state_seconds)
    print("load average at end: {:.2f} {:.2f} {:.2f}".format(*os.getloadavg()))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
