"""A large instance of a MovingAI map: random starts and goals on its largest connected part.

Starts are distinct free cells drawn at random (seeded); each goal is a distinct free cell
drawn among those at most --radius moves from its start (by breadth-first search), or
anywhere on the part without --radius. Written in mapf-IR's instance format, beside a copy
of the map, so that `fleetctl`, the plan player and mapf-IR's `app` all read it.

    .venv/bin/python bench/make_instance.py den520d.map 1000 OUT.txt [--radius 40] [--seed 0]
"""
from __future__ import annotations

import argparse
import random
import shutil
from collections import deque
from pathlib import Path
from typing import List, Optional

import numpy as np

from fleet_common.formats.instance import make_instance, write_instance
from fleet_common.formats.mapfile import read_map
from fleet_common.planning.components import component_labels

SHARED = Path(__file__).resolve().parents[2] / "shared" / "data" / "mapf-ir"


def random_instance(map_path: Path, agents: int, out: Path, radius: Optional[int] = None, seed: int = 0) -> Path:
    """Write the instance (and the map beside it, unless it is there); returns `out`."""
    grid = read_map(str(map_path)).grid
    labels = component_labels(grid)
    free = labels >= 0
    biggest = np.bincount(labels[free]).argmax()
    cells = np.nonzero(labels == biggest)[0].tolist()
    if agents > len(cells):
        raise SystemExit("{} has {} cells in its largest part, fewer than {} agents".format(
            map_path.name, len(cells), agents))
    rng = random.Random(seed)
    starts = rng.sample(cells, agents)
    if radius is None:  # anywhere on the part: a second draw of distinct cells
        goals = rng.sample(cells, agents)
    else:
        taken = set()
        goals = []
        adjacency = grid.adjacency()
        for s in starts:
            choices = [c for c in _within(adjacency, s, radius) if c not in taken]
            if not choices:
                raise SystemExit("no free goal within {} moves of {}; use a larger --radius".format(radius, s))
            goals.append(rng.choice(choices))
            taken.add(goals[-1])
    coord = grid.coord
    inst = make_instance(grid, map_path.name, [coord(c) for c in starts], [coord(c) for c in goals])
    write_instance(inst, str(out))
    if not (out.parent / map_path.name).exists():
        shutil.copy(str(map_path), str(out.parent / map_path.name))
    return out


def _within(adjacency: List[List[int]], start: int, radius: int) -> List[int]:
    seen = {start: 0}
    todo = deque([start])
    while todo:
        c = todo.popleft()
        if seen[c] == radius:
            continue
        for v in adjacency[c]:
            if v not in seen:
                seen[v] = seen[c] + 1
                todo.append(v)
    return [c for c, d in seen.items() if d > 0]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("map", help="a map file, or a map name of ../shared/data/mapf-ir/maps")
    parser.add_argument("agents", type=int)
    parser.add_argument("out", type=Path)
    parser.add_argument("--radius", type=int, default=None, help="goals at most this many moves from starts")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    path = Path(args.map)
    if not path.is_file():
        path = SHARED / "maps" / args.map
    random_instance(path, args.agents, args.out, args.radius, args.seed)
    print(args.out)


if __name__ == "__main__":
    main()

