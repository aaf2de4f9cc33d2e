"""What the manager runs: now `fleet_common.plan_loading`, the one "load a plan to run".

Kept only while `manager.py` and `steering.py` still import from here (the manager's
core of issue 24 imports `fleet_common.plan_loading` directly; then this file goes).
"""
from __future__ import annotations

from fleet_common.plan_loading import LoadedPlan, PlanLoadError, load_plan, pick_robots

__all__ = ["LoadedPlan", "load_plan", "pick_robots", "PlanLoadError"]
