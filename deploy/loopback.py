"""A lab on one machine: real OpenSSH servers on 127.0.0.x standing in for the server and robots.

Each `LoopbackHost` is one `sshd -D` on its own loopback address (127.0.0.2,
127.0.0.3, ...; Linux routes all of 127/8 to lo) and the lab's port, with its
own host key and authorized_keys. sshd's SetEnv gives each host's sessions a
HOME and a TMUX_TMPDIR of their own inside the lab, so checkouts, keys and tmux
servers of different "robots" never meet, and the real home is never touched.
Everyone logs in as the current user with the client key the lab generates.
Used by the tests and bench/deploy.py; `close()` ends every sshd it started (by
pid) and the tmux servers on its own sockets, nothing else.
"""
from __future__ import annotations

import getpass
import os
import shutil
import signal
import socket
import subprocess
import tempfile
import time
from pathlib import Path
from typing import List, Optional

__all__ = ["LoopbackHost", "LoopbackLab", "SSHD", "keygen", "free_port_on"]

SSHD = "/usr/sbin/sshd"
_PRIVSEP_DIR = Path("/run/sshd")  # sshd refuses to start without it


def keygen(path: Path, comment: str = "fleetcontrol-loopback") -> Path:
    """A new ed25519 key pair without passphrase at `path` (and `path`.pub)."""
    for old in (path, path.with_name(path.name + ".pub")):
        if old.exists():
            old.unlink()
    subprocess.run(["ssh-keygen", "-q", "-t", "ed25519", "-N", "", "-C", comment, "-f", str(path)],
                   check=True, capture_output=True, timeout=30)
    return path


class LoopbackHost:
    """One sshd on `address`:`port`; its sessions' home is `home`."""

    def __init__(self, folder: Path, tmux_dir: Path, address: str, port: int) -> None:
        self.folder = folder
        self.address = address
        self.port = port
        self.home = folder / "home"
        self.tmux_dir = tmux_dir
        self.host_key = folder / "ssh_host_ed25519_key"
        self.authorized_keys = folder / "authorized_keys"
        self.log = folder / "sshd.log"
        self.process: Optional[subprocess.Popen] = None
        for d in (folder, self.home, self.tmux_dir):
            d.mkdir(parents=True, exist_ok=True)
        self.authorized_keys.touch()
        keygen(self.host_key, "host-" + address)

    def config_text(self) -> str:
        return "\n".join([
            "ListenAddress {}:{}".format(self.address, self.port),
            "HostKey {}".format(self.host_key),
            "AuthorizedKeysFile {}".format(self.authorized_keys),
            "PidFile {}".format(self.folder / "sshd.pid"),
            "UsePAM no", "StrictModes no", "UseDNS no", "PrintMotd no", "X11Forwarding no",
            "PubkeyAuthentication yes", "PasswordAuthentication no",
            "KbdInteractiveAuthentication no", "PermitRootLogin prohibit-password",
            "LogLevel VERBOSE",
            "SetEnv HOME={} TMUX_TMPDIR={}".format(self.home, self.tmux_dir), ""])

    def start(self, wait: float = 10.0) -> None:
        """Start sshd and wait (bounded) until it accepts connections."""
        if self.process is not None and self.process.poll() is None:
            return
        config = self.folder / "sshd_config"
        config.write_text(self.config_text())
        self.process = subprocess.Popen([SSHD, "-D", "-f", str(config), "-E", str(self.log)],
                                        stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                                        stderr=subprocess.DEVNULL)
        give_up = time.monotonic() + wait
        while time.monotonic() < give_up:
            if self.process.poll() is not None:
                raise RuntimeError("sshd on {}:{} exited at once (status {}); see {}".format(
                    self.address, self.port, self.process.returncode, self.log))
            try:
                socket.create_connection((self.address, self.port), timeout=1.0).close()
                return
            except OSError:
                time.sleep(0.02)
        raise RuntimeError("sshd on {}:{} did not listen within {:g} s; see {}".format(
            self.address, self.port, wait, self.log))

    def stop(self) -> None:
        if self.process is None:
            return
        if self.process.poll() is None:
            self.process.send_signal(signal.SIGTERM)
            try:
                self.process.wait(timeout=10)
            except subprocess.TimeoutExpired:
                self.process.kill()
                self.process.wait(timeout=10)
        self.process = None

    def new_host_key(self) -> None:
        """Another host key, as after a reinstall (takes effect at the next start)."""
        keygen(self.host_key, "host-" + self.address)

    def known_hosts_line(self) -> str:
        kind, blob = self.host_key.with_name(self.host_key.name + ".pub").read_text().split()[:2]
        return "[{}]:{} {} {}\n".format(self.address, self.port, kind, blob)

    def kill_tmux(self, socket_name: str) -> None:
        """End the tmux server this host's sessions started on `socket_name`, if any."""
        env = dict(os.environ, TMUX_TMPDIR=str(self.tmux_dir))
        env.pop("TMUX", None)
        subprocess.run(["tmux", "-L", socket_name, "kill-server"], env=env,
                       capture_output=True, timeout=30)


def free_port_on(addresses: List[str], tries: int = 50) -> int:
    """A TCP port free on every one of `addresses` right now."""
    for _ in range(tries):
        socks = [socket.socket()]
        try:
            socks[0].bind((addresses[0], 0))
            port = socks[0].getsockname()[1]
            for address in addresses[1:]:
                socks.append(socket.socket())
                socks[-1].bind((address, port))
            return port
        except OSError:
            continue
        finally:
            for s in socks:
                s.close()
    raise RuntimeError("no port free on all of {}".format(", ".join(addresses)))


class LoopbackLab:
    """`count` hosts on 127.0.0.`first`... and one port (0: a free one), a client key and
    a known_hosts file."""

    def __init__(self, folder: Path, count: int, port: int = 0, first: int = 2,
                 tmux_socket: str = "fleetcontrol") -> None:
        if not os.path.exists(SSHD):
            raise RuntimeError("{} not found: install openssh-server (scripts/ciirc-exec.sh "
                               "setup does)".format(SSHD))
        if not _PRIVSEP_DIR.is_dir() and os.geteuid() == 0:
            _PRIVSEP_DIR.mkdir(mode=0o755, parents=True, exist_ok=True)
        self.folder = folder
        folder.mkdir(parents=True, exist_ok=True)
        addresses = ["127.0.0.{}".format(first + i) for i in range(count)]
        self.port = port or free_port_on(addresses)
        self.user = getpass.getuser()
        self.tmux_socket = tmux_socket
        self.client_key = keygen(folder / "client_key", "fleetcontrol-client")
        self.known_hosts = folder / "known_hosts"
        self.hosts: List[LoopbackHost] = []
        # tmux sockets live under TMUX_TMPDIR, and a Unix socket path must stay short.
        self._tmux_root = Path(tempfile.mkdtemp(prefix="fc-tmux-"))
        try:
            for i, address in enumerate(addresses):
                host = LoopbackHost(folder / address, self._tmux_root / str(first + i), address,
                                    self.port)
                host.authorized_keys.write_text(self.public_key())
                self.hosts.append(host)
        except BaseException:
            shutil.rmtree(self._tmux_root, ignore_errors=True)
            raise

    def public_key(self) -> str:
        return self.client_key.with_name(self.client_key.name + ".pub").read_text()

    def start(self) -> "LoopbackLab":
        for host in self.hosts:
            host.start()
        return self

    def pin_host_keys(self) -> None:
        """Write every host's key into known_hosts, as a deliberate first contact would."""
        self.known_hosts.write_text("".join(h.known_hosts_line() for h in self.hosts))

    def close(self) -> None:
        for host in self.hosts:
            host.kill_tmux(self.tmux_socket)
            host.stop()
        shutil.rmtree(self._tmux_root, ignore_errors=True)

    def __enter__(self) -> "LoopbackLab":
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.close()
