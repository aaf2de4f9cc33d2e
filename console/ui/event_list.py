"""EventList: what happened, newest at the bottom, with the time it arrived.

The manager's events (faults, links, operators' actions, strategy switches,
the run) and the console's own lines (answers, refusals, a lost manager) in
one list, warnings orange and errors red. Double-clicking a line about a
robot selects that robot and brings it into view (`on_jump`).
"""
from __future__ import annotations

import tkinter as tk
from tkinter import ttk
from typing import Callable, Dict, List, Optional

from ..live.model import Line
from .table import scrolled_table

FONT = ("DejaVu Sans", -11)
#: Lines kept in the widget (the model keeps its own, longer history).
MAX_ROWS = 400


class EventList(ttk.Frame):
    def __init__(self, master: tk.Misc, on_jump: Callable[[int], None]) -> None:
        super().__init__(master, padding=(2, 2))
        ttk.Label(self, text="Events (double-click: show the robot)").pack(anchor=tk.W)
        self.tree = scrolled_table(self, (("time", "time", 60), ("robot", "robot", 46), ("text", "event", 240)),
                                   "Events.Treeview", FONT, 18, 10, "text")
        self.tree.tag_configure("warn", foreground="#b35c00")
        self.tree.tag_configure("error", foreground="#c8101a")
        self.tree.bind("<Double-Button-1>", self._double)
        self.on_jump = on_jump
        self._robots: Dict[str, Optional[int]] = {}
        self._last: Optional[Line] = None

    def sync(self, lines: List[Line]) -> None:
        """Append the lines after the last one shown (`lines` is the model's history)."""
        start = 0
        if self._last is not None:
            for k in range(len(lines) - 1, -1, -1):
                if lines[k] is self._last:
                    start = k + 1
                    break
        new = lines[start:]
        if not new:
            return
        for line in new:
            iid = self.tree.insert("", tk.END, values=(
                line.clock, "" if line.robot is None else line.robot, line.text),
                tags=(line.level,) if line.level != "info" else ())
            self._robots[iid] = line.robot
        self._last = new[-1]
        children = self.tree.get_children()
        if len(children) > MAX_ROWS:
            old = children[:len(children) - MAX_ROWS]
            self.tree.delete(*old)
            for iid in old:
                self._robots.pop(iid, None)
        self.tree.see(self.tree.get_children()[-1])

    def rows(self) -> List[str]:
        return [" ".join(str(v) for v in self.tree.item(i, "values")) for i in self.tree.get_children()]

    def jump(self, iid: str) -> None:
        robot = self._robots.get(iid)
        if robot is not None:
            self.on_jump(robot)

    def _double(self, event: "tk.Event[ttk.Treeview]") -> None:
        iid = self.tree.identify_row(event.y)
        if iid:
            self.jump(iid)
