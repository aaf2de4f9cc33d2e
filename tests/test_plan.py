"""Plan: mapf-IR's cost counting and construction from paths."""
from __future__ import annotations

import numpy as np
import pytest

from fleet_common.plan import Orientation, Plan


def test_soc_is_counted_as_mapf_ir_counts_it():
    # mapf-IR's CBS answer on makespan-soc-pareto (base frame irrelevant for costs)
    a = [(3, 1), (4, 1)]
    b = [(1, 3), (0, 3), (0, 2), (0, 1), (1, 1), (2, 1), (3, 1), (3, 2), (3, 3), (4, 3), (5, 3), (5, 2), (5, 1)]
    plan = Plan.from_paths([a, b])
    assert plan.makespan == 12 and plan.soc == 13
    assert list(plan.path_costs()) == [1, 12]


def test_an_agent_that_leaves_its_goal_and_returns_pays_until_its_last_arrival():
    plan = Plan.from_paths([[(0, 0), (1, 0), (0, 0), (0, 0)]])
    assert plan.soc == 2


def test_makespan_zero_costs_nothing():
    assert Plan.from_paths([[(0, 0)], [(1, 0)]]).soc == 0
    assert Plan.from_paths([]).num_agents == 0


def test_short_paths_wait_at_their_last_cell():
    plan = Plan.from_paths([[(0, 0)], [(1, 0), (2, 0), (3, 0)]])
    assert plan.path(0) == [(0, 0)] * 3 and plan.goals == [(0, 0), (3, 0)]
    assert plan.config(99) == plan.goals


def test_bad_shapes_are_rejected():
    with pytest.raises(ValueError):
        Plan(np.zeros((0, 2, 2)))
    with pytest.raises(ValueError):
        Plan.from_paths([[(0, 0)], []])
    with pytest.raises(ValueError):
        Plan(np.zeros((2, 2, 2)), orientations=np.zeros((2, 3)))


def test_orientation_flip_swaps_only_the_y_headings():
    assert Orientation.Y_PLUS.flipped_y() is Orientation.Y_MINUS
    assert Orientation.X_MINUS.flipped_y() is Orientation.X_MINUS
