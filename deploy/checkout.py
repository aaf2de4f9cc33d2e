"""Getting the code onto a machine: the deploy key first, then a clone (init) or a hard reset
to the branch after a fetch (update).

init and update first install the deploy key (and the git server's host key)
under ~/.ssh on the target, and point the checkout's core.sshCommand at them, so
git there never asks for a password (thesis 6.1.2). The key travels on the
step's stdin, never on a command line. An existing clone of the same
repository is left as it is by init; update follows a changed repository URL.
"""
from __future__ import annotations

import shlex
from typing import List

from .config import DeployConfig
from .errors import DeployError
from .shell import Step, enter, shell_path
from .targets import Target

__all__ = ["DEPLOY_KEY", "GIT_KNOWN_HOSTS", "key_steps", "init_script", "update_script"]

#: Where init/update put the deploy key and the git server's host key on a target.
DEPLOY_KEY = "~/.ssh/fleetcontrol_deploy_key"
GIT_KNOWN_HOSTS = "~/.ssh/fleetcontrol_git_known_hosts"


def _install(source: str, dest: str, data: bytes, what: str) -> Step:
    word = shell_path(dest)
    script = ("set -eu\numask 077\nmkdir -p \"$HOME\"/.ssh\ncat > {0}.new\n"
              "mv -f {0}.new {0}\necho {1}\n").format(
                  word, shlex.quote("{} installed as {}".format(what, dest)))
    return Step("install the {} ({})".format(what, dest), script, data, source)


def _git_ssh(config: DeployConfig) -> str:
    """Shell lines setting $GIT_SSH to the command git uses on the target (absolute paths,
    so the checkout's core.sshCommand works whoever's shell runs it later)."""
    if config.deploy_key is None:
        return 'GIT_SSH="ssh -o BatchMode=yes"\n'
    line = 'GIT_SSH="ssh -i $HOME/.ssh/{} -o IdentitiesOnly=yes -o BatchMode=yes'.format(
        DEPLOY_KEY[len("~/.ssh/"):])
    if config.git_known_hosts is not None:
        line += (' -o UserKnownHostsFile=$HOME/.ssh/{} -o StrictHostKeyChecking=yes'.format(
            GIT_KNOWN_HOSTS[len("~/.ssh/"):]))
    return line + '"\n'


def key_steps(config: DeployConfig) -> List[Step]:
    out = []
    for key, local, dest, what in (
            ("deploy_key", config.deploy_key, DEPLOY_KEY, "deploy key"),
            ("git_known_hosts", config.git_known_hosts, GIT_KNOWN_HOSTS, "git server's host key")):
        if local is None:
            continue
        try:
            data = local.read_bytes()
        except OSError as err:
            raise DeployError("{} {} (from {}): cannot read: {}".format(
                key, local, config.path, err.strerror)) from err
        out.append(_install(str(local), dest, data, what))
    return out


_GIT_PROLOGUE = "set -eu\nexport GIT_TERMINAL_PROMPT=0\n"
_AT = "$(git log -1 --format='%h %s')"


def init_script(target: Target, config: DeployConfig) -> str:
    url, branch = shlex.quote(config.repository), shlex.quote(config.branch)
    return _GIT_PROLOGUE + _git_ssh(config) + """DIR={dir}
if [ -d "$DIR/.git" ]; then
  have=$(git -C "$DIR" remote get-url origin 2>/dev/null || true)
  if [ "$have" != {url} ]; then
    echo "{shown} is a clone of ${{have:-nothing}}, not of "{url}"; move it away or fix deploy.yaml"
    exit 1
  fi
  cd "$DIR"
  git config core.sshCommand "$GIT_SSH"
  echo "already cloned, at {at}"
  exit 0
fi
if [ -e "$DIR" ] && [ -n "$(ls -A "$DIR")" ]; then
  echo "{shown} exists and is not a clone; move it away first"
  exit 1
fi
mkdir -p "$(dirname "$DIR")"
git -c core.sshCommand="$GIT_SSH" clone --branch {branch} -- {url} "$DIR"
cd "$DIR"
git config core.sshCommand "$GIT_SSH"
echo "cloned {branch_shown}, at {at}"
""".format(dir=shell_path(target.path), url=url, branch=branch, shown=target.path,
           branch_shown=config.branch, at=_AT)


def update_script(target: Target, config: DeployConfig) -> str:
    url, branch = shlex.quote(config.repository), shlex.quote(config.branch)
    remote_ref = shlex.quote("refs/remotes/origin/" + config.branch)
    return _GIT_PROLOGUE + _git_ssh(config) + enter(target) + """git config core.sshCommand "$GIT_SSH"
git remote set-url origin {url}
git fetch --prune origin {refspec}
git checkout --force -B {branch} {remote_ref}
echo "at {at} ({branch_shown})"
""".format(url=url, branch=branch, remote_ref=remote_ref, at=_AT, branch_shown=config.branch,
           refspec=shlex.quote("+refs/heads/{0}:refs/remotes/origin/{0}".format(config.branch)))
