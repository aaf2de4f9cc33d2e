"""What runs on the server and the robots: each action as bash steps, built from values only.

Nothing here opens a connection: `steps(action, target, config)` returns the
steps (a title, a bash script, what goes to its stdin), which --dry-run prints
and `ssh.run_steps` runs. Each script's last output line is what the result
table shows. init/update: `checkout`; build: the side's build command in the
checkout; start/stop/status: `sessions`.
"""
from __future__ import annotations

from typing import List

from .checkout import init_script, key_steps, update_script
from .config import DeployConfig
from .sessions import start_script, status_script, stop_script
from .shell import Step, enter
from .targets import Target

__all__ = ["ACTIONS", "steps", "format_steps"]

ACTIONS = ("init", "update", "build", "start", "stop", "status")


def steps(action: str, target: Target, config: DeployConfig) -> List[Step]:
    """The steps of `action` (one of ACTIONS) on `target`, in order."""
    if action == "init":
        return key_steps(config) + [Step("clone", init_script(target, config))]
    if action == "update":
        return key_steps(config) + [Step("update", update_script(target, config))]
    if action == "build":
        return [Step("build", enter(target) + target.build + "\n")]
    if action == "start":
        return [Step("start", start_script(target, config))]
    if action == "stop":
        return [Step("stop", stop_script(config))]
    if action == "status":
        return [Step("status", status_script(target, config))]
    raise ValueError("unknown action {!r}; expected one of {}".format(action, ", ".join(ACTIONS)))


def format_steps(target: Target, step_list: List[Step]) -> str:
    """What --dry-run prints for one target: each step's title and script."""
    out = ["# {} ({})".format(target.name, target.address)]
    for step in step_list:
        source = " < {} ({} bytes)".format(step.stdin_name, len(step.stdin)) if step.stdin else ""
        out.append("## {}{}".format(step.title, source))
        out.append(step.script.rstrip("\n"))
    return "\n".join(out)
