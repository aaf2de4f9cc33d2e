"""Deployment without machines: deploy.yaml's checks, robot selection, the scripts' text,
--dry-run, and ciirc-exec.sh's list of subcommands (no connection is made here)."""
from __future__ import annotations

import dataclasses
import os
import subprocess
import sys
from pathlib import Path
from typing import List

import paramiko
import pytest

from deploy.cli import COMMANDS
from deploy.config import parse_config, read_config
from deploy.errors import DeployConfigError, DeployError
from deploy.hostkeys import PinnedHostKeys
from deploy.remote import steps
from deploy.sessions import status_script
from deploy.targets import robot_targets, select_robots, server_target
from fleet_common.robots import parse_robot_definitions

MINIMAL = """\
repository: /srv/fleet.git
robots:
  build: make
  processes:
    runner: run --robot {id} --home ${HOME}
"""


def deploy_cli(*args: object, cwd: Path) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "deploy", *map(str, args)], capture_output=True,
                          text=True, timeout=60, cwd=cwd)


def test_the_shipped_config_reads_and_names_a_server_and_the_robots_processes(repo_root: Path) -> None:
    config = read_config(repo_root / "deploy.yaml")
    assert config.server is not None and config.server.processes
    assert [name for name, _ in config.robots.processes] == ["runner"]
    # the robots' roslaunch gives up on a node well inside the stop timeout, with the options
    # the ROS tests run roslaunch with (so those options are known to work)
    from ros_procs import ROSLAUNCH
    assert " ".join(ROSLAUNCH) + " agv_package robot.launch" in dict(config.robots.processes)["runner"]
    assert float(ROSLAUNCH[2]) + float(ROSLAUNCH[4]) < config.timeouts.stop
    assert config.known_hosts.is_absolute() and config.log_dir == repo_root / "logs" / "deploy"


@pytest.mark.parametrize("text, line, message", [
    (MINIMAL + "password: hunter2\n", 6, "unknown key (key authentication only"),
    (MINIMAL.replace("build: make", "build: make\n  port: 70000"), 4, "robots.port: expected a port"),
    (MINIMAL + "timeouts:\n  connect: -1\n", 7, "timeouts.connect: expected a positive number"),
    (MINIMAL + "timeouts:\n  conect: 5\n", 7, "unknown key; expected one of: connect, command"),
    (MINIMAL.replace("runner:", "'run ner':"), 5, "a process name is a tmux session name"),
    (MINIMAL.replace("repository: /srv/fleet.git\n", ""), 1, "repository: missing"),
    (MINIMAL + "server:\n  host: 10.0.0.1\n  build: x\n", 7, "server.user: missing"),
    (MINIMAL + "robots: {}\n", 6, "duplicate key 'robots'"),
    (MINIMAL + "branch: [main\n", 7, "not valid YAML"),
])
def test_config_errors_name_the_line_and_what_was_expected(text: str, line: int, message: str) -> None:
    with pytest.raises(DeployConfigError) as caught:
        parse_config(text, "deploy.yaml")
    assert caught.value.line == line, str(caught.value)
    assert message in str(caught.value) and str(caught.value).startswith("deploy.yaml:")


def test_a_bad_config_is_one_line_and_exit_2(tmp_path: Path) -> None:
    (tmp_path / "deploy.yaml").write_text(MINIMAL + "password: hunter2\n")
    result = deploy_cli("robots:status", "--config", tmp_path / "deploy.yaml", cwd=tmp_path)
    assert result.returncode == 2 and result.stdout == ""
    assert result.stderr.count("\n") == 1 and "deploy.yaml:6:11: password: unknown key" in result.stderr


def test_robots_are_chosen_by_id_or_all_and_values_fill_their_commands() -> None:
    robots = parse_robot_definitions("1 10.0.0.1 9001 tb r1 red\n2 10.0.0.2 9002 pi r2 blue\n")
    assert [r.id for r in select_robots(robots, ["2", "1", "2"], "defs")] == [1, 2]
    assert select_robots(robots, ["all"], "defs") == robots
    with pytest.raises(DeployError, match=r"no robot '7' in defs; defined: 1, 2 \(or 'all'\)"):
        select_robots(robots, ["7"], "defs")
    target = robot_targets(parse_config(MINIMAL, "deploy.yaml"), robots)[1]
    assert (target.user, target.host, target.port, target.log_name) == ("pi", "10.0.0.2", 22,
                                                                          "10.0.0.2-robot2")
    # {id} filled in; shell braces such as ${HOME} left alone
    assert target.processes == (("runner", "run --robot 2 --home ${HOME}"),)
    with pytest.raises(DeployError, match="no server: section"):
        server_target(parse_config(MINIMAL, "deploy.yaml"))


def test_update_copies_the_deploy_key_first_and_resets_hard(tmp_path: Path) -> None:
    key = tmp_path / "deploy_key"
    key.write_text("-----BEGIN OPENSSH PRIVATE KEY-----\nsecret\n")
    config = parse_config(MINIMAL + "deploy_key: deploy_key\nbranch: lab-demo\n",
                          str(tmp_path / "deploy.yaml"))
    robots = parse_robot_definitions("3 10.0.0.3 9003 tb r3 red\n")
    plan = steps("update", robot_targets(config, robots)[0], config)
    assert [s.title for s in plan] == [
        "install the deploy key (~/.ssh/fleetcontrol_deploy_key)", "update"]
    assert plan[0].stdin == key.read_bytes() and plan[0].stdin_name == str(key)
    assert "secret" not in plan[0].script  # the key travels on stdin, never in a command line
    assert "git checkout --force -B lab-demo refs/remotes/origin/lab-demo" in plan[1].script
    (tmp_path / "deploy_key").unlink()
    with pytest.raises(DeployError, match="deploy_key .*deploy_key .*cannot read"):
        steps("init", robot_targets(config, robots)[0], config)


def test_dry_run_prints_every_robots_steps_and_connects_to_nothing(repo_root: Path) -> None:
    # The shipped definitions name the lab's real addresses: --dry-run must not touch them.
    result = deploy_cli("robots:update:all", "--dry-run", cwd=repo_root)
    assert result.returncode == 0, result.stderr
    for n in range(1, 6):
        assert "# robot {0} (turtlebot@192.168.2.1{0}:22)".format(n) in result.stdout
    assert result.stdout.count("## update") == 5
    ssh = deploy_cli("robots:ssh", "3", "--dry-run", cwd=repo_root)
    assert ssh.stdout.startswith("ssh -t -p 22 ") and "StrictHostKeyChecking=yes" in ssh.stdout
    assert "turtlebot@192.168.2.13" in ssh.stdout


def test_robots_must_be_named_for_commands_that_change_them(repo_root: Path) -> None:
    result = deploy_cli("robots:start", cwd=repo_root)
    assert result.returncode == 2
    assert result.stderr.strip() == "ciirc-exec.sh robots:start: name the robots: one or more " \
        "ids, or 'all'"


def help_lines(text: str) -> List[str]:
    return [line.strip() for line in text.splitlines() if line.startswith("  ")]


def test_ciirc_exec_lists_every_deploy_command_with_the_same_help(repo_root: Path) -> None:
    result = subprocess.run([str(repo_root / "scripts" / "ciirc-exec.sh"), "--help"],
                            capture_output=True, text=True, timeout=60)
    listed = {line.split(None, 1)[0]: line.split(None, 1)[1] for line in help_lines(result.stdout)}
    for name, (_, _, text) in COMMANDS.items():
        assert listed.get(name) == text


def test_accepting_a_new_host_key_appends_one_line_and_keeps_the_rest(tmp_path: Path) -> None:
    known = tmp_path / "ssh" / "known_hosts"
    known.parent.mkdir()
    known.write_text("@cert-authority *.lab ssh-ed25519 AAAA\nold.host ssh-rsa BBBB")  # no newline
    key = paramiko.Ed25519Key.from_private_key_file(str(_keygen(tmp_path / "k")))
    policy = PinnedHostKeys(known, accept_new=True)
    policy.missing_host_key(paramiko.SSHClient(), "[127.0.0.9]:2222", key)
    lines = known.read_text().splitlines()
    assert lines[:2] == ["@cert-authority *.lab ssh-ed25519 AAAA", "old.host ssh-rsa BBBB"]
    assert lines[2] == "[127.0.0.9]:2222 ssh-ed25519 " + key.get_base64()
    refuse = PinnedHostKeys(known, accept_new=False)
    with pytest.raises(DeployError, match=r"unknown host key: \[127.0.0.9\]:2222 offers "
                                          r"ssh-ed25519 SHA256:.*--accept-new-host-keys"):
        refuse.missing_host_key(paramiko.SSHClient(), "[127.0.0.9]:2222", key)


def _keygen(path: Path) -> Path:
    from deploy.loopback import keygen
    return keygen(path)


def test_a_job_that_breaks_is_a_failed_row_with_its_log_and_the_others_finish(tmp_path: Path) -> None:
    from deploy.fanout import exit_status, format_table, run_all
    from deploy.targets import Target

    targets = [Target("robot {}".format(i), "10.0.0.{}".format(i), 22, "tb", "~/f", "make", (), i)
               for i in (1, 2, 3)]

    def job(target: Target, log) -> str:
        log.write("working on {}\n".format(target.name))
        if target.robot_id == 2:
            raise KeyError("bug")
        return "done {}".format(target.robot_id)

    outcomes = run_all(targets, job, "robots:update", tmp_path / "logs")
    assert [(o.ok, o.detail) for o in outcomes] == [
        (True, "done 1"), (False, "internal error: KeyError: 'bug'"), (True, "done 3")]
    assert exit_status(outcomes) == 1
    assert format_table(outcomes).splitlines()[-1] == "2 of 3 OK; 1 FAILED; logs in {}".format(
        tmp_path / "logs")
    log = (tmp_path / "logs" / "10.0.0.2-robot2.log").read_text()
    assert "robots:update on robot 2 (tb@10.0.0.2:22)" in log and "KeyError: 'bug'" in log


# tmux reports a pane dead as soon as its terminal closes; its exit status only once it has
# reaped the process. This stand-in answers the first two questions in that gap, as the real
# one did on a CI run ("runner exited  right after starting").
RACING_TMUX = """#!/bin/sh
for arg; do last=$arg; done
case " $* " in
  *" has-session "*) exit 0 ;;
  *" list-sessions "*) exit 0 ;;
  *" display-message "*)
    n=$(cat asked 2>/dev/null || echo 0); echo $((n + 1)) > asked
    if [ "$n" -lt 2 ]; then echo "exited "; else echo "exited 3"; fi ;;
esac
"""


def test_status_waits_for_tmux_to_know_how_a_process_that_just_died_exited(tmp_path: Path) -> None:
    fake = tmp_path / "bin"
    fake.mkdir()
    (fake / "tmux").write_text(RACING_TMUX)
    (fake / "tmux").chmod(0o755)
    (tmp_path / "logs").mkdir()
    (tmp_path / "logs" / "runner.log").write_text("roslaunch: package agv_package not found\r\n")
    config = parse_config(MINIMAL, "deploy.yaml")
    robot = robot_targets(config, parse_robot_definitions("1 127.0.0.1 9001 tb r1 red\n"))[0]
    robot = dataclasses.replace(robot, path=str(tmp_path))
    out = subprocess.run(["sh", "-c", status_script(robot, config)], capture_output=True,
                         text=True, timeout=30, cwd=tmp_path,
                         env={**os.environ, "PATH": "{}:{}".format(fake, os.environ["PATH"])})
    assert out.stdout.splitlines()[0] == "runner: exited 3: roslaunch: package agv_package not found"
