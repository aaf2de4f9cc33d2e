"""Installs the mapf-IR stand-in (`app.py`) the way a mapf-IR build is laid out.

`install(root)` makes `root/mapf-IR/build/app` (executable, run by this
Python) and `root/mapf-IR/map/`, the folder the stand-in opens `map_file=`
from, and copies the given maps there.
"""
from __future__ import annotations

import shutil
import stat
import sys
from pathlib import Path
from typing import Iterable

SCRIPT = Path(__file__).resolve().parent / "app.py"


def install(root: Path, maps: Iterable[Path] = ()) -> Path:
    """The path of the installed `app`; its map folder is `app.parent.parent / "map"`."""
    build = root / "mapf-IR" / "build"
    map_dir = root / "mapf-IR" / "map"
    build.mkdir(parents=True, exist_ok=True)
    map_dir.mkdir(parents=True, exist_ok=True)
    app = build / "app"
    app.write_text("#!{}\n{}".format(sys.executable, SCRIPT.read_text(encoding="utf-8")), encoding="utf-8")
    app.chmod(app.stat().st_mode | stat.S_IXUSR | stat.S_IXGRP | stat.S_IXOTH)
    for m in maps:
        shutil.copy(str(m), str(map_dir / Path(m).name))
    return app
