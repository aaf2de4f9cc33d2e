"""AgentLayer: every agent's disc, goal marker, line, ring and id on the canvas.

Theory of operation: all items are created once and then only moved. For a
new fleet state the layer computes every agent's canvas centre with numpy,
picks the agents whose centre moved, and sends the new coordinates to Tk as
one Tcl script (one `coords` command per item), which is what keeps hundreds
of moving agents smooth: per-item Python calls into Tk would cost more than
drawing. The at-goal ring sits still on the goal and is only shown or hidden;
the remaining-path polylines (`console.path_corners`) change only when an
agent passes a turn.
"""
from __future__ import annotations

import math
import tkinter as tk
from typing import Dict, List, Optional

import numpy as np

from ..fleet_state import FleetState
from ..path_corners import PathCorners
from ..scene import Scene
from ..view_options import LINE_NONE, LINE_PATH, ViewOptions
from ..viewport import Viewport

OUTLINE = "#1e1e1e"
SELECTED_OUTLINE = "#000000"
RING = "#ffffff"
#: A remaining path shows at most this many turns ahead (a long shuttle would be thousands).
MAX_TAIL_CORNERS = 64


def disc_radius(cell: float, diameter: Optional[float] = None) -> float:
    """Disc radius for a cell size: a robot's real size (`diameter`, in cells), or about
    mapf-IR's (cell / 2 / sqrt 2) for an agent of a plan; never invisible."""
    return max((0.38 if diameter is None else 0.5 * diameter) * cell, 2.5)


class AgentLayer:
    def __init__(self, canvas: tk.Canvas, scene: Scene) -> None:
        self.canvas = canvas
        self.scene = scene
        self.plan = scene.plan
        n = scene.num_agents
        self.goals = np.array(scene.goals, dtype=np.float64).reshape(-1, 2)
        c = canvas
        tag = ["a%d" % i for i in range(n)]
        colours = scene.colours
        self.goal_items = [c.create_rectangle(0, 0, 0, 0, fill=colours[i], outline="",
                                              tags=("goal", tag[i])) for i in range(n)]
        self.line_items = [c.create_line(0, 0, 0, 0, fill=colours[i], tags=("line", tag[i]))
                           for i in range(n)]
        self.tail_items: Dict[int, int] = {}
        self.disc_items = [c.create_oval(0, 0, 0, 0, fill=colours[i], outline=OUTLINE,
                                         tags=("disc", tag[i])) for i in range(n)]
        self.ring_items = [c.create_oval(0, 0, 0, 0, outline=RING, state=tk.HIDDEN,
                                         tags=("ring", tag[i])) for i in range(n)]
        self.heading_items: List[int] = []
        if self.plan is not None and self.plan.orientations is not None:
            self.heading_items = [c.create_line(0, 0, 0, 0, fill=RING, tags=("heading", tag[i]))
                                  for i in range(n)]
        self.id_items: List[int] = []
        self._w = str(canvas)
        self._xy = np.full((n, 2), np.nan)
        self._at_goal = np.zeros(n, dtype=bool)
        self._shown = np.ones(n, dtype=bool)
        self.corners = PathCorners(self.plan) if self.plan is not None else None
        self._next = np.full(n, -1, dtype=np.int64)  # next corner index each tail was drawn for
        self._state: Optional[FleetState] = None
        self.view: Optional[Viewport] = None
        self.options = ViewOptions()
        self.radius = 3.0

    @property
    def centres(self) -> np.ndarray:
        """(N, 2) canvas centres of the discs as last drawn (NaN before the first state)."""
        return self._xy

    # -- placing everything ------------------------------------------------------------

    def relayout(self, view: Viewport, options: ViewOptions) -> None:
        self.view, self.options = view, options
        n = self.scene.num_agents
        c = self.canvas
        r = self.radius = disc_radius(view.cell)
        g = max(0.16 * view.cell, 1.5)
        self._shown = np.array([options.shows_agent(i) for i in range(n)], dtype=bool)
        goals = view.to_canvas_array(self.goals)
        ring_r, ring_w = 0.62 * r, max(1.0, round(0.16 * r))
        script = []
        for i, (x, y) in enumerate(goals.tolist()):
            script.append("%s coords %d %.1f %.1f %.1f %.1f" % (self._w, self.goal_items[i], x - g, y - g, x + g, y + g))
            script.append("%s coords %d %.1f %.1f %.1f %.1f" % (
                self._w, self.ring_items[i], x - ring_r, y - ring_r, x + ring_r, y + ring_r))
        self._eval(script)
        c.itemconfigure("ring", width=ring_w)
        outline, width = (OUTLINE, 1) if r >= 5 else ("", 0)
        c.itemconfigure("disc", outline=outline, width=width)
        c.itemconfigure("heading", width=max(1, round(r / 4)))
        self._apply_visibility()
        if options.selected is not None and 0 <= options.selected < n:
            sel = options.selected
            c.itemconfigure(self.disc_items[sel], outline=SELECTED_OUTLINE, width=max(2, round(0.22 * r)))
            c.itemconfigure(self.line_items[sel], width=2)
            if options.lines != LINE_PATH and self.corners is not None:
                c.itemconfigure(self.line_items[sel], state=tk.HIDDEN)  # its path replaces the line
            c.tag_raise("a%d" % sel)
        self._sync_ids()
        self._xy[:] = np.nan
        self._next[:] = -1
        if self._state is not None:
            self.update(self._state)

    def _apply_visibility(self) -> None:
        c, opts = self.canvas, self.options
        c.itemconfigure("goal", state=tk.NORMAL if opts.goals else tk.HIDDEN)
        c.itemconfigure("line", state=tk.HIDDEN if opts.lines == LINE_NONE else tk.NORMAL, width=1)
        for tag in ("disc", "heading", "idtext"):
            c.itemconfigure(tag, state=tk.NORMAL if tag != "idtext" or opts.ids else tk.HIDDEN)
        for i in np.nonzero(~self._shown)[0].tolist():
            c.itemconfigure("a%d" % i, state=tk.HIDDEN)
        self._at_goal[:] = False
        c.itemconfigure("ring", state=tk.HIDDEN)
        for i, item in list(self.tail_items.items()):
            if not self._wants_tail(i):
                c.delete(item)
                del self.tail_items[i]

    def _wants_tail(self, i: int) -> bool:
        if self.plan is None or not self._shown[i]:
            return False
        return self.options.lines == LINE_PATH or self.options.selected == i

    def _sync_ids(self) -> None:
        c, n = self.canvas, self.scene.num_agents
        if self.options.ids and not self.id_items:
            self.id_items = [c.create_text(0, 0, text=str(i), fill="#000000", tags=("idtext", "a%d" % i))
                             for i in range(n)]
            c.tag_raise("overlay")
        if self.id_items:
            size = max(7, int(self.radius * 0.9))
            c.itemconfigure("idtext", font=("DejaVu Sans", -size),
                            state=tk.NORMAL if self.options.ids else tk.HIDDEN)
            for i in np.nonzero(~self._shown)[0].tolist():
                c.itemconfigure(self.id_items[i], state=tk.HIDDEN)

    # -- moving ------------------------------------------------------------------------

    def update(self, state: FleetState) -> None:
        self._state = state
        view = self.view
        if view is None:
            return
        xy = view.to_canvas_array(state.positions)
        moved = ~(np.abs(xy - self._xy) < 0.05).all(axis=1)
        nxt = self._next
        if self.corners is not None:
            nxt = self.corners.next_index(state.time)
            if self.options.lines == LINE_PATH:
                moved |= nxt != self._next  # the head segment points to a new corner
        idx = np.nonzero(moved & self._shown)[0]
        script: List[str] = []
        if idx.size:
            self._move(idx, xy, state, nxt, script)
            self._xy[idx] = xy[idx]
        at_goal = np.all(state.positions == self.goals, axis=1) & self._shown
        for i in np.nonzero(at_goal != self._at_goal)[0].tolist():
            script.append("%s itemconfigure %d -state %s" % (
                self._w, self.ring_items[i], "normal" if at_goal[i] else "hidden"))
        self._at_goal = at_goal
        self._eval(script)
        self._update_tails(nxt, xy, moved)

    def _move(self, idx: np.ndarray, xy: np.ndarray, state: FleetState, nxt: np.ndarray,
              script: List[str]) -> None:
        w, r = self._w, self.radius
        pts = xy[idx].tolist()
        ids = idx.tolist()
        for i, (x, y) in zip(ids, pts):
            script.append("%s coords %d %.1f %.1f %.1f %.1f" % (w, self.disc_items[i], x - r, y - r, x + r, y + r))
        if self.options.lines != LINE_NONE:
            if self.options.lines == LINE_PATH and self.corners is not None:
                ends = self.view.to_canvas_array(self.corners.targets(nxt)[idx]).tolist()
            else:
                ends = self.view.to_canvas_array(self.goals[idx]).tolist()
            for i, (x, y), (ex, ey) in zip(ids, pts, ends):
                script.append("%s coords %d %.1f %.1f %.1f %.1f" % (w, self.line_items[i], x, y, ex, ey))
        if self.id_items and self.options.ids:
            for i, (x, y) in zip(ids, pts):
                script.append("%s coords %d %.1f %.1f" % (w, self.id_items[i], x, y))
        if self.heading_items and state.headings is not None:
            sign = 1.0 if self.view.down else -1.0
            for i, (x, y) in zip(ids, pts):
                a = state.headings[i]
                if math.isnan(a):
                    continue
                dx, dy = math.cos(math.radians(a)), sign * math.sin(math.radians(a))
                script.append("%s coords %d %.1f %.1f %.1f %.1f" % (
                    w, self.heading_items[i], x + 0.3 * r * dx, y + 0.3 * r * dy, x + r * dx, y + r * dy))

    def _update_tails(self, nxt: np.ndarray, xy: np.ndarray, moved: np.ndarray) -> None:
        """Redraw the polylines of the agents that passed a corner since they were drawn.

        In path mode the agent's line item is the segment to its next corner; a
        highlighted agent in the other modes gets that segment in its polyline,
        which then follows the agent every frame.
        """
        if self.corners is None or self.view is None:
            return
        c = self.canvas
        redraw = set(np.nonzero(nxt != self._next)[0].tolist())
        sel = self.options.selected
        own_head = sel is not None and self.options.lines != LINE_PATH and 0 <= sel < len(nxt)
        if own_head and moved[sel]:
            redraw.add(sel)
        for i in sorted(redraw):
            if not self._wants_tail(i):
                continue
            points = self.view.to_canvas_array(self.corners.ahead(i, int(nxt[i]), MAX_TAIL_CORNERS))
            if own_head and i == sel:
                points = np.vstack([xy[i:i + 1], points])
            item = self.tail_items.get(i)
            if len(points) < 2:
                if item is not None:
                    c.itemconfigure(item, state=tk.HIDDEN)
                continue
            flat = points.ravel().tolist()
            if item is None:
                width = 2 if sel == i else 1
                item = c.create_line(*flat, fill=self.scene.colours[i], width=width,
                                     tags=("tail", "a%d" % i))
                c.tag_lower(item, "disc")
                self.tail_items[i] = item
            else:
                c.coords(item, *flat)
                c.itemconfigure(item, state=tk.NORMAL)
        self._next = nxt.copy()

    # -- hit test ----------------------------------------------------------------------

    def agent_at(self, px: float, py: float) -> Optional[int]:
        """The shown agent whose disc covers canvas point (px, py), nearest first."""
        if self.scene.num_agents == 0:
            return None
        d = np.hypot(self._xy[:, 0] - px, self._xy[:, 1] - py)
        d[~self._shown | np.isnan(d)] = np.inf
        i = int(np.argmin(d))
        return i if d[i] <= self.radius + 1 else None

    def _eval(self, script: List[str]) -> None:
        if script:
            self.canvas.tk.eval("\n".join(script))
