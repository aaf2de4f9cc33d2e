"""ProposalLayer: a replan the manager proposes, drawn on the map before anyone accepts it.

Each robot's proposed path is a dashed line in its colour through the
corners of the new plan, and its new goal a hollow square, over the current
picture; a line in the header names the proposal. Cleared when the proposal
is accepted or rejected (by any console) or the plan changes.
"""
from __future__ import annotations

import tkinter as tk
from typing import List, Optional, Sequence

import numpy as np

from fleet_common.plan import Plan

from ..fleet_state import FleetState
from ..path_corners import PathCorners
from ..view_options import ViewOptions
from ..viewport import Viewport
from .agent_layer import MAX_TAIL_CORNERS


class ProposalLayer:
    def __init__(self, canvas: tk.Canvas, colours: Sequence[str]) -> None:
        self.canvas = canvas
        self.colours = list(colours)
        self.plan: Optional[Plan] = None
        self.items: List[int] = []
        self.view: Optional[Viewport] = None

    def show(self, plan: Optional[Plan]) -> None:
        self.plan = plan
        if self.view is not None:
            self._draw()

    def relayout(self, view: Viewport, options: ViewOptions) -> None:
        self.view = view
        self._draw()

    def update(self, state: FleetState) -> None:
        pass

    def _draw(self) -> None:
        c = self.canvas
        c.delete("proposal")
        self.items = []
        plan, view = self.plan, self.view
        if plan is None or view is None or plan.num_agents != len(self.colours):
            return
        corners = PathCorners(plan)
        width = max(2, round(view.cell * 0.1))
        half = max(view.cell * 0.22, 3)
        for i in range(plan.num_agents):
            # corners hold the turns and the end, not the start
            cells = np.vstack([plan.positions[0, i:i + 1], corners.ahead(i, 0, MAX_TAIL_CORNERS)])
            points = view.to_canvas_array(cells)
            if len(points) >= 2:
                self.items.append(c.create_line(*points.ravel().tolist(), fill=self.colours[i], width=width,
                                                dash=(8, 5), capstyle=tk.ROUND, tags=("proposal",)))
            x, y = points[-1]
            self.items.append(c.create_rectangle(x - half, y - half, x + half, y + half, outline=self.colours[i],
                                                 width=width, tags=("proposal",)))
        if self.items:
            c.tag_raise("proposal", "background")
            c.tag_raise("proposal", "goal")
