"""Random plans, robot sizes and delays for the execution property tests (shared by the files
that judge runs by the robots' paths: following, re-ordering)."""
from __future__ import annotations

from typing import Dict, Tuple

import numpy as np
from hypothesis import strategies as st

from fleet_common.delays import DelayModel, EventDelays, MoveFates, simulator_fates
from fleet_common.execution import Disabled, Enabled, Engine, ReorderStrategy, RobotFailed, SwitchStrategy, make_strategy
from fleet_common.grid import Grid
from fleet_common.plan import Plan
from fleet_common.planning import solve
from fleet_common.planning.problem import InvalidProblemError
from fleet_common.robot_size import TURTLEBOT2, RobotSize, cell_sized

_PLANS: Dict[int, Tuple[Plan, Grid]] = {}


def random_plan(seed: int) -> Plan:
    """A plan of a built-in solver on a random map (cached per seed)."""
    return random_problem(seed)[0]


def random_problem(seed: int) -> Tuple[Plan, Grid]:
    """A plan of a built-in solver on a random map, and the map (cached per seed)."""
    key = seed
    if key not in _PLANS:
        rng = np.random.default_rng(seed)
        for attempt in range(20):
            w, h = int(rng.integers(5, 12)), int(rng.integers(5, 12))
            grid = Grid(rng.random((h, w)) > rng.choice([0.0, 0.1, 0.2]))
            cells = list(grid.free_cells())
            n = int(rng.integers(3, max(4, len(cells) // 3)))
            starts = [cells[i] for i in rng.permutation(len(cells))[:n]]
            goals = [cells[i] for i in rng.permutation(len(cells))[:n]]
            try:
                result = solve(str(rng.choice(["lacam", "pibt"])), grid, starts, goals, deadline=1.0,
                               seed=seed, max_timestep=200)
            except InvalidProblemError:  # a goal another start cannot reach: draw again
                continue
            if result.solved and result.plan.num_agents >= 2:
                _PLANS[key] = (result.plan, grid)
                break
    return _PLANS[key]


PLAN_SEEDS = list(range(24))


@st.composite
def sizes(draw) -> RobotSize:
    diameter = draw(st.floats(0.05, 0.6))
    return RobotSize(diameter, draw(st.floats(0.0, 0.64 - diameter)) if diameter < 0.64 else 0.0, 0.7)


@st.composite
def delay_models(draw) -> DelayModel:
    low = draw(st.floats(0.3, 1.0))
    events = None
    if draw(st.booleans()):
        events = EventDelays("bernoulli", draw(st.floats(0.0, 0.4)), 1, draw(st.integers(1, 5)))
    return DelayModel(factor=(low, draw(st.floats(low, 3.0))), stall_p=draw(st.sampled_from([0.0, 0.1, 0.5, 1.0])),
                      stall_moves=draw(st.floats(0.0, 4.0)), events=events)


def fates_for(plan: Plan, model: DelayModel, seed: int, stall_at_hold: float) -> MoveFates:
    table = Engine(plan).table
    fates = simulator_fates(model, table.agent, table.num_agents, seed)
    if stall_at_hold > 0:  # every stall right where a follower's first hold point is
        fates = fates._replace(stall_at=np.full(table.num_actions, stall_at_hold))
    return fates


STRATEGY_NAMES = ("adg", "step", "reorder")


def reorders(rng: np.random.Generator) -> ReorderStrategy:
    return ReorderStrategy(gap=int(rng.integers(1, 3)), reach=int(rng.integers(1, 7)),
                           budget=int(rng.choice([3, 40, 400])))


def operator_actions(plan: Plan, rng: np.random.Generator, horizon: float) -> list:
    """Faults and their clearing, disables and enables, and switches between all strategies."""
    controls: list = []
    for _ in range(int(rng.integers(0, 3))):
        agent = int(rng.integers(0, plan.num_agents))
        t = float(rng.uniform(0.0, horizon))
        controls.append((RobotFailed if rng.random() < 0.5 else Disabled)(agent, t))
        controls.append(Enabled(agent, t + float(rng.uniform(0.1, 5.0))))
    for _ in range(int(rng.integers(0, 3))):
        name = str(rng.choice(STRATEGY_NAMES))
        strategy = reorders(rng) if name == "reorder" else make_strategy(name)
        controls.append(SwitchStrategy(strategy, float(rng.uniform(0.0, horizon))))
    return sorted(controls, key=lambda c: c.time)


def operator_case(plan_seed: int, seed: int, salt: int) -> Tuple[Plan, Grid, np.random.Generator, RobotSize, DelayModel]:
    """One run of the tests beside the operator's hand: the random problem, a generator seeded by
    (plan_seed, seed, salt) for the rest of the run's draws, robots of the lab's size on odd seeds
    (else as large as a cell), LoRR delays at a p drawn between 0.1 and 0.3."""
    plan, grid = random_problem(plan_seed)
    rng = np.random.default_rng([plan_seed, seed, salt])
    size = TURTLEBOT2 if seed % 2 else cell_sized()
    model = DelayModel(events=EventDelays("bernoulli", float(rng.uniform(0.1, 0.3)), 1, 5))
    return plan, grid, rng, size, model
