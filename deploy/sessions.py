"""The processes on a machine: start, stop and status of their tmux sessions.

Every process runs in its own tmux session on a dedicated tmux socket
(`tmux -L fleetcontrol`), so the lab's own tmux sessions are never touched; a
session whose process exited stays (remain-on-exit) until the next start or
stop, and its exit status is reported. Each process runs under `script`, which
keeps its terminal and copies everything it prints to `logs/<name>.log` in the
checkout: tmux may lose the last lines of a process that exits at once, the
file does not, and it is what start and status quote. The process's exit status
goes to `logs/<name>.exit` before its session's shell ends: tmux marks a pane
dead when its terminal closes, sometimes seconds before it knows the status
(never, on a loaded machine, within 5 s), and the file is there by then. Stop
sends Ctrl-C, waits `timeouts.stop`, then ends the sessions.
"""
from __future__ import annotations

import shlex

from .config import DeployConfig
from .shell import enter, shell_path, side
from .targets import Target

__all__ = ["start_script", "stop_script", "status_script"]


def _tmux(config: DeployConfig) -> str:
    """Shell functions over the dedicated tmux socket: T, state NAME, sessions."""
    return """command -v tmux >/dev/null || {{ echo "tmux is not installed here (apt install tmux)"; exit 1; }}
T() {{ tmux -L {socket} "$@"; }}
state() {{
  T has-session -t "=$1" 2>/dev/null || {{ echo stopped; return; }}
  # the status file first (written before the pane dies); tmux's own status for a session
  # started without one, which can lag: "exited " without a status then; ask again
  for _ in 1 2 3 4 5 6 7 8 9 10; do
    st=$(T display-message -p -t "=$1:" '#{{?pane_dead,exited #{{pane_dead_status}}#{{?pane_dead_signal,signal #{{pane_dead_signal}},}},running}}')
    case $st in
      exited*) code=$(cat "logs/$1.exit" 2>/dev/null)
               case $code in
                 ''|*[!0-9]*) ;;
                 *) if [ "$code" -gt 128 ]; then st="exited signal $((code - 128))"; else st="exited $code"; fi ;;
               esac ;;
    esac
    [ "$st" = "exited " ] || break
    sleep 0.1
  done
  echo "$st"
}}
sessions() {{ T list-sessions -F '#{{session_name}}' 2>/dev/null || true; }}
last_output() {{
  [ -f "logs/$1.log" ] && tr -d '\r' < "logs/$1.log" | grep -v -e '^ *$' -e '^Script started on ' \
    -e '^Script done on ' | tail -n 1
}}
""".format(socket=shlex.quote(config.tmux_socket))


def start_script(target: Target, config: DeployConfig) -> str:
    # The options go in the same tmux call as the session: a server started alone exits at
    # once (no session yet) and takes its options along.
    if not target.processes:
        return 'echo "no processes configured for {}"\n'.format(side(target))
    lines = [enter(target), _tmux(config), "mkdir -p logs", "started=''", "running=''"]
    for name, command in target.processes:
        lines.append(r"""case $(state {n}) in
  running) running="$running {n}" ;;
  *) T kill-session -t ={n} 2>/dev/null || true
     rm -f logs/{n}.exit
     T start-server \; set-window-option -g remain-on-exit on \; set-option -g history-limit 20000 \; \
       new-session -d -s {n} -c "$PWD" -x 200 -y 50 {cmd}
     started="$started {n}" ;;
esac""".format(n=shlex.quote(name), cmd=shlex.quote(_session_command(name, command))))
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


def _session_command(name: str, command: str) -> str:
    """What a session runs: `command` under `script` (its log), then its status to the file."""
    log, status = shlex.quote("logs/{}.log".format(name)), shlex.quote("logs/{}.exit".format(name))
    return "sh -c {}".format(shlex.quote("script -qfeac {} {}; s=$?; echo $s > {}; exit $s".format(
        shlex.quote("bash -c " + shlex.quote(command)), log, status)))


def stop_script(config: DeployConfig) -> str:
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


def status_script(target: Target, config: DeployConfig) -> str:
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
