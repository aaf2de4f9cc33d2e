"""The manager's settings, from its command line (`main.py`) or a test."""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import List, Optional

from fleet_common.control.messages import DEFAULT_ENDPOINT
from fleet_common.robot_size import TURTLEBOT2, RobotSize

__all__ = ["ManagerSettings", "STALE_AFTER"]

#: Seconds without a pose before a robot's position (its own, or Vicon's) counts as stale.
STALE_AFTER = 0.5


@dataclass
class ManagerSettings:
    strategy: str = "adg"
    lookahead: int = 1
    bind: str = DEFAULT_ENDPOINT
    log_dir: Optional[Path] = None
    step_time: float = 2.5       # s a plan step is expected to take (the planned-position ghost)
    state_rate: float = 20.0     # state messages per second, at least
    state_max_rate: float = 50.0  # and at most, when news (poses, replies) comes faster
    stale_after: float = STALE_AFTER  # s without a pose before a robot's position is stale
    replan_limit: float = 5.0    # s a replan may take
    to_starts_limit: float = 10.0  # s planning the way to the starts may take
    preturn: bool = True         # robots turn towards their next cell while they wait
    definitions: Optional[Path] = None
    map_dirs: List[Path] = field(default_factory=list)  # where `load` looks for map files
    plan_dirs: List[Path] = field(default_factory=list)  # folders whose plans consoles may load by name
    vicon_port: Optional[int] = None  # Vicon Tracker's UDP stream (None: no Vicon)
    vicon_bind: str = "0.0.0.0"
    frames: Optional[Path] = None     # frames file with vicon_to_base (None: the lab's)
    size: RobotSize = TURTLEBOT2      # the robots' size (the definitions' size line)
    accept: bool = False              # take every replan proposal at once (--accept, for scripts)
    reroute: str = "off"              # reroute held-up robots: off, propose or auto (`rerouting`)
    reroute_timed: bool = True        # a look stops after its rule's budget (tests: to the end)
    reroute_scope: str = "held"       # whom a reroute may give new paths: held or all (`RerouteRule.scope`)
    #: plans are trimmed of moves that do not bring a robot in sooner (`planning.trim`): the first
    #: and any loaded later, and the held scope's reroutes' plans before their hand-over
    #: (`RerouteRule.trim`; scope all trims its own whatever this says)
    trim: bool = False
    #: plan steps a robot's quarter turn in place takes, which a reroute's detour costs at each
    #: corner more (`RerouteRule.per_turn`): a TurtleBot's (1.5 rad/s) is about half a nominal move
    quarter_turn_steps: float = 0.5
