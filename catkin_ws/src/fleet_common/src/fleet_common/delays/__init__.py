"""Delay models: how much longer than planned robots take, as data.

One model for every place a plan is executed: `fleetctl simulate` and sweeps
(the one-process simulator), and `fleetctl virtual-fleet` (robots on the
wire). Times are in *nominal moves* (the time one plan step takes, one cell
at the robot's speed); probabilities are per move. The simulator's time unit
is the nominal move; the virtual fleet multiplies by its nominal move time
in seconds.

    model   the terms (`DelayModel`) and how they read to a person
    spec    the spec language: terms on the command line, presets, YAML/JSON
            files (a League of Robot Runners `delayConfig` too)
    draw    what happens to each move, from uniform variates, vectorised
"""
from __future__ import annotations

from .draw import MoveFates, draw_fates, robot_profile, simulator_durations, simulator_fates
from .model import DelayModel, DelayModelError, EventDelays, ProneDelays
from .spec import FORMS, PRESETS, parse_delay_model, read_delay_file

__all__ = ["DelayModel", "DelayModelError", "EventDelays", "ProneDelays", "MoveFates", "draw_fates",
           "robot_profile", "simulator_durations", "simulator_fates", "FORMS", "PRESETS", "parse_delay_model",
           "read_delay_file"]
