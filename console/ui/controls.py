"""ControlsBar: play/pause, step, reset, loop, speed and the time-step slider.

The bar only shows the clock and calls back; the app owns the clock. Setting
a ttk.Scale's value from code fires its command too, so `show` sets a guard
while it writes, and slider moves that the user makes are told apart.
"""
from __future__ import annotations

import math
import tkinter as tk
from tkinter import ttk
from typing import Callable, Dict

from ..sources import MAX_SPEED, MIN_SPEED


class ControlsBar(ttk.Frame):
    def __init__(self, master: tk.Misc, makespan: int, actions: Dict[str, Callable[[], None]],
                 on_seek: Callable[[float], None], on_speed: Callable[[float], None]) -> None:
        super().__init__(master, padding=(4, 2))
        self._on_seek, self._on_speed = on_seek, on_speed
        self._writing = False
        buttons = (("|\u25c0\u25c0", "reset"), ("\u25c0", "step_back"), ("\u25b6", "play_pause"),
                   ("\u25b6|", "step_forward"))
        self.play_button = None
        for text, action in buttons:
            b = ttk.Button(self, text=text, width=4, command=actions[action], takefocus=0)
            b.pack(side=tk.LEFT, padx=1)
            if action == "play_pause":
                self.play_button = b
        self.loop = tk.BooleanVar(self, value=True)
        ttk.Checkbutton(self, text="loop", variable=self.loop, command=actions["loop_from_button"],
                        takefocus=0).pack(side=tk.LEFT, padx=(6, 2))
        ttk.Label(self, text="speed").pack(side=tk.LEFT, padx=(8, 2))
        self.speed = ttk.Scale(self, from_=math.log2(MIN_SPEED), to=math.log2(MAX_SPEED), length=110,
                               command=self._speed_moved, takefocus=0)
        self.speed.pack(side=tk.LEFT)
        self.speed_label = ttk.Label(self, width=12)
        self.speed_label.pack(side=tk.LEFT, padx=(2, 8))
        ttk.Label(self, text="time step").pack(side=tk.LEFT)
        self.time = ttk.Scale(self, from_=0, to=max(makespan, 1e-9), command=self._time_moved, takefocus=0)
        self.time.pack(side=tk.LEFT, fill=tk.X, expand=True, padx=2)
        self.time_label = ttk.Label(self, width=14)
        self.time_label.pack(side=tk.LEFT)
        self.makespan = makespan
        if makespan == 0:
            for child in self.winfo_children():
                if isinstance(child, (ttk.Button, ttk.Scale, ttk.Checkbutton)):
                    child.state(["disabled"])

    def show(self, time: float, playing: bool, speed: float, loop: bool) -> None:
        self._writing = True
        try:
            self.time.set(time)
            self.speed.set(math.log2(speed))
        finally:
            self._writing = False
        self.time_label.configure(text="{:.2f} / {}".format(time, self.makespan))
        self.speed_label.configure(text="{:g} steps/s".format(round(speed, 2)))
        if self.play_button is not None:
            self.play_button.configure(text="||" if playing else "\u25b6")
        if self.loop.get() != loop:
            self.loop.set(loop)

    def _time_moved(self, value: str) -> None:
        if not self._writing:
            self._on_seek(float(value))

    def _speed_moved(self, value: str) -> None:
        if not self._writing:
            self._on_speed(2.0 ** float(value))
