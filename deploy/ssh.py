"""One SSH connection to one machine (paramiko): key authentication only, pinned host keys,
timeouts on connecting and on every step.

`run_steps` connects, runs each step as `bash -c SCRIPT` (its stdin bytes sent,
then end of input), writes all output to the log, and returns the last line the
final step printed. A step is bounded twice: `timeout` on the target ends it
(and its children) after the command timeout, and this side gives up a little
later if the connection itself hangs. Every failure is a `DeployError` whose
one-line message is what the result table shows.
"""
from __future__ import annotations

import codecs
import re
import shlex
import socket
import time
from typing import List, Optional, TextIO

import paramiko

from .config import DeployConfig
from .errors import DeployError, HostKeyRefused
from .hostkeys import PinnedHostKeys, changed_key_message
from .shell import Step
from .targets import Target

__all__ = ["connect", "run_steps", "last_line"]

_GRACE = 15.0           # seconds this side waits beyond the remote timeout
_KILL_AFTER = 5         # seconds between the remote TERM and KILL
_ANSI = re.compile(r"\x1b\[[0-9;?]*[A-Za-z]")
_DETAIL_MAX = 400


def last_line(text: str) -> str:
    """The last non-blank line of `text` (progress bars' \\r count as line ends)."""
    for line in reversed(re.split(r"[\r\n]", _ANSI.sub("", text))):
        if line.strip():
            line = line.strip()
            return line if len(line) <= _DETAIL_MAX else line[:_DETAIL_MAX - 3] + "..."
    return ""


def connect(target: Target, config: DeployConfig, accept_new: bool,
            log: Optional[TextIO] = None) -> paramiko.SSHClient:
    """An authenticated connection to `target`, or DeployError saying why not."""
    where = "{}:{}".format(target.host, target.port)
    seconds = config.timeouts.connect
    client = paramiko.SSHClient()
    policy = PinnedHostKeys(config.known_hosts, accept_new)
    try:
        if config.known_hosts.is_file():
            client.load_system_host_keys(str(config.known_hosts))
    except OSError as err:
        raise DeployError("cannot read {}: {}".format(config.known_hosts, err.strerror)) from err
    client.set_missing_host_key_policy(policy)
    key = str(config.login_key) if config.login_key is not None else None
    try:
        # Only keys: our own (login_key), else ssh-agent's and ~/.ssh/id_*; never a password.
        # `timeout` also bounds the handshake, and paramiko ends that wait without an error:
        # a little longer than the banner's, so a silent server is reported as one.
        client.connect(target.host, target.port, username=target.user, key_filename=key,
                       look_for_keys=key is None, allow_agent=key is None, timeout=seconds + 2,
                       banner_timeout=seconds, auth_timeout=seconds)
    except HostKeyRefused:
        client.close()
        raise
    except paramiko.BadHostKeyException as err:
        client.close()
        raise HostKeyRefused(changed_key_message(target.host, target.port, config.known_hosts,
                                                 err.key, err.expected_key), changed=True) from None
    except paramiko.PasswordRequiredException:
        client.close()
        raise DeployError("the login key {0} has a passphrase: load it into ssh-agent (ssh-add "
                          "{0}) and leave login_key out of {1}".format(key, config.path)) from None
    except paramiko.AuthenticationException:
        client.close()
        raise DeployError("{} refused our key ({}): add its public key to ~/.ssh/authorized_keys "
                          "there (ssh-copy-id -p {} {}@{})".format(
                              target.address, key or "ssh-agent and ~/.ssh/id_*", target.port,
                              target.user, target.host)) from None
    except paramiko.ssh_exception.NoValidConnectionsError as err:
        client.close()
        reasons = {e.strerror or str(e) for e in err.errors.values()}
        raise DeployError("cannot connect to {}: {}{}".format(
            where, "; ".join(sorted(reasons)),
            " (no SSH server running there?)" if "Connection refused" in reasons else "")) from None
    except (socket.timeout, TimeoutError):
        client.close()
        raise DeployError("no answer from {} within {:g} s (machine off, or not on this "
                          "network?)".format(where, seconds)) from None
    except (paramiko.SSHException, EOFError) as err:
        client.close()
        text = str(err) or type(err).__name__
        if "banner" in text:
            text = "connected, but no SSH greeting within {:g} s (not an SSH server, or " \
                   "overloaded?)".format(seconds)
        elif text == "No existing session":
            text = "the SSH handshake did not finish within {:g} s".format(seconds + 2)
        raise DeployError("{}: SSH failed: {}".format(where, text)) from None
    except OSError as err:
        client.close()
        raise DeployError("cannot connect to {}: {}".format(where, err.strerror or err)) from None
    if policy.accepted and log is not None:
        log.write(policy.accepted + "\n")
    return client


def _run(client: paramiko.SSHClient, step: Step, config: DeployConfig, log: TextIO) -> str:
    limit = config.timeouts.command
    transport = client.get_transport()
    if transport is None or not transport.is_active():
        raise DeployError("the SSH connection closed")
    chan = transport.open_session(timeout=config.timeouts.connect)
    try:
        chan.set_combine_stderr(True)
        chan.exec_command("timeout -k {} {:g} bash -c {}".format(
            _KILL_AFTER, limit, shlex.quote(step.script)))
        if step.stdin:
            chan.sendall(step.stdin)
        chan.shutdown_write()
        chan.settimeout(0.5)
        decoder = codecs.getincrementaldecoder("utf-8")(errors="replace")
        tail: List[str] = []
        give_up = time.monotonic() + limit + _KILL_AFTER + _GRACE
        while True:
            try:
                data = chan.recv(65536)
            except socket.timeout:
                if time.monotonic() > give_up:
                    raise DeployError("{}: no end after {:g} s; gave up".format(
                        step.title, limit)) from None
                continue
            if not data:
                break
            text = decoder.decode(data)
            log.write(text)
            tail = (tail + [text])[-50:]
        if not chan.status_event.wait(max(0.0, give_up - time.monotonic())):
            raise DeployError("{}: no exit status".format(step.title))
        status = chan.recv_exit_status()
    finally:
        chan.close()
    last = last_line("".join(tail))
    if status in (124, 137):  # timeout's own statuses: TERM, then KILL
        raise DeployError("{}: timed out after {:g} s{}".format(
            step.title, limit, ": " + last if last else ""))
    if status != 0:
        raise DeployError("{} failed (exit {}){}".format(
            step.title, status, ": " + last if last else ""))
    return last


def run_steps(target: Target, config: DeployConfig, steps: List[Step], accept_new: bool,
              log: TextIO) -> str:
    """Connect, run `steps` in order (stop at the first failure); the last step's last line."""
    client = connect(target, config, accept_new, log)
    try:
        last = ""
        for step in steps:
            log.write("--- {}\n".format(step.title))
            last = _run(client, step, config, log)
        return last
    finally:
        client.close()
