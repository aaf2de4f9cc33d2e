"""Executing MAPF plans on robots that are late, stall and die.

A pure library (no sockets, ROS, threads or clocks): the manager, the virtual
fleet, the console and the tests drive the same code. `Engine` takes a
`Plan` and a strategy, then events in (`ActionStarted`, `ActionCompleted`, `RobotFailed`,
`Disabled`, `Enabled`, `Resume`, `Pause`, `StepRound`, `SwitchStrategy`, `Freeze`, `Thaw`),
decisions out (`Dispatch`: robot r may start its action k now).

    actions       plan -> per-robot moves (waits are not actions)
    adg           Action Dependency Graph: the safety rule every strategy keeps
    strategy      the strategy interface and registry (`make_strategy`)
    step, adg_strategy   the discrete time step and the ADG strategy
    reorder       the ADG whose order at a cell changes when a robot is late
    run, engine   progress of a run; the engine
    blocking      robots blocked by out robots, transitively
    metrics       executed makespan, sum of costs, waits, who blocked whom
    trace, simulate   a one-process simulator (delays from fleet_common.delays) and its
                  collision checker
"""
from __future__ import annotations

from .actions import Action, ActionTable
from .adg import ActionDependencyGraph, build_adg
from .adg_strategy import AdgStrategy
from .engine import Engine
from .errors import EventError, PlanError, UnknownStrategyError
from .events import (
    ActionCompleted, ActionStarted, Disabled, Dispatch, Enabled, Freeze, Pause, Resume, RobotFailed,
    StepRound, SwitchStrategy, Thaw, Tick, Wait,
)
from .metrics import Metrics, RobotMetrics
from .reorder import Pass, ReorderStrategy
from .step import DiscreteTimeStep
from .strategy import STRATEGIES, Strategy, make_strategy, register

__all__ = [
    "Action", "ActionTable", "ActionDependencyGraph", "build_adg", "AdgStrategy", "Engine",
    "EventError", "PlanError", "UnknownStrategyError", "ActionCompleted", "ActionStarted",
    "Disabled", "Dispatch", "Enabled", "Freeze", "Thaw", "Pause", "Resume", "RobotFailed", "StepRound",
    "SwitchStrategy", "Tick", "Wait",
    "Metrics", "RobotMetrics", "Pass", "ReorderStrategy", "DiscreteTimeStep", "STRATEGIES", "Strategy", "make_strategy",
    "register",
]
