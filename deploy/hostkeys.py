"""Host keys pinned in a known_hosts file: an unknown or changed key refuses that host.

Never paramiko's AutoAddPolicy. A host not in the file is refused with its key's
fingerprint and how to trust it deliberately (`--accept-new-host-keys`, which
appends the key on first contact only). A host whose key differs from the pinned
one is always refused (paramiko raises BadHostKeyException before any policy is
asked); the message says how to remove the old key if the machine was
reinstalled. Lines are appended to the file as OpenSSH writes them, so `ssh`
and this module share one file and nothing else in it is rewritten.
"""
from __future__ import annotations

import base64
import hashlib
import threading
from pathlib import Path

import paramiko

from .errors import HostKeyRefused

__all__ = ["PinnedHostKeys", "fingerprint", "known_hosts_name", "changed_key_message"]

_APPEND = threading.Lock()  # several connections may accept keys into one file at once


def fingerprint(key: paramiko.PKey) -> str:
    """OpenSSH's form: `SHA256:` and the unpadded base64 of the key's SHA-256."""
    digest = hashlib.sha256(key.asbytes()).digest()
    return "SHA256:" + base64.b64encode(digest).decode("ascii").rstrip("=")


def known_hosts_name(host: str, port: int) -> str:
    """How known_hosts names a host: `host`, or `[host]:port` off port 22."""
    return host if port == 22 else "[{}]:{}".format(host, port)


def _remove_hint(name: str, path: Path) -> str:
    return "ssh-keygen -R '{}' -f {}".format(name, path)


def changed_key_message(host: str, port: int, path: Path, offered: paramiko.PKey,
                        pinned: paramiko.PKey) -> str:
    name = known_hosts_name(host, port)
    return ("HOST KEY CHANGED for {}: it offers {} {}, {} pins {} {}; refused (the machine "
            "may be an impostor). Only if you know it was reinstalled: check the new key on "
            "it (ssh-keygen -lf /etc/ssh/ssh_host_{}_key.pub), remove the old one with `{}`, "
            "then run again with --accept-new-host-keys").format(
                name, offered.get_name(), fingerprint(offered), path, pinned.get_name(),
                fingerprint(pinned), _key_file_kind(offered), _remove_hint(name, path))


def _key_file_kind(key: paramiko.PKey) -> str:
    name = key.get_name()
    return "ed25519" if "ed25519" in name else "ecdsa" if "ecdsa" in name else "rsa"


class PinnedHostKeys(paramiko.MissingHostKeyPolicy):
    """Called by paramiko for a host the known_hosts file does not name."""

    def __init__(self, path: Path, accept_new: bool) -> None:
        self.path = path
        self.accept_new = accept_new
        self.accepted = ""  # set when a key was added, for the log

    def missing_host_key(self, client: paramiko.SSHClient, hostname: str,
                         key: paramiko.PKey) -> None:
        # paramiko passes the known_hosts name already ("[host]:port" off port 22).
        if not self.accept_new:
            raise HostKeyRefused(
                "unknown host key: {} offers {} {}, not in {}; check it on the machine "
                "(ssh-keygen -lf /etc/ssh/ssh_host_{}_key.pub) and run again with "
                "--accept-new-host-keys to trust it".format(
                    hostname, key.get_name(), fingerprint(key), self.path, _key_file_kind(key)))
        line = "{} {} {}\n".format(hostname, key.get_name(), key.get_base64())
        with _APPEND:
            self.path.parent.mkdir(mode=0o700, parents=True, exist_ok=True)
            with self.path.open("ab+") as out:
                end = out.seek(0, 2)
                if end > 0:  # a last line without its newline would merge with ours
                    out.seek(end - 1)
                    line = ("" if out.read(1) == b"\n" else "\n") + line
                out.write(line.encode("ascii"))
        self.accepted = "accepted new host key {} {} for {} into {}".format(
            key.get_name(), fingerprint(key), hostname, self.path)
