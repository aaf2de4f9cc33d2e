"""File formats FleetControl reads and writes, mapf-IR's first.

- `mapfile`: MovingAI `.map` grids (mapf-IR's and the strict MovingAI rule)
- `instance`: mapf-IR instance files (map, agents, starts and goals)
- `solution`: mapf-IR solution files (solver output, plans)
- `scen`: MovingAI `.scen` scenarios, convertible to instances
- `header`: the `key=value` header lines and line plumbing they share
- `lines`: a file's lines one at a time, within the limits (fleet_common.limits)
- `mapsearch`: where a `map_file=` name is looked for

Readers return base-frame coordinates (origin bottom-left, y up) and flip
mapf-IR's top-left frame on the way in; writers flip back, so a file read and
written unchanged keeps its bytes. A file may instead be written in the base
frame, marked by the header line `orientation=base`.
"""
from __future__ import annotations

from .header import BASE, MAPF_IR, Header, HeaderEntry
from .instance import Instance, format_instance, make_instance, parse_instance, read_instance, \
    write_instance
from .mapfile import MapFile, format_map, map_from_grid, parse_map, read_map, write_map
from .mapsearch import default_map_dirs, resolve_map
from .scen import Scen, ScenEntry, parse_scen, read_scen, scen_to_instance
from .solution import Solution, format_solution, make_solution, parse_solution, read_solution, \
    write_solution

__all__ = [
    "BASE", "MAPF_IR", "Header", "HeaderEntry",
    "Instance", "format_instance", "make_instance", "parse_instance", "read_instance",
    "write_instance",
    "MapFile", "format_map", "map_from_grid", "parse_map", "read_map", "write_map",
    "default_map_dirs", "resolve_map",
    "Scen", "ScenEntry", "parse_scen", "read_scen", "scen_to_instance",
    "Solution", "format_solution", "make_solution", "parse_solution", "read_solution",
    "write_solution",
]
