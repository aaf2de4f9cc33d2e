"""The side panel's lists: agents (pick one to highlight) and conflicts (pick one to jump).

Both hand the picked index to a callback and give the keyboard focus back to
the canvas, so that the arrow keys keep stepping time instead of moving the
list's selection.
"""
from __future__ import annotations

import tkinter as tk
from tkinter import ttk
from typing import Callable, List, Optional, Sequence

FONT = ("DejaVu Sans Mono", -12)


class _PickList(ttk.Frame):
    def __init__(self, master: tk.Misc, title: str, on_pick: Callable[[Optional[int]], None],
                 height: int, focus_back: Callable[[], None]) -> None:
        super().__init__(master, padding=(2, 2))
        self.title = ttk.Label(self, text=title)
        self.title.pack(anchor=tk.W)
        body = ttk.Frame(self)
        body.pack(fill=tk.BOTH, expand=True)
        self.listbox = tk.Listbox(body, height=height, width=34, font=FONT, exportselection=False,
                                  activestyle="none", takefocus=0)
        bar = ttk.Scrollbar(body, orient=tk.VERTICAL, command=self.listbox.yview)
        self.listbox.configure(yscrollcommand=bar.set)
        self.listbox.pack(side=tk.LEFT, fill=tk.BOTH, expand=True)
        bar.pack(side=tk.RIGHT, fill=tk.Y)
        self._on_pick = on_pick
        self._focus_back = focus_back
        self.listbox.bind("<<ListboxSelect>>", self._selected)

    def _selected(self, event: object) -> None:
        picked = self.listbox.curselection()
        self._on_pick(int(picked[0]) if picked else None)
        self._focus_back()

    def mark(self, index: Optional[int]) -> None:
        """Show `index` as selected without calling back."""
        self.listbox.selection_clear(0, tk.END)
        if index is not None and 0 <= index < self.listbox.size():
            self.listbox.selection_set(index)
            self.listbox.see(index)

    def items(self) -> List[str]:
        return list(self.listbox.get(0, tk.END))


class AgentList(_PickList):
    def __init__(self, master: tk.Misc, names: Sequence[str], colours: Sequence[str],
                 on_pick: Callable[[Optional[int]], None], focus_back: Callable[[], None]) -> None:
        super().__init__(master, "Agents ({})".format(len(names)), on_pick, 10, focus_back)
        # the name alone: "robot 3" (its id) on the lab fleet, else "agent 3" (its index)
        for i, (name, colour) in enumerate(zip(names, colours)):
            self.listbox.insert(tk.END, "\u25cf {}".format(name))
            self.listbox.itemconfigure(i, foreground=colour, selectforeground=colour,
                                       selectbackground="#d8d8d0")


class ConflictList(_PickList):
    def __init__(self, master: tk.Misc, on_pick: Callable[[Optional[int]], None],
                 focus_back: Callable[[], None]) -> None:
        super().__init__(master, "Conflicts", on_pick, 12, focus_back)

    def fill(self, labels: Sequence[str], following: int, rotations: int = 0, plan: bool = True) -> None:
        """The validator's findings; `plan` False: there is no plan to check (an instance)."""
        self.listbox.delete(0, tk.END)
        for label in labels:
            self.listbox.insert(tk.END, label)
        if not plan:
            title = "No plan to check: solve the instance (File menu)"
        else:
            title = "Conflicts and errors ({})".format(len(labels)) if labels else "No conflicts: the plan is valid"
        if following:
            title += "\n{} following moves (legal in mapf-IR)".format(following)
        if rotations:
            title += "\n{} rotations (legal in mapf-IR; robots cannot execute them)".format(rotations)
        self.title.configure(text=title)
