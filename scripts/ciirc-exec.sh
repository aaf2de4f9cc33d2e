#!/usr/bin/env bash
# The one entry point for lab staff: set up this machine, run the demo, run the tests.
# Every subcommand is a function cmd_*; SUBCOMMANDS below is the dispatch table and the
# help text, so a new subcommand is one function and one line there.
set -euo pipefail

# Debian 12 packages FleetControl needs (ROS 1 from Debian, Tk, Xvfb, build tools); numpy
# and yaml are the catkin packages' exec_depends, for code run by Debian's own python3.
# git, tmux and OpenSSH are what deployment runs on the server and the robots (the tests
# start real sshd processes, so the server package is needed here too).
APT_PACKAGES=(
  ros-core python3-rospy catkin python3-catkin-pkg python3-numpy python3-yaml
  ros-std-msgs ros-geometry-msgs ros-nav-msgs ros-sensor-msgs
  python3-std-msgs python3-geometry-msgs python3-nav-msgs python3-sensor-msgs
  python3-tk xvfb fonts-dejavu-core python3-venv python3-dev build-essential cmake
  python3-zmq iproute2 openssh-client openssh-server tmux git
)

# Debian's interpreter, not whatever python3 is first on PATH: rospy lives in its
# /usr/lib/python3/dist-packages, which the venv sees through --system-site-packages.
SYSTEM_PYTHON=/usr/bin/python3
VENV=.venv
PIP_SPEC="pip>=24,<27"
SETUP_STAMP="$VENV/.fleetcontrol-setup"
# Where setup links `fleetctl`, so that it is on the PATH and the README's examples work as typed.
BIN_DIR=${FLEETCONTROL_BIN_DIR:-/usr/local/bin}

# name | function | help; in the order `--help` lists them. The server:*, robots:* and
# net:check lines repeat deploy/cli.py's COMMANDS (a test checks that they agree).
SUBCOMMANDS=(
  "setup|cmd_setup|Install what FleetControl needs (Debian 12, as root), fleetctl on the PATH; quick once done."
  "demo|cmd_demo|Set up, then run 'fleetctl demo' on the embedded lab scenario (arguments pass through)."
  "test|cmd_test|Set up, build catkin_ws, check robot code against Python 3.8, run pytest (arguments pass through)."
  "server:init|cmd_deploy|Clone the repository on the server (deploy key copied first)."
  "server:update|cmd_deploy|Hard-reset the server's checkout to the branch's newest commit."
  "server:build|cmd_deploy|Run the server's build command (the project setup)."
  "server:start|cmd_deploy|Start the server's processes, each in its own tmux session."
  "server:stop|cmd_deploy|Stop the server's processes (Ctrl-C, then the sessions go)."
  "server:status|cmd_deploy|Say what runs on the server and which commit it has."
  "server:ssh|cmd_deploy|Open a shell in the server's checkout."
  "server:inspect|cmd_deploy|Attach to the server's process (tmux; Ctrl-b d detaches)."
  "robots:init|cmd_deploy|Clone the repository on robots ID... or all (deploy key copied first)."
  "robots:update|cmd_deploy|Hard-reset robots ID... or all to the branch's newest commit."
  "robots:update:all|cmd_deploy|Same as robots:update all."
  "robots:build|cmd_deploy|Build on robots ID... or all (catkin_make)."
  "robots:start|cmd_deploy|Start robots ID... or all, each process in its own tmux session."
  "robots:start:all|cmd_deploy|Same as robots:start all."
  "robots:stop|cmd_deploy|Stop robots ID... (default all)."
  "robots:status|cmd_deploy|Say what runs on robots ID... (default all), which commit."
  "robots:ssh|cmd_deploy|Open a shell in robot ID's checkout."
  "robots:inspect|cmd_deploy|Attach to robot ID's process (tmux; Ctrl-b d detaches)."
  "net:check|cmd_deploy|Per robot: reachable, SSH login, command port, wire status."
)

PROG=$(basename "$0")
cd "$(dirname "$(readlink -f "${BASH_SOURCE[0]}")")/.."

say() { printf '==> %s\n' "$*"; }
die() { printf '%s: %s\n' "$PROG" "$*" >&2; exit 1; }

# Runs a noisy command with its output in LOG; on failure shows the log's tail and stops.
run_logged() {
  local log=$1 what=$2
  shift 2
  mkdir -p "$(dirname "$log")"
  if ! "$@" >"$log" 2>&1; then
    tail -n 80 "$log" >&2
    die "$what failed (full log: $log)"
  fi
}

usage() {
  local entry name func help
  printf 'Usage: %s SUBCOMMAND [ARGS...]\n\nSubcommands:\n' "$PROG"
  for entry in "${SUBCOMMANDS[@]}"; do
    IFS='|' read -r name func help <<<"$entry"
    printf '  %-17s %s\n' "$name" "$help"
  done
  printf '\nRobots are named by id (robot_definitions.txt) or "all"; the server and robots\n'
  printf 'commands take --dry-run, --jobs N, --accept-new-host-keys and more (SUBCOMMAND --help).\n'
  printf 'Runs from the repository root whatever the current directory.\n'
}

# ---- setup -------------------------------------------------------------------------

missing_apt_packages() {
  local installed pkg
  # dpkg-query fails for packages it has never heard of; those count as missing too.
  installed=$(dpkg-query -W -f='${db:Status-Abbrev} ${Package}\n' "${APT_PACKAGES[@]}" 2>/dev/null \
    | awk '$1 == "ii" { print $2 }') || true
  for pkg in "${APT_PACKAGES[@]}"; do
    grep -qxF "$pkg" <<<"$installed" || printf '%s\n' "$pkg"
  done
}

install_apt_packages() {
  local missing
  command -v dpkg-query >/dev/null || die "setup needs Debian 12 (no dpkg-query here)"
  mapfile -t missing < <(missing_apt_packages)
  if [[ ${#missing[@]} -eq 0 ]]; then
    say "Debian packages: all ${#APT_PACKAGES[@]} present"
    return
  fi
  [[ $(id -u) -eq 0 ]] || die "setup must run as root to install ${#missing[@]} Debian packages (${missing[*]})"
  say "Debian packages: installing ${#missing[@]} (${missing[*]}); takes a few minutes"
  export DEBIAN_FRONTEND=noninteractive
  run_logged /tmp/fleetcontrol-apt.log "apt-get update" apt-get update
  run_logged /tmp/fleetcontrol-apt-install.log "apt-get install" \
    apt-get install -y --no-install-recommends "${missing[@]}"
}

venv_is_usable() {
  [[ -x $VENV/bin/python ]] \
    && grep -qx 'include-system-site-packages = true' "$VENV/pyvenv.cfg" \
    && [[ $("$VENV/bin/python" -c 'import sys; print(sys.base_prefix)') == /usr ]]
}

ensure_venv() {
  if venv_is_usable; then
    return
  fi
  if [[ -e $VENV ]]; then
    say "$VENV was not made from $SYSTEM_PYTHON with system site packages: recreating it"
    rm -rf "$VENV"
  else
    say "creating $VENV from $SYSTEM_PYTHON (sees Debian's rospy)"
  fi
  "$SYSTEM_PYTHON" -m venv --system-site-packages "$VENV"
}

install_python_packages() {
  local want native
  # Whatever decides what pip installs, the C sources it compiles in place (setup.py's EXTENSIONS),
  # and the path, since an editable install records it.
  want=$(cat setup.py pyproject.toml $(find catkin_ws/src -name '*.c' | sort) <(printf '%s %s' "$PIP_SPEC" "$PWD") |
    sha256sum | cut -d' ' -f1)
  native=$(find catkin_ws/src -name '_native*.so' | head -n 1)
  if [[ -f $SETUP_STAMP && $(<"$SETUP_STAMP") == "$want" && -n $native ]]; then
    say "Python packages: up to date in $VENV"
    return
  fi
  say "Python packages: installing into $VENV (pip install -e \".[test]\")"
  rm -f "$SETUP_STAMP"
  run_logged "$VENV/pip-install.log" "pip upgrade" "$VENV/bin/python" -m pip install "$PIP_SPEC"
  run_logged "$VENV/pip-install.log" "pip install" "$VENV/bin/python" -m pip install -e ".[test]"
  printf '%s\n' "$want" >"$SETUP_STAMP"
}

# Bytecode of the sources, written now: an editable install leaves it to Python's first import,
# which never writes it where PYTHONDONTWRITEBYTECODE is set (or the checkout is read-only), and
# then every fleetctl start compiles its modules again. compileall redoes only stale files.
compile_bytecode() {
  run_logged "$VENV/compileall.log" "compiling the sources to bytecode" "$VENV/bin/python" -m compileall -q -j 0 \
    catkin_ws/src/fleet_common/src catkin_ws/src/fleet_manager/src catkin_ws/src/agv_package/src \
    fleetctl console deploy evaluation virtual_fleet
}

# A symlink BIN_DIR/fleetctl -> this checkout's .venv/bin/fleetctl (the last checkout set up wins).
link_fleetctl() {
  local target="$PWD/$VENV/bin/fleetctl" link="$BIN_DIR/fleetctl"
  if [[ -L $link && $(readlink "$link") == "$target" ]]; then
    say "fleetctl: on the PATH ($link)"
  elif [[ -e $link && ! -L $link ]]; then
    say "fleetctl: $link is another program, left alone; run $target"
  elif [[ -d $BIN_DIR && -w $BIN_DIR ]]; then
    ln -sfn "$target" "$link"
    say "fleetctl: $link -> $target"
  else
    say "fleetctl: $BIN_DIR is not a folder this user may write (setup as root does it); run $target, or: export PATH=\"$PWD/$VENV/bin:\$PATH\""
  fi
}

cmd_setup() {
  install_apt_packages
  ensure_venv
  install_python_packages
  compile_bytecode
  link_fleetctl
  say "setup done"
}

# ---- demo --------------------------------------------------------------------------

cmd_demo() {
  cmd_setup
  exec "$VENV/bin/fleetctl" demo "$@"
}

# ---- test --------------------------------------------------------------------------

build_catkin_ws() {
  say "building catkin_ws (catkin_make)"
  # catkin_make links src/CMakeLists.txt to catkin's toplevel.cmake itself when missing.
  run_logged catkin_ws/build/catkin_make.log "catkin_make" \
    bash -c 'cd catkin_ws && catkin_make -DPYTHON_EXECUTABLE="$1"' _ "$SYSTEM_PYTHON"
}

check_robot_python() {
  say "checking that catkin_ws/src runs on Python 3.8 (vermin)"
  # The flags (target 3.8, violations only) are in setup.cfg's [vermin] section.
  "$VENV/bin/vermin" --config-file setup.cfg catkin_ws/src \
    || die "robot-side code needs a Python newer than 3.8 (above); the TurtleBots run ROS Noetic on 3.8"
}

check_lint() {
  say "checking for undefined and unused names (ruff; rules in pyproject.toml)"
  "$VENV/bin/ruff" check --quiet . || die "ruff found mistakes (above)"
}

cmd_test() {
  cmd_setup
  build_catkin_ws
  check_robot_python
  check_lint
  # Two workers (pytest-xdist), a module's tests on one of them (its fixtures: a roscore, an sshd,
  # Tk): most tests wait on processes and sockets, so two share the two cores well (8 minutes
  # instead of 14). FLEETCONTROL_TEST_WORKERS=0 runs them in this process (for -s or pdb).
  local workers=${FLEETCONTROL_TEST_WORKERS:-2}
  say "running pytest ($workers workers)"
  if [[ $workers == 0 ]]; then
    exec "$VENV/bin/python" -m pytest -p no:cacheprovider "$@"
  fi
  exec "$VENV/bin/python" -m pytest -p no:cacheprovider -n "$workers" --dist loadscope "$@"
}

# ---- deployment: server:*, robots:*, net:check -------------------------------------

# The work is done in Python (deploy/: parallel SSH with paramiko); see deploy.yaml.
cmd_deploy() {
  cmd_setup >&2
  exec "$VENV/bin/python" -m deploy "$SUBCOMMAND" "$@"
}

# ---- dispatch ----------------------------------------------------------------------

main() {
  local entry name func help
  case ${1:-} in
    "") usage >&2; exit 2 ;;
    -h | --help | help) usage; exit 0 ;;
  esac
  for entry in "${SUBCOMMANDS[@]}"; do
    IFS='|' read -r name func help <<<"$entry"
    if [[ $1 == "$name" ]]; then
      shift
      SUBCOMMAND=$name
      "$func" "$@"
      return
    fi
  done
  printf "%s: unknown subcommand '%s' (run '%s --help' for the list)\n" "$PROG" "$1" "$PROG" >&2
  exit 2
}

main "$@"
