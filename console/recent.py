"""The files a console opened last, newest first: File -> Open recent.

Kept in `$XDG_CONFIG_HOME/fleetcontrol/recent-files.txt` (else
`~/.config/fleetcontrol/...`), one path a line, with the kind it was opened
as ("plan" or "instance"). A list that cannot be read or written is no
reason to stop: the console then keeps it for this session only.
"""
from __future__ import annotations

import os
from pathlib import Path
from typing import List, Optional, Tuple

__all__ = ["RecentFiles", "default_recent_path"]

#: Files the menu offers.
KEEP = 8


def default_recent_path() -> Path:
    base = os.environ.get("XDG_CONFIG_HOME") or str(Path.home() / ".config")
    return Path(base) / "fleetcontrol" / "recent-files.txt"


class RecentFiles:
    """(kind, path) pairs, newest first; `path` None keeps them in memory only."""

    def __init__(self, path: Optional[Path] = None) -> None:
        self.path = path
        self.entries: List[Tuple[str, Path]] = []
        if path is not None:
            try:
                lines = path.read_text(encoding="utf-8").splitlines()
            except (OSError, UnicodeDecodeError):
                lines = []
            for line in lines:
                kind, _, name = line.partition(" ")
                if kind in ("plan", "instance") and name:
                    self.entries.append((kind, Path(name)))
            self.entries = self.entries[:KEEP]

    def add(self, kind: str, path: Path) -> None:
        path = Path(os.path.abspath(str(path)))
        self.entries = [(kind, path)] + [e for e in self.entries if e[1] != path][:KEEP - 1]
        if self.path is None:
            return
        try:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            self.path.write_text("".join("{} {}\n".format(k, p) for k, p in self.entries), encoding="utf-8")
        except OSError:
            self.path = None  # read-only home: this session only
