"""Where a `map_file=` line finds its map.

mapf-IR opens `map_file` relative to a folder fixed at compile time, so its
files name maps by bare file name (`map_file=arena.map`). We look in the
referring file's own folder first, then in a list of map folders: the
`FLEETCONTROL_MAP_PATH` folders, the shared mapf-IR maps beside a source
checkout, and the lab map shipped with the package. A name with folders is
tried as written and by its basename.
"""
from __future__ import annotations

import os
from pathlib import Path
from typing import List, Optional, Sequence

from ..errors import MapNotFoundError
from ..grid import Grid
from .mapfile import read_map

#: Environment variable: extra map folders, `os.pathsep`-separated, searched first.
MAP_PATH_ENV = "FLEETCONTROL_MAP_PATH"

_PACKAGE_DIR = Path(__file__).resolve().parent.parent


def _checkout_root() -> Optional[Path]:
    """The folder holding `catkin_ws` when running from a source tree, else None."""
    for parent in _PACKAGE_DIR.parents:
        if parent.name == "catkin_ws":
            return parent.parent
    return None


def default_map_dirs() -> List[Path]:
    """Map folders to search, in order (existing or not, except the checkout's)."""
    dirs: List[Path] = []
    for entry in os.environ.get(MAP_PATH_ENV, "").split(os.pathsep):
        if entry:
            dirs.append(Path(entry))
    root = _checkout_root()
    if root is not None:
        shared = root.parent / "shared" / "data" / "mapf-ir" / "maps"
        if shared.is_dir():
            dirs.append(shared)
    dirs.append(_PACKAGE_DIR / "lab")
    return dirs


def resolve_map(map_file: str, relative_to: Optional[Path], map_dirs: Sequence[Path]) -> Path:
    """The path of `map_file`, or MapNotFoundError listing every folder looked in.

    `relative_to` is the folder of the file that names the map (None for text
    without a file). The caller adds its own path and line to the error.
    """
    name = Path(map_file)
    folders: List[Path] = []
    if relative_to is not None:
        folders.append(Path(relative_to))
    folders.extend(Path(d) for d in map_dirs)

    if name.is_absolute():
        if name.is_file():
            return name
        looked = [str(name.parent)]
    else:
        looked = []
    tries = [name] if not name.is_absolute() else []
    if name.name != str(name):
        tries.append(Path(name.name))
    for folder in folders:
        for t in tries:
            candidate = folder / t
            if candidate.is_file():
                return candidate
        if str(folder) not in looked:
            looked.append(str(folder))
    raise MapNotFoundError(
        "map_file '{}' not found; looked in: {}".format(map_file, ", ".join(looked) or "(no folders)")
    )


def load_map_grid(map_file: str, path: Optional[str], map_dirs: Optional[Sequence[Path]],
                  line: Optional[int]) -> Grid:
    """The grid named by `map_file=` on `line` of the file at `path` (None: default dirs)."""
    dirs = default_map_dirs() if map_dirs is None else map_dirs
    try:
        found = resolve_map(map_file, Path(path).parent if path else None, dirs)
    except MapNotFoundError as err:
        raise MapNotFoundError(err.message, path, line) from None
    return read_map(str(found)).grid
