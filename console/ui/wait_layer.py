"""WaitLayer: who waits for whom, over the live fleet (thesis fig. 5.11, SMART's constraining agent).

For each wait the picture shows (`console.live.picture`: waits that have
lasted), the cell the robot waits to enter is framed red, under the discs,
and a red arrow goes from inside the waiting robot's disc to the rim of each
robot it waits for (at most `MAX_ARROWS`: a step barrier may wait for many),
over the discs. Items are pooled: made when more are needed, hidden when not.
"""
from __future__ import annotations

import tkinter as tk
from typing import List, Optional, Tuple

import numpy as np

from ..fleet_state import FleetState
from ..live.picture import WaitMark
from ..view_options import ViewOptions
from ..viewport import Viewport
from .robot_layer import RobotLayer

WAIT = "#e8101a"
#: Arrows drawn per waiting robot.
MAX_ARROWS = 3


class WaitLayer:
    def __init__(self, canvas: tk.Canvas, robots: RobotLayer) -> None:
        self.canvas = canvas
        self.robots = robots
        self.frame_items: List[int] = []
        self.arrow_items: List[int] = []
        self.view: Optional[Viewport] = None
        self._w = str(canvas)

    def relayout(self, view: Viewport, options: ViewOptions) -> None:
        self.view = view
        self.update(None)

    def update(self, state: Optional[FleetState]) -> None:
        pic = self.robots.picture
        if pic is not None and self.view is not None and pic.num_agents == len(self.robots.disc_items):
            self._draw(pic.waits)
            self.canvas.tag_raise("arrow")

    def _draw(self, waits: List[WaitMark]) -> None:
        arrows: List[Tuple[float, float, float, float]] = []
        frames: List[Tuple[float, float]] = []
        view, r, xy = self.view, self.robots.radius, self.robots.centres
        for w in waits:
            frames.append(view.to_canvas(*w.cell))
            x0, y0 = xy[w.agent]
            for other in w.on[:MAX_ARROWS]:
                x1, y1 = xy[other]
                d = float(np.hypot(x1 - x0, y1 - y0))
                if d > 1.6 * r:  # from inside the waiting robot's disc to the other's rim
                    ux, uy = (x1 - x0) / d, (y1 - y0) / d
                    arrows.append((x0 + ux * 0.4 * r, y0 + uy * 0.4 * r, x1 - ux * (r + 1), y1 - uy * (r + 1)))
        c = self.canvas
        width = max(2, round(view.cell * 0.08))
        while len(self.frame_items) < len(frames):
            self.frame_items.append(c.create_rectangle(0, 0, 0, 0, outline=WAIT, tags=("frame",)))
            c.tag_raise(self.frame_items[-1], "ghost")  # under the discs, over the ghosts
        while len(self.arrow_items) < len(arrows):
            self.arrow_items.append(c.create_line(0, 0, 0, 0, fill=WAIT, arrow=tk.LAST, tags=("arrow",)))
        half = view.cell / 2 - width / 2
        script = []
        for k, item in enumerate(self.frame_items):
            if k < len(frames):
                x, y = frames[k]
                script.append("%s coords %d %.1f %.1f %.1f %.1f" % (self._w, item, x - half, y - half, x + half, y + half))
                script.append("%s itemconfigure %d -state normal -width %d" % (self._w, item, width))
            else:
                script.append("%s itemconfigure %d -state hidden" % (self._w, item))
        head = max(8, round(r * 0.7))
        for k, item in enumerate(self.arrow_items):
            if k < len(arrows):
                script.append("%s coords %d %.1f %.1f %.1f %.1f" % ((self._w, item) + arrows[k]))
                script.append("%s itemconfigure %d -state normal -width %d -arrowshape {%d %d %d}" % (
                    self._w, item, max(3, width), head, head + 2, max(3, head // 2)))
            else:
                script.append("%s itemconfigure %d -state hidden" % (self._w, item))
        if script:
            self.canvas.tk.eval("\n".join(script))
