"""The presentation view: the live map for visitors, full screen, with a legend and the run's story.

`Presentation` switches the live console between the operator's window (the
panels left and right, the status line, the menus) and a view for visitors:
the map alone on the whole screen, robots drawn large, a title band (the
plan, what the run is doing, its clock, how many robots are home), a legend
of what the marks on the map mean, and a ticker at the bottom with the last
sentences of the run's story in words (`console.live.ticker`: "robot 2
stalled", "robot 3 waits for robot 2"). F11 or View -> presentation switches;
the demo's console opens in it. Only the view changes: nothing is asked of
the manager, and the operator's panels come back as they were.

`Bands` draws the title, the legend and the ticker on the map's canvas, as
overlays that stay on top of the robots.
"""
from __future__ import annotations

import tkinter as tk
from pathlib import PurePath
from tkinter import font as tkfont
from typing import Callable, List, Optional, Sequence, Tuple

from fleet_common.control import RunInfo

from ..live.model import Line
from ..view_options import ViewOptions
from ..viewport import Viewport
from .map_view import HEADER_HEIGHT, MapView
from .robot_layer import BEHIND, GREY
from .wait_layer import WAIT

__all__ = ["Presentation", "Bands", "run_words", "TICKER_LINES"]

#: Sentences the ticker shows, newest at the bottom.
TICKER_LINES = 4
TITLE_FONT = "DejaVu Sans"
INK = "#1c1c1c"
FADED = "#7a7a74"
PAPER = "#fbfbf7"
#: The smallest robot disc in the presentation view (pixels of radius): visitors see robots.
LARGE = 6.0
#: What the marks on the map mean, in the legend's words.
LEGEND = ("a robot, where it is (the tick: where it faces)", "where the plan wants it now", "behind the plan",
          "waits to enter a cell, for the robot the arrow points to", "out of the run (disabled, fault, no link)",
          "a robot's goal")
#: Fleets this small get a legend line for each robot (its colour and id).
LEGEND_ROBOTS = 12


#: The title band's words for a proposal on the map (its paths dashed), by what proposed it.
PROPOSED = {"reroute": "dashed: a new way round, for the operator to accept",
            "replan": "dashed: a new plan, for the operator to accept"}


def run_words(run: Optional[RunInfo], name: str, proposal: Optional[str] = None) -> Tuple[str, str]:
    """The title band's two lines (`name`: the plan, its file name is what a visitor reads;
    `proposal`: the kind of a proposal drawn on the map, said so that dashed paths have words)."""
    name = PurePath(name).name
    if run is None:
        return "FleetControl: {}".format(name or "waiting for the manager"), "waiting for the manager"
    what = {"waiting": "ready, waiting for Start", "running": "running", "paused": "paused",
            "stopped": "stopped: robots finish their move", "done": "done", "failed": "failed"}.get(
        run.state, run.state)
    if run.purpose == "to-starts":
        what = "driving to the starts" if run.state == "running" else what + " (on the way to the starts)"
    safety = "no collision" if run.collisions == 0 else "{} collisions".format(run.collisions)
    proposed = "  \u00b7  " + PROPOSED.get(proposal, PROPOSED["replan"]) if proposal else ""
    return ("FleetControl: {}  \u00b7  {} robots  \u00b7  strategy {}".format(name, run.robots, run.strategy),
            "{}  \u00b7  {:.0f} s  \u00b7  {} of {} at their goals  \u00b7  {}{}".format(
                what, run.clock, run.arrived, run.robots, safety, proposed))


class Bands:
    """The title band, the legend and the ticker, drawn over the map's canvas."""

    def __init__(self, canvas: tk.Canvas) -> None:
        self.canvas = canvas
        tags = ("overlay", "present")
        c = canvas
        self.title_box = c.create_rectangle(0, 0, 0, 0, fill=PAPER, outline="#c8c8c0", tags=tags)
        self.title = c.create_text(0, 0, anchor=tk.W, fill=INK, tags=tags)
        self.subtitle = c.create_text(0, 0, anchor=tk.W, fill="#303030", tags=tags)
        self.ticker_box = c.create_rectangle(0, 0, 0, 0, fill=PAPER, outline="#c8c8c0", tags=tags)
        self.ticker = [c.create_text(0, 0, anchor=tk.W, tags=tags) for _ in range(TICKER_LINES)]
        self.legend_items: List[int] = []
        self.colours: Sequence[str] = ()
        self.names: Sequence[str] = ()
        self.font = 18
        self.top = self.bottom = self.right = 0
        self.shown = False
        self.hide()

    def bands_for(self, canvas_h: int) -> Tuple[int, int, int]:
        """(top, bottom, right): the title's and the ticker's heights and the legend's width for a
        canvas `canvas_h` pixels high (the map fits in what is left)."""
        self.font = max(14, min(26, canvas_h // 40))
        self.top = int(self.font * 3.4)
        self.bottom = int(self.font * 1.55 * TICKER_LINES + self.font)
        f = tkfont.Font(root=self.canvas, family=TITLE_FONT, size=-self._legend_font())
        widest = max(f.measure(words) for words in LEGEND + tuple(self.names[:LEGEND_ROBOTS]))
        self.right = int(widest + 4 * self._legend_font() * 0.55 + 10 + 20 + 24)
        return self.top, self.bottom, self.right

    def _legend_font(self) -> int:
        return max(12, int(self.font * 0.7))

    def show(self) -> None:
        self.shown = True
        self.canvas.itemconfigure("present", state=tk.NORMAL)
        self.canvas.tag_raise("present")

    def hide(self) -> None:
        self.shown = False
        self.canvas.itemconfigure("present", state=tk.HIDDEN)

    def relayout(self, view: Viewport, options: ViewOptions) -> None:
        c, f, w, h = self.canvas, self.font, view.canvas_w, view.canvas_h
        c.coords(self.title_box, -1, -1, w + 1, self.top)
        c.coords(self.title, 18, self.top * 0.32)
        c.coords(self.subtitle, 18, self.top * 0.72)
        c.itemconfigure(self.title, font=(TITLE_FONT, -f, "bold"))
        c.itemconfigure(self.subtitle, font=(TITLE_FONT, -int(f * 0.85)))
        c.coords(self.ticker_box, -1, h - self.bottom, w + 1, h + 1)
        step = f * 1.55
        for k, item in enumerate(self.ticker):
            c.coords(item, 18, h - self.bottom + f * 0.5 + (k + 0.5) * step)
        self._legend(view)
        if self.shown:
            c.tag_raise("present")

    def update(self, state: object) -> None:
        pass  # the app writes the words (`set_run`, `set_story`): they come from the model

    def set_run(self, title: str, subtitle: str) -> None:
        self.canvas.itemconfigure(self.title, text=title)
        self.canvas.itemconfigure(self.subtitle, text=subtitle)

    def set_story(self, lines: Sequence[Line]) -> None:
        """The last sentences, newest at the bottom in bold, older ones fainter."""
        last = list(lines)[-TICKER_LINES:]
        last = [None] * (TICKER_LINES - len(last)) + last  # type: ignore[list-item]
        for k, (item, line) in enumerate(zip(self.ticker, last)):
            newest = k == TICKER_LINES - 1
            self.canvas.itemconfigure(
                item, text="" if line is None else "{}   {}".format(line.clock, line.text),
                fill=INK if newest else FADED,
                font=(TITLE_FONT, -int(self.font * (1.0 if newest else 0.85)), "bold" if newest else ""))

    def text(self) -> str:
        """What the bands say (title, then the ticker), for tests and recordings."""
        parts = [self.canvas.itemcget(self.title, "text"), self.canvas.itemcget(self.subtitle, "text")]
        return "\n".join(parts + [self.canvas.itemcget(i, "text") for i in self.ticker])

    def set_fleet(self, colours: Sequence[str], names: Sequence[str]) -> None:
        self.colours, self.names = colours, names

    def _legend(self, view: Viewport) -> None:
        """What the marks mean, in a box at the right of the map (over it if there is no room)."""
        c = self.canvas
        for item in self.legend_items:
            c.delete(item)
        self.legend_items = []
        f = self._legend_font()
        r = f * 0.55
        colour = self.colours[0] if self.colours else "#3a78c8"
        rows: List[Tuple[Callable[[float, float], List[int]], str]] = [
            (lambda x, y: [c.create_oval(x - r, y - r, x + r, y + r, fill=colour, outline=INK),
                           c.create_line(x + 0.4 * r, y, x + r, y, fill="#ffffff", width=2)],
             LEGEND[0]),
            (lambda x, y: [c.create_oval(x - r, y - r, x + r, y + r, outline=colour, dash=(4, 3), width=2)],
             LEGEND[1]),
            (lambda x, y: [c.create_oval(x - r, y - r, x + r, y + r, fill=colour, outline=BEHIND, width=3)],
             LEGEND[2]),
            (lambda x, y: [c.create_rectangle(x - r, y - r, x + r, y + r, outline=WAIT, width=3),
                           c.create_line(x + r + 2, y, x + 3 * r, y, fill=WAIT, width=3, arrow=tk.LAST)],
             LEGEND[3]),
            (lambda x, y: [c.create_oval(x - r, y - r, x + r, y + r, fill=GREY, outline=colour, width=2)],
             LEGEND[4]),
            (lambda x, y: [c.create_rectangle(x - r * 0.5, y - r * 0.5, x + r * 0.5, y + r * 0.5, fill=colour,
                                              outline="")],
             LEGEND[5]),
        ]
        if 0 < len(self.colours) <= LEGEND_ROBOTS:
            for colour_k, name in zip(self.colours, self.names):
                rows.append((lambda x, y, k=colour_k: [c.create_oval(x - r, y - r, x + r, y + r, fill=k,
                                                                     outline=INK)], name))
        line_h = f * 1.6
        tags = ("overlay", "present")
        # the words first, to know how wide the box must be; then the box behind them
        texts = [c.create_text(0, 0, anchor=tk.W, text="On the map", font=(TITLE_FONT, -f, "bold"), fill=INK,
                               tags=tags)]
        texts += [c.create_text(0, 0, anchor=tk.W, text=words, font=(TITLE_FONT, -f), fill=INK, tags=tags)
                  for _, words in rows]
        widest = max((c.bbox(t)[2] - c.bbox(t)[0]) for t in texts)
        symbols = 4 * r + 10
        x1 = view.canvas_w - 12
        x0 = x1 - (20 + symbols + widest)
        y0 = self.top + 12
        box = c.create_rectangle(x0, y0, x1, y0 + line_h * (len(rows) + 1) + 8, fill=PAPER,
                                 outline="#c8c8c0", tags=tags)
        c.tag_lower(box, texts[0])
        self.legend_items += [box] + texts
        c.coords(texts[0], x0 + 10, y0 + line_h * 0.6)
        for k, (draw, _) in enumerate(rows):
            y = y0 + line_h * (k + 1.6)
            c.coords(texts[k + 1], x0 + 10 + symbols, y)
            for item in draw(x0 + 10 + r, y):
                c.addtag_withtag("present", item)
                c.addtag_withtag("overlay", item)
                self.legend_items.append(item)
        state = tk.NORMAL if self.shown else tk.HIDDEN
        for item in self.legend_items:
            c.itemconfigure(item, state=state)


class Presentation:
    """Switches the live console's window between the operator's view and the visitors' one."""

    def __init__(self, root: tk.Tk, operator_parts: Callable[[], Sequence[Tuple[tk.Widget, dict]]],
                 map_area: tk.Widget, get_map: Callable[[], MapView], on_change: Callable[[], None]) -> None:
        self.root = root
        self.operator_parts = operator_parts  # (widget, its pack options), in packing order
        self.map_area = map_area
        self.get_map = get_map
        self.on_change = on_change
        self.on = False
        self._geometry = ""
        self._menu: Optional[str] = None

    def toggle(self) -> None:
        self.set(not self.on)

    def set(self, on: bool) -> None:
        if on == self.on:
            return
        self.on = on
        root = self.root
        if on:
            self._geometry = root.geometry()
            self._menu = str(root.cget("menu"))
            root.configure(menu="")
            for widget, _ in self.operator_parts():
                widget.pack_forget()
            try:
                root.attributes("-fullscreen", True)
            except tk.TclError:
                pass
            # without a window manager (Xvfb) -fullscreen does nothing: take the screen ourselves
            root.geometry("{}x{}+0+0".format(root.winfo_screenwidth(), root.winfo_screenheight()))
        else:
            try:
                root.attributes("-fullscreen", False)
            except tk.TclError:
                pass
            self.map_area.pack_forget()
            for widget, options in self.operator_parts():
                widget.pack(**options)
            self.map_area.pack(side=tk.LEFT, fill=tk.BOTH, expand=True)
            if self._menu:
                root.configure(menu=self._menu)
            # the size it had (none yet if it opened in this view: then its natural size)
            size = self._geometry.split("+")[0]
            root.geometry(self._geometry if size and int(size.split("x")[0]) > 200 else "")
        self.on_change()

    def bands(self, canvas_h: int, bands: Bands) -> Tuple[int, int, int]:
        return bands.bands_for(canvas_h) if self.on else (HEADER_HEIGHT, 0, 0)
