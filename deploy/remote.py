"""What runs on the server and the robots: each action as bash steps, built from values only.

Nothing here opens a connection: `steps(action, target, config)` returns the
steps (a title, a bash script, what goes to its stdin), which `--dry-run`
prints and `actions` runs over SSH. Each script's last output line is what the
result table shows.

- init: clone the branch into the checkout (an existing clone of the same
  repository is left as it is).
- update: hard reset of the branch to the repository's, after a fetch.
- init and update first install the deploy key (and the git server's host key)
  under ~/.ssh, and point the checkout's core.sshCommand at them, so git on the
  target never asks for a password (thesis 6.1.2).
- build: the side's build command in the checkout.
- start/stop/status: every process runs in its own tmux session on a dedicated
  tmux socket (`tmux -L fleetcontrol`), so the lab's own tmux sessions are never
  touched; a session whose process exited stays (remain-on-exit) until the next
  start or stop. Each process runs under `script`, which keeps its terminal and
  copies everything it prints to `logs/<name>.log` in the checkout: tmux may
  lose the last lines of a process that exits at once, the file does not, and
  it is what start and status quote. Stop sends Ctrl-C and waits.
"""
from __future__ import annotations

import shlex
from dataclasses import dataclass
from typing import List

from .config import DeployConfig
from .errors import DeployError
from .targets import Target

__all__ = ["Step", "steps", "format_steps", "ACTIONS", "DEPLOY_KEY", "GIT_KNOWN_HOSTS", "shell_path"]

#: Where init/update put the deploy key and the git server's host key on a target.
DEPLOY_KEY = "~/.ssh/fleetcontrol_deploy_key"
GIT_KNOWN_HOSTS = "~/.ssh/fleetcontrol_git_known_hosts"

ACTIONS = ("init", "update", "build", "start", "stop", "status")


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


def _side(target: Target) -> str:
    return "server" if target.robot_id is None else "robots"


def _enter(target: Target) -> str:
    """cd into the checkout, or stop with a message saying what to run first."""
    return ('cd {0} 2>/dev/null && [ -d .git ] || {{ echo "no checkout at {1}: run '
            '{2}:init first"; exit 1; }}\n').format(
                shell_path(target.path), target.path, _side(target))


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


def _key_steps(config: DeployConfig) -> List[Step]:
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


def _init(target: Target, config: DeployConfig) -> str:
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


def _update(target: Target, config: DeployConfig) -> str:
    url, branch = shlex.quote(config.repository), shlex.quote(config.branch)
    remote_ref = shlex.quote("refs/remotes/origin/" + config.branch)
    return _GIT_PROLOGUE + _git_ssh(config) + _enter(target) + """git config core.sshCommand "$GIT_SSH"
git remote set-url origin {url}
git fetch --prune origin {refspec}
git checkout --force -B {branch} {remote_ref}
echo "at {at} ({branch_shown})"
""".format(url=url, branch=branch, remote_ref=remote_ref, at=_AT, branch_shown=config.branch,
           refspec=shlex.quote("+refs/heads/{0}:refs/remotes/origin/{0}".format(config.branch)))


def _tmux(config: DeployConfig) -> str:
    """Shell functions over the dedicated tmux socket: T, state NAME, sessions."""
    return """command -v tmux >/dev/null || {{ echo "tmux is not installed here (apt install tmux)"; exit 1; }}
T() {{ tmux -L {socket} "$@"; }}
state() {{
  T has-session -t "=$1" 2>/dev/null || {{ echo stopped; return; }}
  T display-message -p -t "=$1:" '#{{?pane_dead,exited #{{pane_dead_status}}#{{?pane_dead_signal,signal #{{pane_dead_signal}},}},running}}'
}}
sessions() {{ T list-sessions -F '#{{session_name}}' 2>/dev/null || true; }}
last_output() {{
  [ -f "logs/$1.log" ] && tr -d '\r' < "logs/$1.log" | grep -v -e '^ *$' -e '^Script started on ' \
    -e '^Script done on ' | tail -n 1
}}
""".format(socket=shlex.quote(config.tmux_socket))


def _start(target: Target, config: DeployConfig) -> str:
    # The options go in the same tmux call as the session: a server started alone exits at
    # once (no session yet) and takes its options along.
    if not target.processes:
        return 'echo "no processes configured for {}"\n'.format(_side(target))
    lines = [_enter(target), _tmux(config), "mkdir -p logs", "started=''", "running=''"]
    for name, command in target.processes:
        lines.append(r"""case $(state {n}) in
  running) running="$running {n}" ;;
  *) T kill-session -t ={n} 2>/dev/null || true
     T start-server \; set-window-option -g remain-on-exit on \; set-option -g history-limit 20000 \; \
       new-session -d -s {n} -c "$PWD" -x 200 -y 50 {cmd}
     started="$started {n}" ;;
esac""".format(n=shlex.quote(name), cmd=shlex.quote("script -qfeac {} logs/{}.log".format(
            shlex.quote("bash -c " + shlex.quote(command)), name))))
    lines.append("""[ -z "$started" ] || sleep {check}
for name in $started; do
  s=$(state "$name")
  if [ "$s" != running ]; then
    echo "$name $s right after starting: $(last_output "$name")"
    exit 1
  fi
done
echo "started:${{started:- nothing}}${{running:+; already running:$running}}"
""".format(check=config.timeouts.start_check))
    return "\n".join(lines)


def _stop(config: DeployConfig) -> str:
    return _tmux(config) + """names=$(sessions)
[ -n "$names" ] || {{ echo "nothing was running"; exit 0; }}
for name in $names; do
  [ "$(state "$name")" = running ] && T send-keys -t "=$name:" C-c
done
waited=0
while [ $waited -lt {ticks} ]; do
  busy=''
  for name in $names; do [ "$(state "$name")" = running ] && busy="$busy $name"; done
  [ -n "$busy" ] || break
  sleep 0.2
  waited=$((waited + 1))
done
for name in $names; do T kill-session -t "=$name" 2>/dev/null || true; done
if [ -n "$busy" ]; then
  echo "stopped:" $names"; killed after {seconds:g} s without exiting on Ctrl-C:$busy"
else
  echo "stopped:" $names
fi
""".format(ticks=max(1, int(config.timeouts.stop / 0.2)), seconds=config.timeouts.stop)


def _status(target: Target, config: DeployConfig) -> str:
    names = " ".join(shlex.quote(n) for n, _ in target.processes)
    return _tmux(config) + """cd {dir} 2>/dev/null || true
report=''
for name in $( (printf '%s\\n' {names}; sessions) | awk 'NF && !seen[$0]++'); do
  s=$(state "$name")
  case $s in
    running) s="running (pid $(T display-message -p -t "=$name:" '#{{pane_pid}}'))" ;;
    exited*) s="$s: $(last_output "$name")" ;;
  esac
  echo "$name: $s"
  report="$report${{report:+, }}$name $s"
done
if cd {dir} 2>/dev/null && [ -d .git ]; then
  at="at $(git log -1 --format=%h) ($(git rev-parse --abbrev-ref HEAD))"
  [ -z "$(git status --porcelain --untracked-files=no)" ] || at="$at, locally modified"
else
  at="no checkout at {shown}"
fi
echo "${{report:-nothing configured}}; $at"
""".format(names=names, dir=shell_path(target.path), shown=target.path)


def steps(action: str, target: Target, config: DeployConfig) -> List[Step]:
    """The steps of `action` (one of ACTIONS) on `target`, in order."""
    if action == "init":
        return _key_steps(config) + [Step("clone", _init(target, config))]
    if action == "update":
        return _key_steps(config) + [Step("update", _update(target, config))]
    if action == "build":
        return [Step("build", _enter(target) + target.build + "\n")]
    if action == "start":
        return [Step("start", _start(target, config))]
    if action == "stop":
        return [Step("stop", _stop(config))]
    if action == "status":
        return [Step("status", _status(target, config))]
    raise ValueError("unknown action {!r}; expected one of {}".format(action, ", ".join(ACTIONS)))


def format_steps(target: Target, step_list: List[Step]) -> str:
    """What --dry-run prints for one target: each step's title and script."""
    out = ["# {} ({})".format(target.name, target.address)]
    for step in step_list:
        source = " < {} ({} bytes)".format(step.stdin_name, len(step.stdin)) if step.stdin else ""
        out.append("## {}{}".format(step.title, source))
        out.append(step.script.rstrip("\n"))
    return "\n".join(out)
