"""The bash building blocks of every remote step: a Step, a path as one word, entering the checkout."""
from __future__ import annotations

import shlex
from dataclasses import dataclass

from .targets import Target

__all__ = ["Step", "shell_path", "side", "enter"]


@dataclass(frozen=True)
class Step:
    title: str
    script: str
    stdin: bytes = b""
    stdin_name: str = ""   # what the stdin bytes are, for --dry-run (never the bytes)


def shell_path(path: str) -> str:
    """`path` as one bash word; a leading `~` becomes the target's $HOME."""
    if path == "~":
        return '"$HOME"'
    if path.startswith("~/"):
        return '"$HOME"/' + shlex.quote(path[2:])
    return shlex.quote(path)


def side(target: Target) -> str:
    return "server" if target.robot_id is None else "robots"


def enter(target: Target) -> str:
    """cd into the checkout, or stop with a message saying what to run first."""
    return ('cd {0} 2>/dev/null && [ -d .git ] || {{ echo "no checkout at {1}: run '
            '{2}:init first"; exit 1; }}\n').format(
                shell_path(target.path), target.path, side(target))
