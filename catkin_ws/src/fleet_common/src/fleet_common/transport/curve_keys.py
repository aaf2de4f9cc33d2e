"""CurveZMQ key files: who may drive the robots.

`fleetctl keys` makes two key pairs in one folder, as ZeroMQ certificate
files (`NAME.key` holds the public key, `NAME.key_secret` both; Z85 text):

    manager.key  manager.key_secret   the lab's manager (the only client robots obey)
    robot.key    robot.key_secret     every robot (one pair for the fleet)
    console.key  console.key_secret   operator consoles (the only clients the manager obeys)

A robot needs `robot.key_secret` and `manager.key`; the manager needs
`manager.key_secret`, `robot.key` and `console.key`; a console needs
`console.key_secret` and `manager.key`. The folder is $FLEETCONTROL_KEYS, else
$XDG_CONFIG_HOME/fleetcontrol/keys (~/.config/fleetcontrol/keys); secret files
are made readable by their owner only, and a secret file that group or others
may read is refused with the `chmod` that fixes it (as OpenSSH refuses such
a private key). Keys never go into the repository.
"""
from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path
from typing import List, Optional, Tuple, Union

import zmq
import zmq.auth
from zmq.utils import z85

from ..errors import FleetError

__all__ = ["RobotKeys", "ManagerKeys", "ConsoleKeys", "default_keys_dir", "make_keys",
           "load_robot_keys", "load_manager_keys", "load_console_keys", "KEY_NAMES"]

ENV_VAR = "FLEETCONTROL_KEYS"
KEY_NAMES = ("manager", "robot", "console")


@dataclass(frozen=True)
class RobotKeys:
    """What a robot needs: its key pair and the one manager key it obeys (Z85 bytes)."""

    public: bytes
    secret: bytes
    manager_public: bytes


@dataclass(frozen=True)
class ManagerKeys:
    """What the manager needs: its key pair, the robots' public key and the consoles'
    (Z85 bytes; `console_public` is None in a key folder made before consoles had keys)."""

    public: bytes
    secret: bytes
    robot_public: bytes
    console_public: Optional[bytes] = None


@dataclass(frozen=True)
class ConsoleKeys:
    """What an operator console needs: its key pair and the manager's public key."""

    public: bytes
    secret: bytes
    manager_public: bytes


def default_keys_dir() -> Path:
    env = os.environ.get(ENV_VAR)
    if env:
        return Path(env)
    config = os.environ.get("XDG_CONFIG_HOME") or str(Path.home() / ".config")
    return Path(config) / "fleetcontrol" / "keys"


def make_keys(folder: Union[str, Path, None] = None, force: bool = False) -> List[Path]:
    """Create the key pairs in `folder`; the files written. Existing pairs are kept
    unless `force` (replacing them locks out every robot until it gets the new ones);
    pairs missing from an older folder (the console's) are added."""
    folder = Path(folder) if folder is not None else default_keys_dir()
    have = [n for n in KEY_NAMES if (folder / (n + ".key")).exists()
            or (folder / (n + ".key_secret")).exists()]
    if have and not force and len(have) == len(KEY_NAMES):
        raise FleetError("{} already has keys ({}); use --force to replace them (robots then "
                         "need the new robot.key_secret and manager.key)".format(
                             folder, ", ".join(n + ".key" for n in have)))
    folder.mkdir(parents=True, exist_ok=True)
    os.chmod(folder, 0o700)
    written: List[Path] = []
    for name in KEY_NAMES:
        if name in have and not force:
            continue
        public, secret = zmq.auth.create_certificates(str(folder), name)
        os.chmod(secret, 0o600)
        written += [Path(public), Path(secret)]
    return written


def _load(folder: Path, name: str, secret: bool) -> Tuple[bytes, Optional[bytes]]:
    path = folder / (name + (".key_secret" if secret else ".key"))
    if not path.is_file():
        raise FleetError("{} not found: make the keys with `fleetctl keys --dir {}` (or set "
                         "${})".format(path, folder, ENV_VAR))
    if secret:
        check_private(path)
    try:
        public, secret_key = zmq.auth.load_certificate(str(path))
    except (OSError, ValueError) as err:
        raise FleetError("{}: not a ZeroMQ certificate: {}".format(path, err)) from err
    for what, key in (("public", public), ("secret", secret_key)):
        if key is None and (what == "public" or secret):
            raise FleetError("{}: no {}-key line".format(path, what))
        if key is not None and not _valid_z85_key(key):
            raise FleetError("{}: the {} key is not a 40-character Z85 CURVE key".format(path, what))
    return public, secret_key


def check_private(path: Path) -> None:
    """FleetError if the secret key file `path` may be read by its group or by others: whoever
    reads it can drive the robots (or pose as the manager to consoles)."""
    try:
        mode = os.stat(str(path)).st_mode
    except OSError as err:
        raise FleetError("{}: cannot read: {}".format(path, err.strerror)) from err
    if mode & 0o077:
        raise FleetError("{} may be read by others (mode {:04o}): a secret key must be its owner's "
                         "alone; run `chmod 600 {}`".format(path, mode & 0o7777, path))


def _valid_z85_key(key: bytes) -> bool:
    try:
        return len(key) == 40 and len(z85.decode(key)) == 32
    except (ValueError, KeyError, TypeError):
        return False


def load_robot_keys(folder: Union[str, Path, None] = None) -> RobotKeys:
    folder = Path(folder) if folder is not None else default_keys_dir()
    public, secret = _load(folder, "robot", secret=True)
    manager_public, _ = _load(folder, "manager", secret=False)
    return RobotKeys(public, secret or b"", manager_public)


def load_manager_keys(folder: Union[str, Path, None] = None) -> ManagerKeys:
    folder = Path(folder) if folder is not None else default_keys_dir()
    public, secret = _load(folder, "manager", secret=True)
    robot_public, _ = _load(folder, "robot", secret=False)
    console_public = (_load(folder, "console", secret=False)[0]
                      if (folder / "console.key").is_file() else None)
    return ManagerKeys(public, secret or b"", robot_public, console_public)


def load_console_keys(folder: Union[str, Path, None] = None) -> ConsoleKeys:
    folder = Path(folder) if folder is not None else default_keys_dir()
    public, secret = _load(folder, "console", secret=True)
    manager_public, _ = _load(folder, "manager", secret=False)
    return ConsoleKeys(public, secret or b"", manager_public)


def curve_available() -> bool:
    """Whether this libzmq was built with CURVE (Debian's is)."""
    return bool(zmq.has("curve"))
