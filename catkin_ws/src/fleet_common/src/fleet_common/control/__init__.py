"""The manager <-> console protocol, sans-I/O (thesis 5.1.1, 5.4).

    messages   what a console sees (RunSetup, State, Notice, Proposal) and asks (Request)
    codec      messages <-> JSON frames, with size and depth limits, checked by the schema
               (`fleet_common.schema`, the checkers the robot protocol's codec uses too)
    requests   the actions (`ACTIONS`) and their arguments, checked (what `Request.args` may hold)
    desk       the manager's end: consoles, versions (the Lamport clock), answers
    session    the console's end: what it has seen, what it asked, what came back

No sockets here (they are in `fleet_common.transport.console_channel`): a
console and a manager can be wired together in memory in tests.
"""
from __future__ import annotations

from .codec import ControlProtocolError, decode, encode
from .messages import (PROTOCOL_VERSION, Activity, Answer, Bye, Heartbeat, Hello, Notice, PlanData,
                       Proposal, Request, RobotInfo, RobotState, RunInfo, RunSetup, State, Waiting,
                       Welcome)
from .requests import ACTIONS, RUN_ACTIONS

__all__ = ["ControlProtocolError", "decode", "encode", "ACTIONS", "RUN_ACTIONS", "PROTOCOL_VERSION", "Activity",
           "Answer", "Bye", "Heartbeat", "Hello", "Notice", "PlanData", "Proposal", "Request",
           "RobotInfo", "RobotState", "RunInfo", "RunSetup", "State", "Waiting", "Welcome"]

