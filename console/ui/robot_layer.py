"""RobotLayer: the live fleet on the canvas (what `console.live.picture` says, drawn).

Per robot, created once and then only moved or restyled: a faint dashed ghost
at its planned position, a yellow halo when it is behind the plan, its disc
at the reported pose with a heading tick, its robot id, and (when greyed) the
reason in small text under it; its goal as a small square. Shared: the selected robot's remaining plan as a thick line from where it is through
the corners ahead (fig. 5.7). The waits are `WaitLayer`'s, drawn over these.

As in `AgentLayer`, all coordinates of a frame go to Tk as one Tcl script;
styles change only for the robots whose flags changed, so 300 robots cost a
few milliseconds a frame.
"""
from __future__ import annotations

import tkinter as tk
from typing import Dict, List, Optional

import numpy as np

from ..fleet_state import FleetState
from ..live.picture import Picture
from ..path_corners import PathCorners
from ..scene import Scene
from ..view_options import ViewOptions
from ..viewport import Viewport
from .agent_layer import MAX_TAIL_CORNERS, OUTLINE, SELECTED_OUTLINE, disc_radius

GREY = "#b9b9b4"
GREY_TEXT = "#3c3c3c"
BEHIND = "#f2c200"
HEADING = "#ffffff"
#: Robot ids are written on the discs when a cell is at least this many pixels.
MIN_LABEL_CELL = 14.0
#: Ghosts are dashed rings up to this many robots (a third of the X server's work at 300).
MAX_DASHED = 50


def text_on(colour: str) -> str:
    """Black or white, whichever reads better on `colour` ('#rrggbb')."""
    r, g, b = (int(colour[k:k + 2], 16) for k in (1, 3, 5))
    return "#101010" if 0.299 * r + 0.587 * g + 0.114 * b > 140 else "#ffffff"


class RobotLayer:
    def __init__(self, canvas: tk.Canvas, scene: Scene, robot_ids: List[int]) -> None:
        self.canvas = canvas
        self.scene = scene
        self.robot_ids = robot_ids
        n = scene.num_agents
        c = canvas
        colours = scene.colours
        tag = ["a%d" % i for i in range(n)]
        self.goal_items = [c.create_rectangle(0, 0, 0, 0, fill=colours[i], outline="",
                                              tags=("goal", tag[i])) for i in range(n)]
        self.tail_item = c.create_line(0, 0, 0, 0, width=3, state=tk.HIDDEN, capstyle=tk.ROUND,
                                       joinstyle=tk.ROUND, tags=("tail",))
        dash = (4, 3) if n <= MAX_DASHED else ()  # dashes cost the X server: plain rings for crowds
        self.ghost_items = [c.create_oval(0, 0, 0, 0, outline=colours[i], dash=dash, width=2 if dash else 1,
                                          state=tk.HIDDEN, tags=("ghost", tag[i])) for i in range(n)]
        self.halo_items = [c.create_oval(0, 0, 0, 0, outline=BEHIND, state=tk.HIDDEN,
                                         tags=("halo", tag[i])) for i in range(n)]
        self.disc_items = [c.create_oval(0, 0, 0, 0, fill=colours[i], outline=OUTLINE,
                                         tags=("disc", tag[i])) for i in range(n)]
        self.heading_items = [c.create_line(0, 0, 0, 0, fill=HEADING, capstyle=tk.ROUND,
                                            tags=("heading", tag[i])) for i in range(n)]
        self.id_items = [c.create_text(0, 0, text=str(rid), fill=text_on(colours[i]), tags=("robotid", tag[i]))
                         for i, rid in enumerate(robot_ids)]
        self.label_items: Dict[int, int] = {}
        self.corners = PathCorners(scene.plan) if scene.plan is not None and n else None
        self.goals = np.array(scene.goals, dtype=np.float64).reshape(-1, 2)
        self.picture: Optional[Picture] = None
        self.view: Optional[Viewport] = None
        self.options = ViewOptions()
        self.radius = 3.0
        #: discs never smaller than this (pixels of radius): the presentation view's robots are large
        self.min_radius = 0.0
        self._w = str(canvas)
        self._xy = np.full((n, 2), np.nan)
        self._gxy = np.full((n, 2), np.nan)
        self._grey = np.zeros(n, dtype=bool)
        self._behind = np.zeros(n, dtype=bool)
        self._labels = [""] * n
        self._ghosts_on = False

    @property
    def centres(self) -> np.ndarray:
        """(N, 2) canvas centres of the discs as last drawn."""
        return self._xy

    def set_picture(self, picture: Picture) -> None:
        self.picture = picture

    # -- placing everything ------------------------------------------------------------

    def relayout(self, view: Viewport, options: ViewOptions) -> None:
        self.view, self.options = view, options
        c = self.canvas
        r = self.radius = max(disc_radius(view.cell, self.scene.robot_diameter), self.min_radius)
        g = max(0.16 * view.cell, 1.5)
        script = []
        for i, (x, y) in enumerate(view.to_canvas_array(self.goals).tolist()):
            script.append("%s coords %d %.1f %.1f %.1f %.1f" % (self._w, self.goal_items[i], x - g, y - g, x + g, y + g))
        self._eval(script)
        c.itemconfigure("goal", state=tk.NORMAL if options.goals else tk.HIDDEN)
        c.itemconfigure("halo", width=max(2, round(0.24 * r)))
        c.itemconfigure("heading", width=max(1, round(r / 4)))
        c.itemconfigure("robotid", font=("DejaVu Sans", -max(7, int(r * 0.8)), "bold"),
                        state=tk.NORMAL if self._ids_shown() else tk.HIDDEN)
        c.itemconfigure("robotlabel", font=("DejaVu Sans", -max(8, min(12, int(r * 0.55)))))
        for i in range(len(self.disc_items)):
            self._style(i)
        for name in ("tail", "ghost", "halo", "disc", "heading", "robotid", "robotlabel"):
            c.tag_raise(name)
        self._xy[:] = np.nan
        self._gxy[:] = np.nan
        if self.picture is not None:
            self.update(None)

    # -- a new picture -----------------------------------------------------------------

    def update(self, state: Optional[FleetState]) -> None:
        pic, view = self.picture, self.view
        if pic is None or view is None or pic.num_agents != len(self.disc_items):
            return
        script: List[str] = []
        xy = view.to_canvas_array(pic.pose)
        moved = ~(np.abs(xy - self._xy) < 0.05).all(axis=1)
        haloed = pic.behind & ~pic.grey
        idx = np.nonzero(moved | (haloed & ~self._behind))[0]  # a halo shown now needs its place
        if idx.size:
            self._move(idx, xy, pic, haloed, script)
            self._xy[idx] = xy[idx]
        self._ghosts(pic, script)
        self._eval(script)
        for i in np.nonzero((pic.grey != self._grey) | (haloed != self._behind))[0].tolist():
            self._grey[i], self._behind[i] = pic.grey[i], haloed[i]
            self._style(i)
        for i, text in enumerate(pic.labels):
            if text != self._labels[i]:
                self._labels[i] = text
                self._label(i, text)
        self._draw_tail(pic)

    def _move(self, idx: np.ndarray, xy: np.ndarray, pic: Picture, haloed: np.ndarray,
              script: List[str]) -> None:
        """Coordinates of the robots `idx`, computed for all at once, sent as one script."""
        w, r = self._w, self.radius
        x, y = xy[idx, 0], xy[idx, 1]
        coords = "%s coords %d %.1f %.1f %.1f %.1f"
        script.extend(coords % (w, self.disc_items[i], a, b, c, d) for i, (a, b, c, d) in zip(
            idx.tolist(), np.column_stack([x - r, y - r, x + r, y + r]).tolist()))
        theta = pic.theta[idx]
        known = ~np.isnan(theta)
        dx = np.where(known, np.cos(np.where(known, theta, 0.0)), 0.0)
        dy = np.where(known, np.sin(np.where(known, theta, 0.0)), 0.0) * (1.0 if self.view.down else -1.0)
        ticks = np.column_stack([x + 0.45 * r * dx, y + 0.45 * r * dy, x + r * dx, y + r * dy])
        script.extend(coords % (w, self.heading_items[i], a, b, c, d) for i, (a, b, c, d) in zip(
            idx.tolist(), ticks.tolist()))
        halo = r + max(2, round(0.24 * r))
        on = haloed[idx]
        script.extend(coords % (w, self.halo_items[i], a - halo, b - halo, a + halo, b + halo)
                      for i, (a, b) in zip(idx[on].tolist(), xy[idx[on]].tolist()))
        if self._ids_shown():  # hidden ids need not follow (relayout places them)
            script.extend("%s coords %d %.1f %.1f" % (w, self.id_items[i], a, b)
                          for i, (a, b) in zip(idx.tolist(), xy[idx].tolist()))
        for i in idx.tolist():
            label = self.label_items.get(i)
            if label is not None:
                script.append("%s coords %d %.1f %.1f" % (w, label, xy[i, 0], xy[i, 1] + r + 2))

    def _ids_shown(self) -> bool:
        return self.view is not None and (self.view.cell >= MIN_LABEL_CELL or self.radius >= 8)

    def _ghosts(self, pic: Picture, script: List[str]) -> None:
        on = pic.ghost is not None
        if on != self._ghosts_on:
            self.canvas.itemconfigure("ghost", state=tk.NORMAL if on else tk.HIDDEN)
            self._ghosts_on = on
            self._gxy[:] = np.nan
        if pic.ghost is None:
            return
        gxy = self.view.to_canvas_array(pic.ghost)
        r = self.radius * 0.92
        changed = np.nonzero(~(np.abs(gxy - self._gxy) < 0.05).all(axis=1))[0]
        script.extend("%s coords %d %.1f %.1f %.1f %.1f" % (self._w, self.ghost_items[i], a - r, b - r, a + r, b + r)
                      for i, (a, b) in zip(changed.tolist(), gxy[changed].tolist()))
        self._gxy = gxy

    def _style(self, i: int) -> None:
        c, r = self.canvas, self.radius
        colour = self.scene.colours[i]
        selected = self.options.selected == i
        c.itemconfigure(self.id_items[i], fill=text_on(GREY if self._grey[i] else colour))
        if self._grey[i]:
            c.itemconfigure(self.disc_items[i], fill=GREY, outline=colour, width=max(2, round(0.2 * r)))
        else:
            c.itemconfigure(self.disc_items[i], fill=colour,
                            outline=SELECTED_OUTLINE if selected else (OUTLINE if r >= 5 else ""),
                            width=max(2, round(0.22 * r)) if selected else (1 if r >= 5 else 0))
        c.itemconfigure(self.halo_items[i], state=tk.NORMAL if self._behind[i] else tk.HIDDEN)

    def _label(self, i: int, text: str) -> None:
        item = self.label_items.get(i)
        if item is None:
            if not text:
                return
            x, y = self._xy[i] if not np.isnan(self._xy[i]).any() else (0.0, 0.0)
            item = self.canvas.create_text(x, y + self.radius + 2, anchor=tk.N, fill=GREY_TEXT,
                                           font=("DejaVu Sans", -max(8, min(12, int(self.radius * 0.55)))),
                                           tags=("robotlabel", "a%d" % i))
            self.label_items[i] = item
        self.canvas.itemconfigure(item, text=text, state=tk.NORMAL if text else tk.HIDDEN)

    # -- waits and the selected robot's plan -------------------------------------------

    def _draw_tail(self, pic: Picture) -> None:
        sel = self.options.selected
        c = self.canvas
        if sel is None or self.corners is None or not 0 <= sel < pic.num_agents:
            c.itemconfigure(self.tail_item, state=tk.HIDDEN)
            return
        step = float(pic.steps[sel])
        index = int((self.corners.times[sel] <= step + 1e-9).sum())
        ahead = self.corners.ahead(sel, index, MAX_TAIL_CORNERS)
        points = np.vstack([pic.pose[sel:sel + 1], ahead]) if len(ahead) else pic.pose[sel:sel + 1]
        if len(points) < 2:
            c.itemconfigure(self.tail_item, state=tk.HIDDEN)
            return
        flat = self.view.to_canvas_array(points).ravel().tolist()
        c.coords(self.tail_item, *flat)
        c.itemconfigure(self.tail_item, state=tk.NORMAL, fill=self.scene.colours[sel],
                        width=max(3, round(self.radius * 0.35)))

    # -- hit test ----------------------------------------------------------------------

    def agent_at(self, px: float, py: float) -> Optional[int]:
        """The robot (agent index) whose disc covers canvas point (px, py), nearest first."""
        if not len(self.disc_items):
            return None
        d = np.hypot(self._xy[:, 0] - px, self._xy[:, 1] - py)
        d[np.isnan(d)] = np.inf
        i = int(np.argmin(d))
        return i if d[i] <= self.radius + 1 else None

    def _eval(self, script: List[str]) -> None:
        if script:
            self.canvas.tk.eval("\n".join(script))
