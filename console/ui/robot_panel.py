"""RobotPanel: everything about the selected robot (thesis fig. 5.6).

Its details (link, pose, source and age, Vicon, faults, action, progress,
timing), the chain of robots it is blocked by, and its last events, in one
read-only text box that is rewritten when the picture changes. Robot panel
buttons act on this robot only: enable or disable it, take its position from
the robot or from Vicon.
"""
from __future__ import annotations

import tkinter as tk
from tkinter import ttk
from typing import Callable, List, Optional, Sequence, Tuple

from ..live.model import Line

FONT = ("DejaVu Sans", -12)
MONO = ("DejaVu Sans Mono", -11)
#: Events of the robot shown in its panel.
LAST_EVENTS = 8
#: What the panel says while no robot is selected: how to read the map.
LEGEND = (
    ("On the map\n", "head"),
    ("  disc        a robot where it reports it is;\n"
     "              the white tick shows where it faces\n", ""),
    ("  dashed ring where the plan wants it now\n", ""),
    ("  yellow ring behind its plan\n", ""),
    ("  red frame   the cell a robot waits to enter;\n"
     "              the red arrow points to the robot\n"
     "              it waits for\n", "warn"),
    ("  grey disc   link down, stale pose, fault or\n"
     "              disabled: the reason is under it\n", ""),
    ("  square      a robot's goal\n", ""),
    ("\nClick a robot (map or list) for its details,\n"
     "its remaining plan and who blocks it.\n", ""),
)


class RobotPanel(ttk.LabelFrame):
    def __init__(self, master: tk.Misc, on_action: Callable[..., None]) -> None:
        super().__init__(master, text="Robot", padding=(6, 4))
        self.on_action = on_action
        head = ttk.Frame(self)
        head.pack(fill=tk.X)
        self.swatch = tk.Canvas(head, width=18, height=18, highlightthickness=0)
        self.swatch.pack(side=tk.LEFT)
        self._disc = self.swatch.create_oval(2, 2, 16, 16, fill="", outline="")
        self.title = ttk.Label(head, text="click a robot on the map or in the list", font=FONT)
        self.title.pack(side=tk.LEFT, padx=4)
        bar = ttk.Frame(self)
        bar.pack(fill=tk.X, pady=(4, 2))
        self.buttons = {}
        for label, action, args in (("Enable", "enable", {}), ("Disable", "disable", {}),
                                    ("Robot pose", "source", {"source": "robot"}),
                                    ("Vicon pose", "source", {"source": "vicon"})):
            b = ttk.Button(bar, text=label, takefocus=0, width=9,
                           command=lambda a=action, kw=args: self._act(a, kw))
            b.pack(side=tk.LEFT, padx=1)
            self.buttons[label] = b
        self.text = tk.Text(self, width=44, height=17, font=MONO, wrap=tk.WORD, relief=tk.FLAT,
                            background="#fbfbf8", takefocus=0)
        self.text.pack(fill=tk.BOTH, expand=True)
        self.text.tag_configure("head", font=("DejaVu Sans", -12, "bold"))
        self.text.tag_configure("warn", foreground="#c8101a")
        self.text.configure(state=tk.DISABLED)
        self.robot_id: Optional[int] = None
        self._shown: Tuple = ()

    def _act(self, action: str, args: dict) -> None:
        if self.robot_id is not None:
            self.on_action(action, robot=self.robot_id, **args)

    def show(self, robot_id: Optional[int], colour: str, details: Sequence[Tuple[str, str]],
             chain: Sequence[str], events: Sequence[Line], grey: Optional[str]) -> None:
        """Fill the panel (rewritten only if something changed)."""
        shown = (robot_id, colour, tuple(details), tuple(chain), tuple(events), grey)
        if shown == self._shown:
            return
        self._shown = shown
        self.robot_id = robot_id
        self.swatch.itemconfigure(self._disc, fill=colour if robot_id is not None else "",
                                  outline="#1e1e1e" if robot_id is not None else "")
        self.configure(text="Robot {}".format(robot_id) if robot_id is not None else "Robot")
        self.title.configure(text="robot {}{}".format(robot_id, ": " + grey if grey else "")
                             if robot_id is not None else "click a robot on the map or in the list")
        lines: List[Tuple[str, str]] = [] if robot_id is not None else list(LEGEND)
        for label, value in details:
            lines.append(("{:<9s}{}\n".format(label, value), "warn" if "STALE" in value or "DISAGREES" in value else ""))
        if robot_id is not None:
            lines.append(("Blocked by\n", "head"))
            lines += [("  " + c + "\n", "warn") for c in chain] or [("  nobody\n", "")]
            lines.append(("Last events\n", "head"))
            lines += [("  {} {}\n".format(e.clock, e.text), "warn" if e.level != "info" else "")
                      for e in events[-LAST_EVENTS:]] or [("  none yet\n", "")]
        self.text.configure(state=tk.NORMAL)
        self.text.delete("1.0", tk.END)
        for text, tag in lines:
            self.text.insert(tk.END, text, (tag,) if tag else ())
        self.text.configure(state=tk.DISABLED)

    def content(self) -> str:
        return self.text.get("1.0", tk.END)
