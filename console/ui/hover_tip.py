"""HoverTip: a small note by a widget while the pointer rests on it (a greyed button's why).

The note says what `text()` says when it shows, and again on `refresh()` (the
manager's reason can change while the pointer rests: a robot arrives); an
empty text shows nothing. It comes after a short delay, so that a pointer
crossing a row of buttons does not flash a note on each, and goes on leaving
or pressing the widget.
"""
from __future__ import annotations

import tkinter as tk
from typing import Callable, Optional

#: Milliseconds the pointer rests on the widget before the note shows.
DELAY_MS = 350
FONT = ("DejaVu Sans", -12)
#: Wrapped at this many pixels: a reason of 300 characters makes six short lines.
WRAP = 340


class HoverTip:
    def __init__(self, widget: tk.Widget, text: Callable[[], str], delay_ms: int = DELAY_MS) -> None:
        self.widget, self.text, self.delay_ms = widget, text, delay_ms
        self.window: Optional[tk.Toplevel] = None
        self._label: Optional[tk.Label] = None
        self._due: Optional[str] = None
        widget.bind("<Enter>", lambda e: self._schedule(), add="+")
        widget.bind("<Leave>", lambda e: self.hide(), add="+")
        widget.bind("<ButtonPress>", lambda e: self.hide(), add="+")

    @property
    def shown(self) -> str:
        """The note's text while it shows ("" otherwise)."""
        return "" if self._label is None else str(self._label.cget("text"))

    def refresh(self) -> None:
        """Say `text()` again if the note shows (gone if it is empty now)."""
        if self._label is None:
            return
        text = self.text()
        if not text:
            self.hide()
        elif text != self.shown:
            self._label.configure(text=text)

    def hide(self) -> None:
        if self._due is not None:
            self.widget.after_cancel(self._due)
            self._due = None
        if self.window is not None:
            self.window.destroy()
        self.window = self._label = None

    def _schedule(self) -> None:
        self.hide()
        self._due = self.widget.after(self.delay_ms, self._show)

    def _show(self) -> None:
        self._due = None
        text = self.text()
        if not text or not self.widget.winfo_ismapped():
            return
        w = self.widget
        self.window = tk.Toplevel(w)
        self.window.wm_overrideredirect(True)  # no frame, no title: a note, not a window
        self._label = tk.Label(self.window, text=text, font=FONT, justify=tk.LEFT, wraplength=WRAP,
                               background="#fff8d0", foreground="#202020", relief=tk.SOLID, borderwidth=1,
                               padx=5, pady=3)
        self._label.pack()
        # below the widget, kept on the screen (a button at the window's right edge)
        self.window.update_idletasks()
        x = min(w.winfo_rootx(), w.winfo_screenwidth() - self.window.winfo_reqwidth() - 2)
        self.window.wm_geometry("+{}+{}".format(max(0, x), w.winfo_rooty() + w.winfo_height() + 2))
