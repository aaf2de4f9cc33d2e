"""ssh and inspect: a person's own terminal on one machine, through the OpenSSH client.

Interactive use needs a real terminal, which OpenSSH's `ssh -t` gives; it gets
the same rules as the rest of deployment: the same known_hosts file with strict
checking (`accept-new` only when asked), the login key, no password prompts.
`ssh` opens a login shell in the checkout; `inspect` attaches to the first
process's tmux session (Ctrl-b d detaches and leaves it running; Ctrl-b s lists
the others).
"""
from __future__ import annotations

import shlex
from typing import List

from .config import DeployConfig
from .shell import shell_path
from .targets import Target

__all__ = ["ssh_argv", "shell_command", "inspect_command"]


def ssh_argv(target: Target, config: DeployConfig, remote: str, accept_new: bool) -> List[str]:
    argv = ["ssh", "-t", "-p", str(target.port),
            "-o", "UserKnownHostsFile={}".format(config.known_hosts),
            "-o", "StrictHostKeyChecking={}".format("accept-new" if accept_new else "yes"),
            "-o", "PasswordAuthentication=no", "-o", "KbdInteractiveAuthentication=no",
            "-o", "ConnectTimeout={:g}".format(config.timeouts.connect)]
    if config.login_key is not None:
        argv += ["-i", str(config.login_key), "-o", "IdentitiesOnly=yes"]
    return argv + ["{}@{}".format(target.user, target.host), remote]


def shell_command(target: Target) -> str:
    return 'cd {} && exec "${{SHELL:-bash}}" -l'.format(shell_path(target.path))


def inspect_command(target: Target, config: DeployConfig) -> str:
    socket = shlex.quote(config.tmux_socket)
    if not target.processes:
        return "echo 'no processes configured'; exit 1"
    name = shlex.quote("=" + target.processes[0][0])
    return ("tmux -L {0} has-session -t {1} 2>/dev/null || {{ echo 'not running: {2}'; "
            "exit 1; }}; exec tmux -L {0} attach-session -t {1}").format(
                socket, name, target.processes[0][0])
