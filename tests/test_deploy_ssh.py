"""Deployment against real OpenSSH servers: one sshd per "robot" on 127.0.0.2, .3, ...,
plus one for the server and one serving the bare git repository (the deploy key is
the only key it accepts). Every command runs as a user runs it (`python -m deploy`,
once through scripts/ciirc-exec.sh), and every effect is checked on the robot side:
its files, its tmux sessions, its processes.
"""
from __future__ import annotations

import os
import re
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import Callable, Dict, Iterator, List, Tuple

import pytest

from deploy.loopback import LoopbackLab, keygen
from helpers import free_ports

ROBOTS = 3
STUB_PROCESS = "echo $$ > {name}.pid; echo {name} up; exec sleep 600"


def git(*args: str, cwd: Path) -> str:
    env = dict(os.environ, GIT_AUTHOR_NAME="t", GIT_AUTHOR_EMAIL="t@lab", GIT_COMMITTER_NAME="t",
               GIT_COMMITTER_EMAIL="t@lab")
    return subprocess.run(["git", *args], cwd=cwd, env=env, check=True, capture_output=True,
                          text=True, timeout=60).stdout.strip()


class Lab:
    """The test's lab: robots, a server and a git host, each a real sshd on its own address."""

    def __init__(self, tmp: Path, robots: int = ROBOTS) -> None:
        self.tmp = tmp
        self.ssh = LoopbackLab(tmp / "lab", robots + 2)
        self.robots = self.ssh.hosts[:robots]
        self.server, self.git_host = self.ssh.hosts[robots:]
        deploy_key = keygen(tmp / "deploy_key", "deploy")
        self.git_host.authorized_keys.write_text(Path(str(deploy_key) + ".pub").read_text())
        (tmp / "git_known_hosts").write_text(self.git_host.known_hosts_line())
        self.source = tmp / "src"
        self.source.mkdir()
        git("init", "-q", "-b", "main", cwd=self.source)
        self.commit("first")
        self.origin = tmp / "origin.git"
        git("clone", "-q", "--bare", str(self.source), str(self.origin), cwd=tmp)
        git("remote", "add", "origin", str(self.origin), cwd=self.source)
        (tmp / "arrived").mkdir()
        (tmp / "robot_definitions.txt").write_text("".join(
            "{} {} {} {} tb{} red\n".format(i + 1, h.address, 20000 + i, self.ssh.user, i + 1)
            for i, h in enumerate(self.robots)))
        self.write_config()
        self.ssh.start()
        self.ssh.pin_host_keys()

    def write_config(self, robot_build: str = "", extra: str = "", runner: str = "") -> None:
        build = robot_build or (
            # every robot waits until all have arrived: passes only if they build at once
            'touch {a}/{{id}}; n=0; while [ $(ls {a} | wc -l) -lt {count} ] && [ $n -lt 300 ]; '
            'do sleep 0.1; n=$((n + 1)); done; [ $(ls {a} | wc -l) -ge {count} ] && '
            'echo "built {{id}} at $(git rev-parse --short HEAD)" | tee built.txt').format(
                a=self.tmp / "arrived", count=len(self.robots))
        (self.tmp / "deploy.yaml").write_text("""\
repository: ssh://{user}@{git.address}:{port}{origin}
branch: main
deploy_key: deploy_key
git_known_hosts: git_known_hosts
login_key: {key}
known_hosts: {known}
log_dir: logs
timeouts:
  connect: 10
  command: 60
  stop: 10
  start_check: 0.5
{extra}
server:
  host: {server.address}
  user: {user}
  port: {port}
  path: ~/fleetcontrol
  build: echo "server built at $(git rev-parse --short HEAD)"
  processes:
    manager: {manager}
robots:
  port: {port}
  path: ~/fleetcontrol
  build: {build}
  processes:
    runner: {runner}
""".format(user=self.ssh.user, git=self.git_host, port=self.ssh.port, origin=self.origin,
           key=self.ssh.client_key, known=self.ssh.known_hosts, server=self.server,
           build=quote_yaml(build), extra=extra,
           manager=quote_yaml(STUB_PROCESS.format(name="manager")),
           runner=quote_yaml(runner or STUB_PROCESS.format(name="runner"))))

    def commit(self, message: str) -> str:
        (self.source / "README").write_text(message + "\n")
        git("add", "README", cwd=self.source)
        git("commit", "-q", "-m", message, cwd=self.source)
        return git("rev-parse", "HEAD", cwd=self.source)

    def push(self, message: str) -> str:
        sha = self.commit(message)
        git("push", "-q", "origin", "main", cwd=self.source)
        return sha

    def deploy(self, *args: str, stdin: str = "") -> subprocess.CompletedProcess:
        return subprocess.run(
            [sys.executable, "-m", "deploy", *args, "--config", str(self.tmp / "deploy.yaml"),
             "--definitions", str(self.tmp / "robot_definitions.txt")],
            capture_output=True, text=True, timeout=180, input=stdin, cwd=self.tmp)

    def checkout(self, host: object) -> Path:
        return host.home / "fleetcontrol"  # type: ignore[attr-defined]

    def tmux_has(self, host: object, session: str) -> bool:
        env = dict(os.environ, TMUX_TMPDIR=str(host.tmux_dir))  # type: ignore[attr-defined]
        env.pop("TMUX", None)
        return subprocess.run(["tmux", "-L", "fleetcontrol", "has-session", "-t", "=" + session],
                              env=env, capture_output=True, timeout=30).returncode == 0

    def close(self) -> None:
        self.ssh.close()


def quote_yaml(text: str) -> str:
    return "'" + text.replace("'", "''") + "'"


def rows(stdout: str) -> Dict[str, Tuple[str, str]]:
    """target -> (OK/FAILED, detail) from the result table."""
    out = {}
    for line in stdout.splitlines():
        cells = re.split(r"\s{2,}", line.strip(), maxsplit=4)
        if len(cells) >= 4 and cells[2] in ("OK", "FAILED"):
            out[cells[0]] = (cells[2], cells[4] if len(cells) > 4 else "")
    return out


def alive(pid_file: Path) -> bool:
    """Whether the process is running (a zombie is not: a container's pid 1 may never reap)."""
    try:
        stat = Path("/proc/{}/stat".format(int(pid_file.read_text()))).read_text()
    except FileNotFoundError:
        return False
    return stat.rsplit(")", 1)[1].split()[0] != "Z"


@pytest.fixture
def lab(tmp_path: Path) -> Iterator[Lab]:
    made = Lab(tmp_path)
    try:
        yield made
    finally:
        made.close()


def test_init_update_build_start_status_stop_on_every_robot_at_once(lab: Lab) -> None:
    names = ["robot {}".format(i + 1) for i in range(ROBOTS)]

    init = lab.deploy("robots:init", "all")
    assert init.returncode == 0, init.stdout + init.stderr
    assert {n: r[0] for n, r in rows(init.stdout).items()} == {n: "OK" for n in names}
    for host in lab.robots:
        assert (lab.checkout(host) / "README").read_text() == "first\n"
        key = host.home / ".ssh" / "fleetcontrol_deploy_key"  # copied first, owner-only
        assert key.read_bytes() == (lab.tmp / "deploy_key").read_bytes()
        assert key.stat().st_mode & 0o077 == 0

    # A new commit upstream and a stray local edit on robot 2: update hard-resets to upstream.
    sha = lab.push("second")
    (lab.checkout(lab.robots[1]) / "README").write_text("edited on the robot\n")
    update = lab.deploy("robots:update:all")
    assert update.returncode == 0, update.stdout + update.stderr
    for host in lab.robots:
        assert git("rev-parse", "HEAD", cwd=lab.checkout(host)) == sha
        assert (lab.checkout(host) / "README").read_text() == "second\n"
    assert all("({})".format("main") in detail for _, detail in rows(update.stdout).values())

    build = lab.deploy("robots:build", "all")  # each robot's build waits for the others'
    assert build.returncode == 0, build.stdout + build.stderr
    for i, host in enumerate(lab.robots):
        assert (lab.checkout(host) / "built.txt").read_text() == "built {} at {}\n".format(
            i + 1, sha[:7])
        assert rows(build.stdout)["robot {}".format(i + 1)] == ("OK", "built {} at {}".format(
            i + 1, sha[:7]))

    start = lab.deploy("robots:start:all")
    assert start.returncode == 0, start.stdout + start.stderr
    for host in lab.robots:
        assert lab.tmux_has(host, "runner") and alive(lab.checkout(host) / "runner.pid")

    status = lab.deploy("robots:status")
    assert status.returncode == 0
    for name, (result, detail) in rows(status.stdout).items():
        assert result == "OK" and detail.startswith("runner running (pid ")
        assert detail.endswith("at {} (main)".format(sha[:7]))

    stop = lab.deploy("robots:stop")
    assert stop.returncode == 0
    assert {n: r for n, r in rows(stop.stdout).items()} == {n: ("OK", "stopped: runner")
                                                              for n in names}
    for host in lab.robots:
        assert not lab.tmux_has(host, "runner") and not alive(lab.checkout(host) / "runner.pid")
    logs = sorted(p.name for p in (lab.tmp / "logs").iterdir())
    assert logs == ["{}-robot{}.log".format(h.address, i + 1) for i, h in enumerate(lab.robots)]
    assert "robots:update:all on robot 1" in (lab.tmp / "logs" / logs[0]).read_text()


def test_the_server_side_through_ciirc_exec(lab: Lab, repo_root: Path) -> None:
    # its setup step links fleetctl into FLEETCONTROL_BIN_DIR: a scratch folder, not this machine's PATH
    env = dict(os.environ, FLEETCONTROL_BIN_DIR=str(lab.tmp))

    def script(*args: str) -> subprocess.CompletedProcess:
        return subprocess.run(
            [str(repo_root / "scripts" / "ciirc-exec.sh"), *args, "--config",
             str(lab.tmp / "deploy.yaml")], capture_output=True, text=True, timeout=300, env=env)

    for command in ("server:init", "server:update", "server:build", "server:start"):
        result = script(command)
        assert result.returncode == 0, result.stdout + result.stderr
    assert rows(result.stdout) == {"server": ("OK", "started: manager")}
    assert lab.tmux_has(lab.server, "manager")
    assert alive(lab.checkout(lab.server) / "manager.pid")
    status = script("server:status")
    assert rows(status.stdout)["server"][1].startswith("manager running (pid ")
    assert script("server:stop").returncode == 0
    assert not lab.tmux_has(lab.server, "manager")
    assert rows(script("server:status").stdout)["server"][1].startswith("manager stopped; at ")


def test_a_robot_whose_sshd_is_down_fails_alone_and_the_others_finish(lab: Lab) -> None:
    assert lab.deploy("robots:init", "all").returncode == 0
    sha = lab.push("second")
    lab.robots[1].stop()
    update = lab.deploy("robots:update", "all")
    assert update.returncode == 1
    table = rows(update.stdout)
    assert table["robot 2"][0] == "FAILED"
    assert "cannot connect to {}:{}: Connection refused".format(
        lab.robots[1].address, lab.ssh.port) in table["robot 2"][1]
    assert table["robot 1"][0] == table["robot 3"][0] == "OK"
    assert "2 of 3 OK; 1 FAILED" in update.stdout
    for host in (lab.robots[0], lab.robots[2]):
        assert git("rev-parse", "HEAD", cwd=lab.checkout(host)) == sha
    assert git("rev-parse", "HEAD", cwd=lab.checkout(lab.robots[1])) != sha


def test_a_changed_host_key_is_refused_even_when_accepting_new_ones(lab: Lab) -> None:
    pinned = lab.ssh.known_hosts.read_text()
    robot = lab.robots[0]
    robot.stop()
    robot.new_host_key()
    robot.start()
    status = lab.deploy("robots:status", "--accept-new-host-keys")
    assert status.returncode == 1
    result, detail = rows(status.stdout)["robot 1"]
    assert result == "FAILED"
    assert detail.startswith("HOST KEY CHANGED for [{}]:{}: it offers ssh-ed25519 SHA256:".format(
        robot.address, lab.ssh.port))
    assert "ssh-keygen -R '[{}]:{}' -f {}".format(
        robot.address, lab.ssh.port, lab.ssh.known_hosts) in detail
    assert rows(status.stdout)["robot 2"][0] == "OK"
    assert lab.ssh.known_hosts.read_text() == pinned  # nothing was replaced or added


def test_unknown_host_keys_are_refused_until_accepted_deliberately(lab: Lab) -> None:
    lab.ssh.known_hosts.write_text("")
    refused = lab.deploy("robots:status", "1")
    assert refused.returncode == 1
    detail = rows(refused.stdout)["robot 1"][1]
    assert detail.startswith("unknown host key: [{}]:{} offers ssh-ed25519 SHA256:".format(
        lab.robots[0].address, lab.ssh.port)) and "--accept-new-host-keys" in detail
    assert lab.deploy("robots:status", "--accept-new-host-keys").returncode == 0
    assert sorted(lab.ssh.known_hosts.read_text().splitlines()) == sorted(
        h.known_hosts_line().strip() for h in lab.robots)
    assert lab.deploy("robots:status").returncode == 0  # pinned now


def test_a_process_that_dies_at_start_and_a_step_past_its_timeout_fail_with_their_reason(
        lab: Lab) -> None:
    lab.write_config(robot_build="echo $$ > build.pid; exec sleep 120",
                     runner="echo roslaunch: package agv_package not found; exit 3")
    lab.deploy("robots:init", "1")
    text = (lab.tmp / "deploy.yaml").read_text().replace("command: 60", "command: 1")
    (lab.tmp / "deploy.yaml").write_text(text)
    build = lab.deploy("robots:build", "1")
    assert build.returncode == 1
    assert rows(build.stdout)["robot 1"] == ("FAILED", "build: timed out after 1 s")
    assert not alive(lab.checkout(lab.robots[0]) / "build.pid")  # ended on the robot too
    (lab.tmp / "deploy.yaml").write_text(text.replace("command: 1", "command: 60"))  # start: no race with 1 s
    start = lab.deploy("robots:start", "1")
    assert start.returncode == 1
    assert rows(start.stdout)["robot 1"] == (
        "FAILED", "start failed (exit 1): runner exited 3 right after starting: roslaunch: "
                  "package agv_package not found")
    assert rows(lab.deploy("robots:status", "1").stdout)["robot 1"][1].startswith(
        "runner exited 3: roslaunch: package agv_package not found; at ")


def test_robots_ssh_opens_a_shell_in_the_checkout(lab: Lab) -> None:
    lab.deploy("robots:init", "2")
    shell = lab.deploy("robots:ssh", "2", stdin="pwd\necho home=$HOME\n")
    assert shell.returncode == 0, shell.stderr
    assert str(lab.checkout(lab.robots[1])) in shell.stdout.splitlines()
    assert "home={}".format(lab.robots[1].home) in shell.stdout
    inspect = lab.deploy("robots:inspect", "2")
    assert inspect.returncode == 1 and "not running: runner" in inspect.stdout


def test_net_check_reports_each_robots_state(tmp_path: Path) -> None:
    from fleet_common.robots import parse_robot_definitions
    from fleet_common.transport.curve_keys import load_robot_keys, make_keys
    from virtual_fleet.fleet import FleetThread, VirtualFleet

    # robot 1: sshd and a virtual robot on 127.0.0.1; robot 2: sshd, nothing on its
    # command port; robot 3: nothing at all.
    ssh = LoopbackLab(tmp_path / "lab", 2, first=1)
    cmd1, cmd2, cmd3, feedback = free_ports(4)
    text = "1 127.0.0.1 {} {u} tb1 red\n2 127.0.0.2 {} {u} tb2 green\n3 127.0.0.3 {} {u} tb3 " \
        "blue\n".format(cmd1, cmd2, cmd3, u=ssh.user)
    (tmp_path / "defs.txt").write_text(text)
    (tmp_path / "deploy.yaml").write_text(
        "repository: /nowhere.git\nlogin_key: {}\nknown_hosts: {}\nrobots:\n  port: {}\n"
        "  build: 'true'\n".format(ssh.client_key, ssh.known_hosts, ssh.port))
    make_keys(tmp_path / "keys")
    fleet = VirtualFleet(parse_robot_definitions(text)[:1], keys=load_robot_keys(tmp_path / "keys"),
                         feedback_base=feedback)
    try:
        ssh.start()
        ssh.pin_host_keys()
        with FleetThread(fleet):
            result = subprocess.run(
                [sys.executable, "-m", "deploy", "net:check", "--config",
                 str(tmp_path / "deploy.yaml"), "--definitions", str(tmp_path / "defs.txt"),
                 "--keys", str(tmp_path / "keys"), "--wire-timeout", "10", "--feedback-base",
                 str(feedback)], capture_output=True, text=True, timeout=120)
    finally:
        ssh.close()
    assert result.returncode == 1, result.stderr
    table: List[List[str]] = [re.split(r"\s{2,}", line.strip()) for line in
                              result.stdout.splitlines()[1:4]]
    assert table[0] == ["robot 1", "127.0.0.1", "yes", "ok", "{} open".format(cmd1),
                        "ok: idle at (0.0, 0.0)"]
    assert table[1] == ["robot 2", "127.0.0.2", "yes", "ok", "{} refused".format(cmd2),
                        "not tried (port refused)"]
    assert table[2] == ["robot 3", "127.0.0.3", "yes", "down (refused)",
                        "{} refused".format(cmd3), "not tried (port refused)"]
    assert result.stdout.splitlines()[-1] == "1 of 3 robots fully reachable"


def net_check(tmp_path: Path, *args: str) -> str:
    """net:check's wire column for robot 1 of tmp_path/defs.txt (no sshd: SSH is down on purpose)."""
    (tmp_path / "deploy.yaml").write_text("repository: /nowhere.git\nknown_hosts: {}\nrobots:\n"
                                          "  port: {}\n  build: 'true'\n".format(
                                              tmp_path / "known_hosts", free_ports(1)[0]))
    result = subprocess.run([sys.executable, "-m", "deploy", "net:check", "1", "--config",
                             str(tmp_path / "deploy.yaml"), "--definitions", str(tmp_path / "defs.txt"),
                             *args], capture_output=True, text=True, timeout=120)
    assert result.returncode == 1, result.stderr
    return re.split(r"\s{2,}", result.stdout.splitlines()[1].strip())[-1]


def test_net_check_listens_without_disturbing_a_manager_and_hello_takes_the_robot_over(
        tmp_path: Path) -> None:
    import zmq

    from fleet_common.robots import parse_robot_definitions
    from fleet_common.transport.curve_keys import (load_manager_keys, load_robot_keys,
                                                   make_keys)
    from fleet_common.wire import Status
    from fleet_common.wire.link_events import LinkDown, LinkUp, RobotReply
    from fleet_common.transport.links import LinkSet
    from fleet_common.transport.robot_link import RobotLink
    from virtual_fleet.fleet import FleetThread, VirtualFleet

    command, feedback = free_ports(2)
    text = "1 127.0.0.1 {} tb tb1 red\n".format(command)
    (tmp_path / "defs.txt").write_text(text)
    make_keys(tmp_path / "keys")
    make_keys(tmp_path / "other")
    robots = parse_robot_definitions(text)
    fleet = VirtualFleet(robots, keys=load_robot_keys(tmp_path / "keys"), feedback_base=feedback)
    context = zmq.Context()
    links = LinkSet([RobotLink(context, robots[0], "manager-epoch",
                               keys=load_manager_keys(tmp_path / "keys"))])
    # the manager's side, served all along as a manager serves it (heartbeats included), in a
    # thread of its own while net:check runs
    events: List[object] = []
    done = threading.Event()
    ask = threading.Event()  # the serving thread asks the robot for its status (the link is its own)

    def serve() -> None:
        while not done.is_set():
            if ask.is_set():
                ask.clear()
                links[1].get_status()
            events.extend(links.poll(0.05))

    def downs() -> List[LinkDown]:
        return [e for e in list(events) if isinstance(e, LinkDown)]

    def wait_until(condition: Callable[[], bool], what: str, timeout: float = 10.0) -> None:
        deadline = time.monotonic() + timeout
        while not condition():
            if time.monotonic() > deadline:
                pytest.fail("timed out waiting for " + what)
            time.sleep(0.05)

    def still_in_charge() -> None:
        """The manager's link is still the robot's: a status round trip comes back (a robot taken
        over would have said bye to it first)."""
        before = len(events)
        ask.set()
        wait_until(lambda: any(isinstance(e, RobotReply) and isinstance(e.reply, Status)
                               for e in list(events)[before:]) or bool(downs()), "a status reply")
        assert downs() == []

    base = ("--keys", str(tmp_path / "keys"), "--wire-timeout", "5", "--feedback-base", str(feedback))
    server = threading.Thread(target=serve)
    try:
        with FleetThread(fleet):
            server.start()
            wait_until(lambda: any(isinstance(e, LinkUp) for e in list(events)), "the manager's link to come up")
            wire = net_check(tmp_path, *base)
            assert wire == "ok: idle at (0.0, 0.0)"
            still_in_charge()  # listening left the manager in charge
            wire = net_check(tmp_path, "--keys", str(tmp_path / "other"), "--wire-timeout", "1",
                             "--feedback-base", str(feedback))
            assert wire == "no pose feedback on port {} within 1 s (CurveZMQ keys, or the robot's " \
                "--no-curve?)".format(feedback)
            still_in_charge()
            wire = net_check(tmp_path, *base, "--hello")
            assert wire == "ok: idle at (0.0, 0.0)"
            wait_until(downs, "the manager's link to be taken over")
            assert "took over robot 1" in downs()[0].reason  # as its --help warns
    finally:
        done.set()
        if server.is_alive():
            server.join(10)
        links.close()
        context.term()


def test_a_machine_that_accepts_but_never_speaks_ssh_fails_within_the_connect_timeout(
        tmp_path: Path) -> None:
    import socket

    silent = socket.socket()  # the kernel completes the handshake; nobody ever answers
    silent.bind(("127.0.0.1", 0))
    silent.listen(8)
    port = silent.getsockname()[1]
    try:
        (tmp_path / "defs.txt").write_text("1 127.0.0.1 {} root tb1 red\n".format(free_ports(1)[0]))
        (tmp_path / "deploy.yaml").write_text(
            "repository: /nowhere.git\nknown_hosts: {}\ntimeouts:\n  connect: 1\nrobots:\n"
            "  port: {}\n  build: 'true'\n".format(tmp_path / "known_hosts", port))
        result = subprocess.run(
            [sys.executable, "-m", "deploy", "robots:status", "--config",
             str(tmp_path / "deploy.yaml"), "--definitions", str(tmp_path / "defs.txt")],
            capture_output=True, text=True, timeout=120)
    finally:
        silent.close()
    assert result.returncode == 1
    assert rows(result.stdout)["robot 1"] == ("FAILED", "127.0.0.1:{}: SSH failed: connected, "
                                              "but no SSH greeting within 1 s (not an SSH "
                                              "server, or overloaded?)".format(port))


def test_robots_inspect_attaches_to_the_running_process_and_ctrl_b_d_detaches(lab: Lab) -> None:
    import pty
    import select
    import time

    lab.deploy("robots:init", "1")
    assert lab.deploy("robots:start", "1").returncode == 0
    master, slave = pty.openpty()  # tmux attach needs a terminal: give it one
    process = subprocess.Popen(
        [sys.executable, "-m", "deploy", "robots:inspect", "1", "--config",
         str(lab.tmp / "deploy.yaml"), "--definitions", str(lab.tmp / "robot_definitions.txt")],
        stdin=slave, stdout=slave, stderr=slave, env=dict(os.environ, TERM="xterm"),
        start_new_session=True)
    os.close(slave)
    seen = b""
    try:
        # Ctrl-b d every half second until tmux says it detached: keys typed before the
        # client attached are dropped, so type them again rather than guess when it is ready.
        give_up, next_keys = time.monotonic() + 60, 0.0
        while time.monotonic() < give_up:
            if b"[detached (from session runner)]" in seen or process.poll() is not None:
                break
            if time.monotonic() >= next_keys:
                os.write(master, b"\x02d")
                next_keys = time.monotonic() + 0.5
            ready, _, _ = select.select([master], [], [], 0.1)
            try:
                seen += os.read(master, 65536) if ready else b""
            except OSError:  # the terminal's other end closed
                break
        assert process.wait(timeout=60) == 0, seen[-2000:]
    finally:
        if process.poll() is None:
            process.kill()
            process.wait(timeout=10)
        try:
            while select.select([master], [], [], 0)[0]:
                seen += os.read(master, 65536)
        except OSError:
            pass
        os.close(master)
    assert b"[detached (from session runner)]" in seen  # only an attached client detaches
    assert lab.tmux_has(lab.robots[0], "runner")  # detaching leaves it running
    assert alive(lab.checkout(lab.robots[0]) / "runner.pid")
