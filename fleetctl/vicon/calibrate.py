"""`fleetctl vicon calibrate`: fit vicon -> base, show how well it fits, write it or refuse."""
from __future__ import annotations

import argparse
import datetime
import math
import re
from pathlib import Path
from typing import Dict, List, Tuple

from fleet_common.errors import FleetError, TransformError
from fleet_common.frames import write_transform
from fleet_common.vicon.base_grid import VICON_TRANSFORM
from fleet_common.vicon.calibration import (Calibration, Correspondence, calibrate,
                                            format_correspondences, read_correspondences)

from ..options import start_poses
from . import fleet, frames_path, open_provider, robot_named, stop_on_signals, watch

#: A robot must be seen in this many frames to be measured.
MIN_SAMPLES = 5


def calibrate_command(args: argparse.Namespace) -> int:
    pairs = read_correspondences(args.pairs) if args.pairs else measure(args)
    try:
        result = calibrate(pairs)
    except TransformError as err:  # too few or unusable points: say where they came from
        if args.pairs is None:
            raise FleetError("calibrate --live: {}".format(err.message)) from None
        raise err.with_path(str(args.pairs)) if err.path is None else err
    print_fit(result)
    target = frames_path(args)
    if result.rms_cm > args.max_rms:
        worst = result.worst()
        print("refused: RMS {:.2f} cm is above {:g} cm; the worst point is {} ({:.1f} cm): a "
              "robot on another cell than given?  {} unchanged".format(
                  result.rms_cm, args.max_rms, worst.describe(), max(result.residuals_cm),
                  target))
        return 1
    if args.dry_run:
        print("dry run: {} unchanged".format(target))
        return 0
    note = "fitted by fleetctl vicon calibrate on {}: {} points, RMS {:.2f} cm".format(
        datetime.date.today().isoformat(), len(pairs), result.rms_cm)
    write_transform(target, VICON_TRANSFORM, result.transform, note)
    print("wrote {} into {}".format(VICON_TRANSFORM, target))
    return 0


def print_fit(result: Calibration) -> None:
    print("{:<20} {:>14} {:>22} {:>12}".format("point", "cell", "vicon (mm)", "residual"))
    for pair, residual in zip(result.pairs, result.residuals_cm):
        print("{:<20} {:>14} {:>22} {:>9.2f} cm".format(
            pair.describe()[:20], "({:g}, {:g})".format(*pair.cell),
            "({:.1f}, {:.1f})".format(*pair.vicon), residual))
    print("RMS {:.2f} cm over {} points; {:.1f} mm per cell, rotated {:.2f} degrees".format(
        result.rms_cm, len(result.pairs), result.mm_per_cell, result.rotation_deg))


def _cells(args: argparse.Namespace, robots: list) -> Dict[str, Tuple[float, float]]:
    """Vicon name -> the base cell that robot stands on."""
    if args.at:
        out = {}
        for text in args.at:
            m = re.fullmatch(r"([^=]+)=(-?[\d.]+),(-?[\d.]+)", text.strip())
            if not m:
                raise FleetError("--at {!r}: expected ROBOT=X,Y (e.g. 3=4,5)".format(text))
            out[robot_named(robots, m.group(1)).vicon_name] = (float(m.group(2)),
                                                               float(m.group(3)))
        return out
    poses = start_poses(args.instance, robots)
    if poses is None:
        raise FleetError("the lab instance has fewer agents than the {} robots: say where "
                         "they stand with --at or --instance".format(len(robots)))
    return {r.vicon_name: (poses[r.id].x, poses[r.id].y) for r in robots}


def measure(args: argparse.Namespace) -> List[Correspondence]:
    """Average where Vicon sees each robot over --for seconds; with --record, all pairs."""
    robots = fleet(args)
    cells = _cells(args, robots)
    provider = open_provider(args, robots)
    samples: Dict[str, List[Tuple[float, float]]] = {name: [] for name in cells}

    def take(fixes: list) -> None:
        for fix in fixes:
            if fix.name in samples:
                samples[fix.name].append(provider.stream.sightings[fix.name].obj.translation[:2])
    try:
        watch(provider, args.seconds, stop_on_signals(), take)
    finally:
        provider.close()
    pairs = []
    for name, cell in cells.items():
        seen = samples[name]
        if len(seen) < MIN_SAMPLES:
            print("{}: seen in {} frames, left out (is it on the floor, in view?)".format(
                name, len(seen)))
            continue
        mx = sum(p[0] for p in seen) / len(seen)
        my = sum(p[1] for p in seen) / len(seen)
        spread = math.sqrt(sum((p[0] - mx) ** 2 + (p[1] - my) ** 2 for p in seen) / len(seen))
        if spread / 10.0 > args.max_rms:
            print("{}: moved during the measurement ({:.1f} cm spread), left out".format(
                name, spread / 10.0))
            continue
        print("{} on ({:g}, {:g}): {} frames at ({:.1f}, {:.1f}) mm, spread {:.2f} cm".format(
            name, cell[0], cell[1], len(seen), mx, my, spread / 10.0))
        pairs.append(Correspondence(cell, (mx, my), name))
    if args.record is not None:
        pairs = _record(args.record, pairs)
    return pairs


def _record(path: Path, new: List[Correspondence]) -> List[Correspondence]:
    earlier = read_correspondences(path) if path.exists() else []
    everything = earlier + new
    path.write_text(format_correspondences(everything), encoding="utf-8")
    print("recorded {} pairs in {} ({} in all)".format(len(new), path, len(everything)))
    return everything
