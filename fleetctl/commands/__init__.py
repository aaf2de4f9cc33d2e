"""One module per `fleetctl` subcommand, listed in `COMMANDS`: the one registry.

Adding a subcommand is one module here and one line in `COMMANDS`:

    ("name-on-the-command-line", "module_in_this_package", "one-line help"),

The module defines `add_arguments(parser)` and `run(args) -> int` (the exit
status), optionally `DESCRIPTION` (the longer text of `fleetctl NAME --help`)
and `PASSTHROUGH = True` (it receives what follows `--` unparsed). The help
line lives here, not in the module, so that `fleetctl --help` imports no
command module and a command imports only its own module: start-up stays
fast whatever the other commands need (numpy, ZeroMQ, Tk). A module may still
define `NAME`/`HELP`; tests check they agree with its line here.
"""
from __future__ import annotations

COMMANDS: tuple[tuple[str, str, str], ...] = (
    ("info", "info", "summarise any supported file (map, instance, solution, scen, legacy XML, robot definitions)"),
    ("validate", "validate", "check a mapf-IR solution: cells, moves, vertex and swap conflicts, rotations, header claims"),
    ("repair", "repair", "repair a solution's rotations (robots cannot perform them); writes the same format"),
    ("convert", "convert", "convert between mapf-IR and lab orientation; scen -> instance; legacy XML -> mapf-IR"),
    ("solve", "solve", "plan an instance (or a .scen) with pibt, lacam, cbs, ecbs, pp, pibt-turns or mapf-IR; write a solution"),
    ("demo", "demo", "the lab scenario on virtual robots, steered by the manager, watched in the live console"),
    ("keys", "keys", "make the CurveZMQ key pairs of the manager, the robots and the consoles"),
    ("virtual-fleet", "virtual_fleet", "run one virtual robot per robot definition on 127.0.0.1, speaking the robot protocol"),
    ("console", "console", "watch and steer a running fleet (--manager), or play a mapf-IR solution (--replay)"),
    ("simulate", "simulate", "run a solution on simulated robots with delays: metrics, collisions, who waited for whom"),
    ("manager", "manager", "execute a plan on the robots (real or virtual), steered from consoles"),
    ("trace", "trace", "a run folder as a mapf-IR solution (where robots really were) and its summary"),
    ("experiment", "experiment", "run a sweep (plans x strategies x delay models x seeds) on simulated robots: a results table"),
    ("report", "report", "an HTML report with plots of a sweep's results table or of one run folder"),
    ("vicon", "vicon", "the Vicon motion-capture stream: listen to it, calibrate it, or simulate Tracker"),
)

#: The commands that read and write files and end, in one thread, their files written in `with`
#: blocks: `fleetctl` loads numpy's unused parts lazily for them and ends their process without the
#: interpreter's teardown (`fleetctl.one_shot`). Add one only after checking its code for that.
ONE_SHOT = frozenset({"info", "validate", "repair", "convert", "solve", "trace"})
