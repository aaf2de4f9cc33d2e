"""What a flooding console costs the manager: log lines, run-log growth, States per console.

Starts `fleetctl manager` on the lab plan (no robots unless --fleet: a virtual fleet of the
lab's five robots, connected and waiting) on 127.0.0.1, then one console sends --garbage
frames that are no console message and --refused requests the manager refuses
("disable 99999"), while another only watches (tests/floods.py). Prints how long the manager
took, the States each console got per second meanwhile (the manager's limit is 50), and
how much the manager's log and its run log grew.

    .venv/bin/python bench/floods.py [--garbage 10000] [--refused 10000] [--fleet]
"""
from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from fleet_common.lab import lab_instance_path  # noqa: E402
from floods import flood  # noqa: E402
from live import fleet_definitions, start_fleet, start_manager  # noqa: E402


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--garbage", type=int, default=10_000)
    parser.add_argument("--refused", type=int, default=10_000)
    parser.add_argument("--fleet", action="store_true", help="with the lab's five virtual robots connected")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory(prefix="fleet-floods-") as tmp:
        folder = Path(tmp)
        definitions, feedback, port = fleet_definitions(folder, 5)
        fleet = start_fleet(folder, definitions, feedback) if args.fleet else None
        manager = start_manager(folder, lab_instance_path(), definitions, port, "--log", folder / "runs",
                                "--log-level", "info")
        try:
            manager.wait_line(r"^manager: ")
            deadline = time.monotonic() + 30
            while not list((folder / "runs").glob("*/events.jsonl")):
                assert time.monotonic() < deadline, "no run folder"
                time.sleep(0.05)
            events = next((folder / "runs").glob("*/events.jsonl"))
            figures = flood(port, manager.log, events, args.garbage, args.refused)
        finally:
            manager.stop()
            if fleet is not None:
                fleet.stop()
        print("{:,} garbage frames, then {:,} refused requests from one console{}".format(
            args.garbage, args.refused, "; five robots connected" if args.fleet else "; no robots"))
        for line in figures.lines():
            print("  " + line)
    return 0


if __name__ == "__main__":
    sys.exit(main())
