"""WaitLayer: who waits for whom, over the live fleet (thesis fig. 5.11, SMART's constraining agent).

For each wait the picture shows (`console.live.picture`: waits that have
lasted), the cell the robot waits to enter is framed red, under the discs,
and a red arrow goes from inside the waiting robot's disc to the rim of each
robot it waits for (at most `MAX_ARROWS`: a step barrier may wait for many),
over the discs. A robot following another into a cell at the safe distance
(moving, not waiting) has a thin dark line from its disc to its leader's rim.
Items are pooled: made when more are needed, hidden when not.
"""
from __future__ import annotations

import tkinter as tk
from typing import Callable, Dict, List, Optional, Tuple

import numpy as np

from ..fleet_state import FleetState
from ..live.picture import WaitMark
from ..view_options import ViewOptions
from ..viewport import Viewport
from .robot_layer import RobotLayer

WAIT = "#e8101a"
FOLLOW = "#303030"
#: Arrows drawn per waiting robot.
MAX_ARROWS = 3


class WaitLayer:
    def __init__(self, canvas: tk.Canvas, robots: RobotLayer) -> None:
        self.canvas = canvas
        self.robots = robots
        self.frame_items: List[int] = []
        self.arrow_items: List[int] = []
        self.follow_items: List[int] = []
        self.view: Optional[Viewport] = None
        self._w = str(canvas)
        self._shown: Dict[int, int] = {}  # id(pool) -> how many of its items are shown
        self._drawn: Tuple[list, list, list] = ([], [], [])
        self._style: Tuple[int, int] = (0, 0)

    def relayout(self, view: Viewport, options: ViewOptions) -> None:
        self.view = view
        self._drawn = ([], [], [])
        self._style = (0, 0)  # the cell size may have changed: style every item again
        self.update(None)

    def update(self, state: Optional[FleetState]) -> None:
        pic = self.robots.picture
        if pic is not None and self.view is not None and pic.num_agents == len(self.robots.disc_items):
            self._draw(pic.waits, pic.follows)
            self.canvas.tag_raise("arrow")

    def _draw(self, waits: List[WaitMark], follows: List[Tuple[int, int]]) -> None:
        arrows: List[Tuple[float, float, float, float]] = []
        lines: List[Tuple[float, float, float, float]] = []
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
        for follower, leader in follows:
            x0, y0 = xy[follower]
            x1, y1 = xy[leader]
            d = float(np.hypot(x1 - x0, y1 - y0))
            if d > 2.0 * r:  # from the follower's rim to the leader's
                ux, uy = (x1 - x0) / d, (y1 - y0) / d
                lines.append((x0 + ux * r, y0 + uy * r, x1 - ux * (r + 1), y1 - uy * (r + 1)))
        if (frames, arrows, lines) == self._drawn:
            return  # nothing moved: nothing to send
        self._drawn = (frames, arrows, lines)
        width = max(2, round(view.cell * 0.08))
        head = max(8, round(r * 0.7))
        style = (width, head)
        restyle = style != self._style
        self._style = style
        half = view.cell / 2 - width / 2
        script: List[str] = []
        self._pool(self.frame_items, [(x - half, y - half, x + half, y + half) for x, y in frames],
                   "-width %d" % width, restyle, script, self._make_frame)
        self._pool(self.arrow_items, arrows, "-width %d -arrowshape {%d %d %d}" % (
            max(3, width), head, head + 2, max(3, head // 2)), restyle, script, self._make_arrow)
        self._pool(self.follow_items, lines, "-width %d" % max(1, width // 2), restyle, script,
                   self._make_follow)
        if script:
            self.canvas.tk.eval("\n".join(script))

    def _pool(self, items: List[int], coords: List[Tuple[float, float, float, float]], style: str,
              restyle: bool, script: List[str], make: Callable[[], int]) -> None:
        """Place the first len(coords) items of the pool (made if missing), hide the rest that
        were shown; the style goes only to items shown anew (or to all, when it changed)."""
        shown = self._shown.get(id(items), 0)
        while len(items) < len(coords):
            items.append(make())
        for k, (x0, y0, x1, y1) in enumerate(coords):
            script.append("%s coords %d %.1f %.1f %.1f %.1f" % (self._w, items[k], x0, y0, x1, y1))
            if k >= shown or restyle:
                script.append("%s itemconfigure %d -state normal %s" % (self._w, items[k], style))
        for item in items[len(coords):shown]:
            script.append("%s itemconfigure %d -state hidden" % (self._w, item))
        self._shown[id(items)] = len(coords)

    def _make_frame(self) -> int:
        item = self.canvas.create_rectangle(0, 0, 0, 0, outline=WAIT, state=tk.HIDDEN, tags=("frame",))
        self.canvas.tag_raise(item, "ghost")  # under the discs, over the ghosts
        return item

    def _make_follow(self) -> int:
        return self.canvas.create_line(0, 0, 0, 0, fill=FOLLOW, dash=(3, 3), state=tk.HIDDEN,
                                       tags=("arrow",))

    def _make_arrow(self) -> int:
        return self.canvas.create_line(0, 0, 0, 0, fill=WAIT, arrow=tk.LAST, state=tk.HIDDEN, tags=("arrow",))
