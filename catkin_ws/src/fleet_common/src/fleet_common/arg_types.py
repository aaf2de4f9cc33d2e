"""argparse types for numbers, and the parser they are used with: a bad value is the parser's
one-line error naming the option, never a traceback from deep inside, nor a run with a value nobody
meant (NaN and infinity are not numbers a user types on purpose). Shared by fleetctl, the
manager's own command line and deployment's.
"""
from __future__ import annotations

import argparse
import math
from typing import Callable, NoReturn, Optional

__all__ = ["Parser", "number", "positive", "non_negative", "at_least_one", "integer", "seed", "count", "port",
           "robot_size", "ROBOT_SIZE_HELP", "endpoint", "tcp_endpoint"]


class Parser(argparse.ArgumentParser):
    """An ArgumentParser whose command-line errors are one line on stderr, exit status 2.

    argparse prints its usage block before the error, two lines or more that every other error of
    ours does not have; the usage stays one `-h` away, and the line says so. A command's
    subparsers are of this class too (argparse makes them of their parent's class).
    """

    #: whose `--help` the line points to (default: this parser's prog); argparse reports an unknown
    #: option from the top-level parser, so fleetctl names the command that was chosen here
    see: Optional[str] = None

    def error(self, message: str) -> NoReturn:
        self.exit(2, "{}: error: {} (see {} --help)\n".format(
            self.prog, " ".join(message.split()), self.see or self.prog))


def number(text: str, ok: Callable[[float], bool], expected: str) -> float:
    """argparse type helper: a finite number for which `ok` holds."""
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not (math.isfinite(value) and ok(value)):
        raise argparse.ArgumentTypeError("expected {}, got {!r}".format(expected, text))
    return value


def positive(text: str) -> float:
    """argparse type: a number > 0."""
    return number(text, lambda v: v > 0, "a positive number")


def non_negative(text: str) -> float:
    """argparse type: a number >= 0."""
    return number(text, lambda v: v >= 0, "a number >= 0")


def at_least_one(text: str) -> float:
    """argparse type: a number >= 1 (a suboptimality bound)."""
    return number(text, lambda v: v >= 1, "a number >= 1")


def integer(text: str, low: int, high: Optional[int], expected: str) -> int:
    """argparse type helper: an integer in low..high (high None: no upper bound)."""
    try:
        value = int(text)
    except ValueError:
        value = low - 1
    if value < low or (high is not None and value > high):
        raise argparse.ArgumentTypeError("expected {}, got {!r}".format(expected, text))
    return value


def seed(text: str) -> int:
    """argparse type: a random seed, an integer >= 0."""
    return integer(text, 0, None, "a seed, an integer >= 0")


def count(text: str) -> int:
    """argparse type: an integer >= 1."""
    return integer(text, 1, None, "an integer >= 1")


def port(text: str) -> int:
    """argparse type: a TCP or UDP port."""
    return integer(text, 1, 65535, "a port 1-65535")


def tcp_endpoint(text: str) -> str:
    """`tcp://HOST:PORT` from `tcp://HOST:PORT` or `HOST:PORT` (ValueError saying what was expected)."""
    value = text.strip()
    rest = value[len("tcp://"):] if value.startswith("tcp://") else value
    host, sep, number_text = rest.rpartition(":")
    host = host[1:-1] if host.startswith("[") and host.endswith("]") else host
    if "://" in rest or not sep or not host or any(c.isspace() for c in host) or "/" in host \
            or not number_text.isdigit() or not 1 <= int(number_text) <= 65535:
        raise ValueError("expected HOST:PORT or tcp://HOST:PORT (a port 1-65535), got {!r}".format(text))
    return "tcp://{}:{}".format(rest.rpartition(":")[0], int(number_text))


def endpoint(text: str) -> str:
    """argparse type: a ZeroMQ TCP endpoint, with or without tcp://."""
    try:
        return tcp_endpoint(text)
    except ValueError as err:
        raise argparse.ArgumentTypeError(str(err)) from None


ROBOT_SIZE_HELP = ("the robots' size: DIAMETER:MARGIN in metres (0.354:0.1 is a TurtleBot 2), or 'cell' "
                   "for robots as large as a cell (the cell rule alone; nobody follows into a cell "
                   "being left); default: the size line of the robot definitions, else a TurtleBot 2")


def robot_size(text: str) -> "RobotSize":  # noqa: F821
    """argparse type: `cell` or DIAMETER:MARGIN (metres), on the lab's 0.7 m cells."""
    from .robot_size import RobotSize, cell_sized

    if text.strip() == "cell":
        return cell_sized()
    parts = text.split(":")
    try:
        diameter, margin = float(parts[0]), float(parts[1]) if len(parts) == 2 else math.nan
    except ValueError:
        diameter = margin = math.nan
    if len(parts) != 2 or not (0 < diameter < 100 and 0 <= margin < 100):
        raise argparse.ArgumentTypeError(
            "expected DIAMETER:MARGIN in metres (e.g. 0.354:0.1) or 'cell', got {!r}".format(text))
    return RobotSize(diameter, margin)
