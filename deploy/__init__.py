"""Deployment over SSH: set up, update, build, start and stop the server and every robot.

The thesis's `ciirc-exec.sh` commands (6.1.2), done in Python so that the whole
fleet is handled at once: `scripts/ciirc-exec.sh robots:update all` runs
`python -m deploy robots:update all` after setup.

Theory of operation: deploy.yaml (`config`) says where the code comes from and
how each side builds and runs; robot_definitions.txt says which robots there
are (`targets`). Each action is a list of bash steps built from those values
alone (`remote`, from `checkout` for the code and `sessions` for the tmux
processes, on `shell`'s building blocks; also what --dry-run prints).
`fanout` runs one job per machine in its own thread: `ssh` connects with
paramiko (keys only, host keys pinned by `hostkeys`, timeouts everywhere),
runs the steps and logs their output to the machine's own file; the result is
one table row per machine and exit status 1 if any failed. `interactive` hands a terminal to OpenSSH for ssh/inspect;
`netcheck` probes TCP, SSH and the wire protocol. `loopback` starts real sshd
processes on 127.0.0.x standing in for robots, for tests and the benchmark.
"""
