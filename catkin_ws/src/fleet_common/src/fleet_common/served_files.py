"""Files a remote peer may name: only inside the folders a process serves, regular files only,
opened without blocking.

A console asks the manager to `load` a plan. Its text may travel in the
request, or the console names a file in one of the folders the manager was
told to serve (`fleetctl manager --plans DIR`); maps named by `map_file=`
are found the same way in the served folders and the manager's map
folders. Nothing else on the manager's machine is reachable: `ServedFolders`
refuses, before opening anything, a name that is absolute, climbs out with
`..`, or is not text; opens the file with O_NONBLOCK | O_NOFOLLOW (a FIFO
or a device answers at once, and is refused by `fstat` as not a regular
file), checks where the opened file really is (a symlink leading out of the
served folder, even one swapped in meanwhile, is refused), and reads at
most `max_bytes`. A refusal (`NotServed`) names the file as the peer gave
it and says why, never what is in it.

Linux (the lab PC) tells where an open file is through /proc/self/fd; where
it cannot, the check before opening (the real path inside a served folder)
stands alone.
"""
from __future__ import annotations

import errno
import os
import stat
from pathlib import Path
from typing import List, Optional, Sequence, Tuple

from .errors import FleetError
from .limits import MAX_NAME_CHARS, excerpt

__all__ = ["ServedFolders", "NotServed", "MAX_SERVED_NAME"]

#: Longest name a peer may give (a path inside a served folder).
MAX_SERVED_NAME = 1024
_CHUNK = 1024 * 1024


class NotServed(FleetError):
    """A name a peer gave that this process will not open, and why (never the file's content)."""


class ServedFolders:
    """The folders whose regular files a peer may read by name (`roots`), `max_bytes` at most."""

    def __init__(self, roots: Sequence[Path], max_bytes: int, what: str = "file") -> None:
        self.roots: List[Path] = []
        for root in roots:
            try:
                real = Path(os.path.realpath(str(root)))
            except (OSError, ValueError):
                continue
            if real.is_dir() and real not in self.roots:
                self.roots.append(real)
        self.max_bytes = max_bytes
        self.what = what

    def read(self, name: str) -> Tuple[Path, str]:
        """The file `name` names in the first served folder that has it: (its real path, its text,
        undecodable bytes kept as surrogates). NotServed saying why not."""
        parts = self._parts(name)
        if not self.roots:
            raise NotServed("{} {}: this manager serves no folder of {}s (start it with --plans DIR); "
                            "send the file's content instead".format(self.what, excerpt(name), self.what))
        found = self._locate(parts, name)
        if found is None:
            raise NotServed("{} {}: no such {} in the served folders".format(self.what, excerpt(name), self.what))
        return found[0], self._read(found[0], found[1], name)

    def find(self, name: str) -> Optional[Tuple[Path, str]]:
        """`read` for a `map_file=` name: as written when it is a name inside a served folder,
        else by its last part; None when no served folder has it."""
        base = name.replace("\\", "/").rsplit("/", 1)[-1]
        for each in [name] + ([base] if base and base != name else []):
            try:
                parts = self._parts(each)
            except NotServed:
                continue
            found = self._locate(parts, each)
            if found is not None:
                return found[0], self._read(found[0], found[1], each)
        return None

    def _locate(self, parts: List[str], name: str) -> Optional[Tuple[Path, Path]]:
        """(real path, its served folder) of the first folder holding `parts`; None if none does."""
        for root in self.roots:
            path = root.joinpath(*parts)
            if not os.path.lexists(str(path)):
                continue
            real = Path(os.path.realpath(str(path)))
            if not _inside(real, root):
                raise NotServed("{} {}: leads out of the served folder; refused".format(self.what, excerpt(name)))
            return real, root
        return None

    def _parts(self, name: str) -> List[str]:
        if not isinstance(name, str) or not name or len(name) > MAX_SERVED_NAME:
            raise NotServed("{} name: expected a name of 1 to {} characters inside a served folder".format(
                self.what, MAX_SERVED_NAME))
        if "\x00" in name or any(not c.isprintable() for c in name):
            raise NotServed("{} {}: a name with control characters; refused".format(self.what, excerpt(name)))
        text = name.replace("\\", "/")
        if text.startswith("/") or (len(text) > 1 and text[1] == ":"):
            raise NotServed("{} {}: an absolute path; name a file inside a served folder".format(
                self.what, excerpt(name)))
        parts = [p for p in text.split("/") if p not in ("", ".")]
        if ".." in parts:
            raise NotServed("{} {}: '..' leads out of the served folder; refused".format(self.what, excerpt(name)))
        if not parts or any(len(p) > MAX_NAME_CHARS for p in parts):
            raise NotServed("{} {}: not a file name".format(self.what, excerpt(name)))
        return parts

    def _read(self, real: Path, root: Path, name: str) -> str:
        flags = os.O_RDONLY | os.O_NONBLOCK | getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_NOCTTY", 0)
        try:
            fd = os.open(str(real), flags)
        except OSError as err:
            why = "a symlink" if err.errno == errno.ELOOP else (err.strerror or "cannot be opened")
            raise NotServed("{} {}: {}; refused".format(self.what, excerpt(name), why)) from None
        try:
            info = os.fstat(fd)
            if not stat.S_ISREG(info.st_mode):
                raise NotServed("{} {}: not a regular file ({}); refused".format(
                    self.what, excerpt(name), _kind(info.st_mode)))
            opened = _opened_path(fd)
            if opened is not None and not _inside(opened, root):
                raise NotServed("{} {}: leads out of the served folder; refused".format(self.what, excerpt(name)))
            if info.st_size > self.max_bytes:
                raise NotServed("{} {}: {:,} bytes; a served {} may have at most {:,}".format(
                    self.what, excerpt(name), info.st_size, self.what, self.max_bytes))
            chunks, total = [], 0
            while True:
                try:
                    chunk = os.read(fd, _CHUNK)
                except BlockingIOError:
                    raise NotServed("{} {}: not ready to be read; refused".format(self.what, excerpt(name))) from None
                if not chunk:
                    break
                total += len(chunk)
                if total > self.max_bytes:
                    raise NotServed("{} {}: more than {:,} bytes; refused".format(
                        self.what, excerpt(name), self.max_bytes))
                chunks.append(chunk)
        except OSError as err:
            raise NotServed("{} {}: cannot be read: {}".format(self.what, excerpt(name), err.strerror)) from None
        finally:
            os.close(fd)
        return b"".join(chunks).decode("utf-8", "surrogateescape")


def _inside(path: Path, root: Path) -> bool:
    return path == root or root in path.parents


def _opened_path(fd: int) -> Optional[Path]:
    """Where the open file `fd` really is (Linux), None where that cannot be told."""
    try:
        return Path(os.readlink("/proc/self/fd/{}".format(fd)))
    except OSError:
        return None


def _kind(mode: int) -> str:
    for test, name in ((stat.S_ISDIR, "a folder"), (stat.S_ISFIFO, "a FIFO"), (stat.S_ISCHR, "a device"),
                       (stat.S_ISBLK, "a device"), (stat.S_ISSOCK, "a socket")):
        if test(mode):
            return name
    return "special"
