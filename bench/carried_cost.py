"""What the manager's check for robots moved by hand costs (`fleet_manager.carried`).

The 300-robot arena (PIBT) on 300 in-memory robots (tests/memory_fleet.py), robots of the lab's
size: `carried(run)` timed while the run runs (most robots driving: judged in no time) and once
it is paused and every robot stands (each judged). The loop judges ten times a second
(`core.CARRIED_EVERY`), and a State's refusals once more at most every `ALLOWED_EVERY`.

    .venv/bin/python bench/carried_cost.py [CALLS]      # default 200 calls each
"""
from __future__ import annotations

import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))  # the in-memory fleet

from fleet_common.plan_loading import load_plan  # noqa: E402
from fleet_manager.carried import carried  # noqa: E402
from fleet_manager.settings import ManagerSettings  # noqa: E402
from memory_fleet import MemoryFleet, lab_fleet  # noqa: E402

SHARED = Path(__file__).resolve().parents[2] / "shared" / "data" / "mapf-ir"


def timed(run, calls: int) -> float:
    began = time.perf_counter()
    for _ in range(calls):
        carried(run)
    return (time.perf_counter() - began) / calls * 1e3


def main() -> int:
    calls = int(sys.argv[1]) if len(sys.argv) > 1 else 200
    loaded = load_plan(SHARED / "instances" / "arena_300agents_1.txt", 300, "fleet", [SHARED / "maps"], solver="pibt")
    f = MemoryFleet(loaded, lab_fleet(300), settings=ManagerSettings(step_time=0.5))
    ops = f.console()
    f.link_up()
    f.advance(0.5)
    assert f.ask(ops, "start").ok
    f.advance(3.0)
    run = f.core.run
    standing = sum(r.flight is None for r in run.fleet)
    print("running, {} of 300 standing: {:.3f} ms a call".format(standing, timed(run, calls)))
    assert f.ask(ops, "pause").ok
    f.run_until(lambda: not run.driver.moving, 10)
    f.advance(0.5)
    standing = sum(r.flight is None for r in run.fleet)
    print("paused, {} of 300 standing: {:.3f} ms a call ({} found moved)".format(
        standing, timed(run, calls), len(carried(run))))
    return 0


if __name__ == "__main__":
    sys.exit(main())
