"""Benchmark: a 300-robot virtual fleet and one manager process, over TCP with CURVE.

Starts `fleetctl virtual-fleet` (one process, one event loop) on generated
definitions, connects one RobotLink per robot from this process (one LinkSet
loop), and for --seconds keeps every robot driving round a 1-cell square
(a drive is sent as soon as the last one completes) while asking each for
its status once a second. Prints the command round trip (drive sent ->
Accepted received; GetStatus sent -> Status received) as median and 99th
percentile, how long the fleet took to connect, pose feedback received, and
CPU use of each process (share of one core, from /proc and process_time).

    .venv/bin/python bench/virtual_fleet.py [--robots 300] [--seconds 20] [--time-scale 1]
"""
from __future__ import annotations

import argparse
import os
import signal
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Dict, List

import zmq

from fleet_common.robots import read_robot_definitions
from fleetctl.local_fleet import free_port_block
from fleet_common.wire import Accepted, Completed, Failed, PoseFeedback, Status
from fleet_common.transport.curve_keys import load_manager_keys, make_keys
from fleet_common.transport.links import LinkSet
from fleet_common.transport.robot_link import LinkUp, RobotLink, RobotReply

SQUARE = [(1, 0), (1, 1), (0, 1), (0, 0)]  # corners relative to the robot's start cell


def percentile(values: List[float], q: float) -> float:
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, int(q * len(ordered)))]


def cpu_seconds(pid: int) -> float:
    fields = Path("/proc/{}/stat".format(pid)).read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robots", type=int, default=300)
    parser.add_argument("--seconds", type=float, default=20.0)
    parser.add_argument("--time-scale", type=float, default=1.0)
    args = parser.parse_args()

    work = Path(tempfile.mkdtemp(prefix="fleet-bench-"))
    make_keys(work / "keys")
    command_base = free_port_block(2 * args.robots)
    feedback_base = command_base + args.robots
    (work / "robots.txt").write_text("".join(
        "{} 127.0.0.1 {} u tb{} red\n".format(i, command_base + i - 1, i)
        for i in range(1, args.robots + 1)))
    robots = read_robot_definitions(work / "robots.txt")
    fleet = subprocess.Popen(
        [sys.executable, "-m", "fleetctl", "virtual-fleet", "--definitions",
         str(work / "robots.txt"), "--keys", str(work / "keys"), "--time-scale",
         str(args.time_scale), "--feedback-base", str(feedback_base), "--log-level", "warning"],
        stdout=subprocess.PIPE, text=True)
    context = zmq.Context()
    links = None
    try:
        print(fleet.stdout.readline().strip())
        t0 = time.monotonic()
        links = LinkSet([RobotLink(context, r, "bench", keys=load_manager_keys(work / "keys"))
                         for r in robots])
        up = set()
        while len(up) < len(robots):
            up |= {e.robot_id for e in links.poll(0.05) if isinstance(e, LinkUp)}
            if time.monotonic() - t0 > 60:
                raise SystemExit("only {} of {} robots connected in 60 s".format(len(up), len(robots)))
        connect_s = time.monotonic() - t0

        sent: Dict[tuple, float] = {}   # (robot, command id) -> send time
        corner = {r.id: 0 for r in robots}
        start = {r.id: (float((r.id - 1) % 32), float((r.id - 1) // 32)) for r in robots}
        next_status = {r.id: time.monotonic() + (r.id % 100) / 100.0 for r in robots}
        drive_rtt: List[float] = []
        status_rtt: List[float] = []
        completed = failed = poses = 0

        def drive(rid: int) -> None:
            dx, dy = SQUARE[corner[rid] % 4]
            corner[rid] += 1
            sx, sy = start[rid]
            sent[(rid, links[rid].drive_to_position(sx + dx, sy + dy, 0.0))] = time.monotonic()

        fleet_cpu0, own_cpu0, t_start = cpu_seconds(fleet.pid), time.process_time(), time.monotonic()
        for r in robots:
            drive(r.id)
        while time.monotonic() - t_start < args.seconds:
            for ev in links.poll(0.02):
                now = time.monotonic()
                if isinstance(ev, PoseFeedback):
                    poses += 1
                    continue
                if not isinstance(ev, RobotReply):
                    continue
                reply, key = ev.reply, (ev.robot_id, ev.reply.id)
                if isinstance(reply, Accepted) and key in sent:
                    drive_rtt.append(now - sent[key])
                elif isinstance(reply, Status) and key in sent:
                    status_rtt.append(now - sent.pop(key))
                elif isinstance(reply, (Completed, Failed)):
                    sent.pop(key, None)
                    completed += isinstance(reply, Completed)
                    failed += isinstance(reply, Failed)
                    drive(ev.robot_id)
            now = time.monotonic()
            for rid, due in next_status.items():
                if now >= due:
                    next_status[rid] = due + 1.0
                    sent[(rid, links[rid].get_status())] = now
        elapsed = time.monotonic() - t_start
        fleet_cpu = (cpu_seconds(fleet.pid) - fleet_cpu0) / elapsed
        own_cpu = (time.process_time() - own_cpu0) / elapsed
    finally:
        if links is not None:
            links.close()
        context.destroy(linger=0)
        fleet.send_signal(signal.SIGINT)
        try:
            fleet.wait(timeout=20)
        except subprocess.TimeoutExpired:
            fleet.kill()
            fleet.wait()

    ms = 1000.0
    print("robots {}, time scale {:g}, measured {:.1f} s; all connected (CURVE) in {:.2f} s".format(
        len(robots), args.time_scale, elapsed, connect_s))
    print("drives: {} completed, {} failed, {:.0f}/s".format(completed, failed, completed / elapsed))
    print("drive sent -> Accepted: median {:.2f} ms, p99 {:.2f} ms over {}".format(
        statistics.median(drive_rtt) * ms, percentile(drive_rtt, 0.99) * ms, len(drive_rtt)))
    print("  its quantiles 0/10/25/50/75/90/100 % (ms): {}".format(" ".join(
        "{:.1f}".format(percentile(drive_rtt, q) * ms) for q in (0, .1, .25, .5, .75, .9, 1))))
    print("GetStatus -> Status:    median {:.2f} ms, p99 {:.2f} ms over {}".format(
        statistics.median(status_rtt) * ms, percentile(status_rtt, 0.99) * ms, len(status_rtt)))
    print("pose feedback received: {:.0f}/s ({:.1f} Hz per robot)".format(
        poses / elapsed, poses / elapsed / len(robots)))
    print("CPU (share of one core): fleet process {:.0f}%, manager process {:.0f}%".format(
        fleet_cpu * 100, own_cpu * 100))
    return 0


if __name__ == "__main__":
    sys.exit(main())
