"""The live console's actions: its menus, picking robots, asking the manager, saving the window.

A mixin of `LiveApp`, as `PlayerActions` is of the player: the menus and the
panels reach each action by name (`window.LiveWindow` lists what they use of it). `ask` is the one way a control reaches the
manager: a request based on the version of the state the window shows.

A greyed Run menu entry says why after a dash, its beginning ("Start — not
on their start cells (the plan file's coordinates): robot 3 is at…"): Tk's
menus have no notes on hover, and a greyed entry cannot be pressed to ask;
the whole sentence is on the run button's note.
"""
from __future__ import annotations

import tkinter as tk
from tkinter import filedialog
from typing import Any, Optional

from ..keys import AGENTS, KEYS, VIEW
from ..live.describe import cell_text, greyed
from . import capture
from .admin_panel import RUN_CONTROLS, RunControl, usable, why_greyed
from .help_window import show_keys
from .window import LiveWindow

#: Characters of the reason a greyed Run menu entry carries, at most (a menu is as wide as its
#: longest entry).
MENU_WHY_CHARS = 72


class LiveActions:
    def _build_menus(self: "LiveWindow") -> None:
        bar = tk.Menu(self.root, tearoff=False)
        bar.add_cascade(label="File", menu=self.add_file_menu(bar))
        run = tk.Menu(bar, tearoff=False)
        for control in RUN_CONTROLS:
            if control.menu is not None:
                run.add_command(label=control.menu, command=lambda a=control.action: self.ask(a))
        bar.add_cascade(label="Run", menu=run)
        self.run_menu = run
        for group in (VIEW, AGENTS):
            menu = tk.Menu(bar, tearoff=False)
            if group == VIEW:
                menu.add_command(label="presentation for visitors (full screen) on / off", accelerator="F11",
                                 command=self._guarded(self.do_presentation))
            for key in KEYS:
                if key.group == group:
                    menu.add_command(label=key.help.replace("agent", "robot"), accelerator=key.shown,
                                     command=self.actions[key.action])
            bar.add_cascade(label="Robots" if group == AGENTS else group, menu=menu)
        help_menu = tk.Menu(bar, tearoff=False)
        help_menu.add_command(label="keyboard shortcuts", accelerator="F1", command=lambda: show_keys(self.root))
        bar.add_cascade(label="Help", menu=help_menu)
        self.root.configure(menu=bar)
        self.menubar = bar

    # -- picking and asking ------------------------------------------------------------

    def selected_robot(self: "LiveWindow") -> Optional[int]:
        ids = self.model.robot_ids()
        sel = self.options.selected
        return ids[sel] if sel is not None and 0 <= sel < len(ids) else None

    def select(self: "LiveWindow", agent: Optional[int]) -> None:
        self.options.selected = agent
        rid = self.selected_robot()
        self.admin.mark(rid)
        self.relayout()
        self._show_robot()
        if rid is not None:
            r = self.model.robot(rid)
            self.status.set("robot {}{}".format(rid, "" if r is None else ": at {}, {}".format(
                cell_text((r.x, r.y), self.place) if r.x is not None else "unknown position", greyed(r) or "ok")))

    def _pick_robot(self: "LiveWindow", robot_id: Optional[int]) -> None:
        agent = None if robot_id is None else self.model.agent_of.get(robot_id)
        if agent != self.options.selected:
            self.select(agent)
        self.canvas.focus_set()

    def jump_to_robot(self: "LiveWindow", robot_id: int) -> None:
        """Select `robot_id` and bring it into view (the event list's double-click)."""
        agent = self.model.agent_of.get(robot_id)
        if agent is None:
            return
        x, y = self.model.fleet_state().positions[agent]
        if not self.map.view.shows(x, y):
            self.map.view.centre_on(x, y)
            self.map.changed()
        self.select(agent)

    def ask(self: "LiveWindow", action: str, **args: Any) -> None:
        """Send a request based on the state this window shows (thesis 5.1.1: a decision on a
        picture that is no longer true is refused); the answer comes back through the feed."""
        shown = self.model.state
        self._ask(action, based_on=shown.version if shown is not None else None, **args)
        self.status.set("asked the manager: {}{}".format(action, "".join(
            " {}={}".format(k, v) for k, v in sorted(args.items()) if k != "text")))

    def grey_run_menu(self: "LiveWindow") -> None:
        """The Run menu's entries as the buttons: greyed when the manager would refuse them, saying
        why (without a manager, every entry greyed says nothing: the map's banner says it once)."""
        run = self.model.state.run if self.model.state is not None else None
        connected = self.model.connected
        for index, control in enumerate(c for c in RUN_CONTROLS if c.menu is not None):
            why = why_greyed(control.action, run, connected) if connected and run is not None else ""
            self.run_menu.entryconfigure(index, state=tk.NORMAL if usable(control.action, run, connected)
                                         else tk.DISABLED, label=menu_label(control, why))

    def do_presentation(self: "LiveWindow") -> None:
        """The map for visitors, full screen (F11 again: back to the operator's window)."""
        self.presentation.toggle()

    # -- capture -----------------------------------------------------------------------

    def save_window(self: "LiveWindow", path: str) -> None:
        capture.grab(self.root, path)
        self.status.set("saved {}".format(path))

    def _save_window(self: "LiveWindow") -> None:
        path = filedialog.asksaveasfilename(parent=self.root, defaultextension=".png",
                                            filetypes=[("PNG image", "*.png")], title="Save window as PNG")
        if path:
            self.root.after(200, self._guarded(lambda: self.save_window(path)))


def menu_label(control: RunControl, why: str) -> str:
    """`control`'s Run menu entry, with `why` it is greyed after a dash: its beginning, cut after a
    word (a menu entry is one line; what a long reason names first is what matters most)."""
    if not why:
        return control.menu or control.label
    if len(why) > MENU_WHY_CHARS:
        why = why[:MENU_WHY_CHARS].rsplit(" ", 1)[0].rstrip(",;:( ") + "\u2026"
    return "{} \u2014 {}".format(control.menu or control.label, why)
