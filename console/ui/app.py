"""PlayerApp: the console window, wiring a fleet-state source to the views.

Threading rule (as in thonny): Tk is touched on the main thread only. A source
is polled by one `after()` loop every FRAME_MS; a live source is a
`QueueSource` that network threads fill, so nothing else ever reaches into Tk.
Key, menu and mouse handlers run on the same thread; a handler that fails
logs its error and shows it in the status line instead of ending the window.
Slow work (reading a file, solving an instance: `FileActions`) runs in a
`Jobs` thread whose results the same loop drains; `open_scene` then shows the
new scene in this window.
"""
from __future__ import annotations

import logging
import time
import tkinter as tk
from tkinter import ttk
from typing import Callable, Dict, Optional, Tuple, Union

import numpy as np

from fleet_common.plan import Plan

from .. import orientation
from ..conflicts import conflict_entries
from ..fleet_state import FleetState
from ..jobs import Jobs
from ..keys import FILE, GROUPS, KEYS
from ..scene import Scene
from ..sources import DEFAULT_SPEED, PlanClock, QueueSource
from .tk_gc import TkThreadCollector
from ..view_options import ViewOptions
from .actions import PlayerActions
from .agent_layer import AgentLayer
from .conflict_layer import ConflictLayer
from .controls import ControlsBar
from .file_actions import FileActions
from .lists import AgentList, ConflictList
from .map_view import MapView
from .overlays import SEPARATOR, AxesLayer, CellIdLayer, HeaderBand

log = logging.getLogger(__name__)

#: One frame every 33 ms: 30 frames per second while something moves.
FRAME_MS = 33
#: Seconds before the same failure of a frame is logged again.
FAILURE_QUIET = 10.0


class PlayerApp(PlayerActions, FileActions):
    """The player window on `root`; `source` None plays `scene.plan` with a `PlanClock`."""

    #: milliseconds between polls of the source
    frame_ms = FRAME_MS

    def __init__(self, root: tk.Tk, scene: Scene, options: Optional[ViewOptions] = None,
                 source: Optional[QueueSource] = None, canvas_size: Tuple[int, int] = (900, 680),
                 playing: bool = True, speed: float = DEFAULT_SPEED) -> None:
        self.root = root
        self.options = options or ViewOptions()
        self.jobs = Jobs()
        self.collector = TkThreadCollector(root)  # Tk objects are freed on this thread only
        self.speed = speed
        self._after: Optional[str] = None
        self._failures: Dict[str, float] = {}
        root.report_callback_exception = self._report  # type: ignore[assignment]
        self._load(scene, source, canvas_size, playing)
        root.bind("<Destroy>", self._destroyed, add="+")
        self._tick()

    def open_scene(self, scene: Scene) -> None:
        """Show `scene` instead of the current one, in the same window (File menu, solving)."""
        size = (self.canvas.winfo_width(), self.canvas.winfo_height())
        for child in self.root.winfo_children():
            child.destroy()
        self.options.selected, self.options.only_selected = None, False
        self._load(scene, None, size, True)

    # -- building ----------------------------------------------------------------------

    def _load(self, scene: Scene, source: Optional[QueueSource], canvas_size: Tuple[int, int],
              playing: bool) -> None:
        self.scene = scene
        self.options.file_opened(scene.file_orientation)
        self.clock: Optional[PlanClock] = None
        self.source: Union[PlanClock, QueueSource]
        if source is None:
            plan = scene.plan if scene.plan is not None else Plan(np.array([scene.starts]).reshape(1, -1, 2))
            self.clock = PlanClock(plan, speed=self.speed, playing=playing and plan.makespan > 0)
            self.source = self.clock
        else:
            self.source = source
        self.entries = conflict_entries(scene.findings)
        self.state: Optional[FleetState] = None
        self.root.title("FleetControl player: {}".format(scene.title or "plan"))
        self.actions: Dict[str, Callable[[], None]] = {
            k.action: self._guarded(getattr(self, "do_" + k.action)) for k in KEYS}
        self.actions["loop_from_button"] = self._guarded(self._loop_from_button)
        self._build(canvas_size)
        self._bind_keys()
        self._build_menus()
        self.relayout()
        self._status_changed()

    def _build(self, canvas_size: Tuple[int, int]) -> None:
        scene, root = self.scene, self.root
        self.status = tk.StringVar(root, value="")
        ttk.Label(root, textvariable=self.status, anchor=tk.W, padding=(6, 2)).pack(side=tk.BOTTOM, fill=tk.X)
        self.controls: Optional[ControlsBar] = None
        if self.clock is not None:
            self.controls = ControlsBar(root, self.clock.makespan, self.actions, self._seek_from_slider,
                                        self._speed_from_slider)
            self.controls.pack(side=tk.BOTTOM, fill=tk.X)
        side = ttk.Frame(root, padding=(2, 2))
        side.pack(side=tk.RIGHT, fill=tk.Y)
        self.map = MapView(root, scene.grid.free, canvas_size[0], canvas_size[1], down=self._mirrored())
        self.map.pack(side=tk.LEFT, fill=tk.BOTH, expand=True)
        canvas = self.canvas = self.map.canvas
        self.cell_ids = CellIdLayer(canvas, scene.grid.free, scene.file_orientation, scene.node_ids)
        self.agents = AgentLayer(canvas, scene)
        self.conflicts = ConflictLayer(canvas, self.entries)
        self.axes = AxesLayer(canvas, scene.file_orientation)
        self.header = HeaderBand(canvas, scene.info)
        self.layers = (self.cell_ids, self.agents, self.conflicts, self.axes, self.header)
        focus = self.canvas.focus_set
        self.agent_list = AgentList(side, scene.names, scene.colours, self._pick_agent, focus)
        self.agent_list.pack(fill=tk.BOTH, expand=True)
        self.conflict_list = ConflictList(side, self._pick_conflict, focus)
        self.conflict_list.pack(fill=tk.BOTH, expand=True)
        self._fill_conflicts()
        self.map.on_view_change(self.relayout)
        self.map.on_click = self._clicked
        self.map.on_hover = self._hovered
        canvas.focus_set()

    def _bind_keys(self) -> None:
        for key in KEYS:
            handler = self.actions[key.action]
            for sequence in key.sequences:
                self.root.bind(sequence, lambda e, h=handler: h())

    def _build_menus(self) -> None:
        bar = tk.Menu(self.root, tearoff=False)
        self.menus: Dict[str, tk.Menu] = {}
        for group in GROUPS:
            menu = self.menus[group] = tk.Menu(bar, tearoff=False)
            for key in KEYS:
                if key.group == group:
                    menu.add_command(label=key.help, accelerator=key.shown, command=self.actions[key.action])
            bar.add_cascade(label=group, menu=menu)
        self._add_solve_menu(self.menus[FILE])
        self.root.configure(menu=bar)
        self.menubar = bar

    # -- the frame loop ----------------------------------------------------------------

    def _tick(self) -> None:
        started = time.perf_counter()
        try:
            self.jobs.drain()  # results of background work, handled here on the Tk thread
            self.refresh()
        except Exception as err:  # one bad frame must not stop the loop, nor flood the log
            key = "{}: {}".format(type(err).__name__, err)
            if self._failures.get(key, -1e9) + FAILURE_QUIET <= started:
                self._failures[key] = started
                log.exception("frame failed (the same failure is logged again after %g s at most)",
                              FAILURE_QUIET)
        spent = int((time.perf_counter() - started) * 1000)
        self._after = self.root.after(max(1, self.frame_ms - spent), self._tick)

    def refresh(self) -> None:
        """Poll the source now and draw what changed."""
        state = self.source.poll(time.monotonic())
        if state is not None:
            self.show(state)

    def show(self, state: FleetState) -> None:
        was_playing = self.clock is not None and self.clock.playing
        self.state = state
        if self.options.follow and self._keep_in_sight(state):
            return  # the view moved: everything was placed again, this state with it
        for layer in self.layers:
            layer.update(state)
        self._show_controls()
        if self.clock is not None and was_playing != self.clock.playing:
            self._status_changed()

    def _show_controls(self) -> None:
        if self.clock is not None and self.controls is not None:
            self.controls.show(self.clock.time, self.clock.playing, self.clock.speed, self.clock.loop)

    def _keep_in_sight(self, state: FleetState) -> bool:
        """Follow mode: when the selected agent nears the view's edge, centre the view on it
        (not at every frame: the map picture is drawn again each time the view moves)."""
        agent = self.options.selected
        if agent is None or not 0 <= agent < len(state.positions):
            return False
        x, y = (float(v) for v in state.positions[agent])
        view = self.map.view
        cx, cy = view.to_canvas(x, y)
        w, top, bottom = view.canvas_w - view.right, view.top, view.canvas_h - view.bottom
        if 0.2 * w <= cx <= 0.8 * w and top + 0.2 * (bottom - top) <= cy <= bottom - 0.2 * (bottom - top):
            return False
        view.centre_on(x, y)
        self.map.changed()
        return True

    def relayout(self) -> None:
        """Place every item again (the view or the options changed)."""
        for layer in self.layers:
            layer.relayout(self.map.view, self.options)
        if self.state is not None:
            for layer in self.layers:
                layer.update(self.state)
        self.canvas.tag_raise("overlay")

    def close(self) -> None:
        self.root.destroy()

    def _destroyed(self, event: "tk.Event[tk.Misc]") -> None:
        # the window is going (q, the window manager, a test): stop the frame loop with it
        if event.widget is self.root and self._after is not None:
            self.root.after_cancel(self._after)
            self._after = None

    # -- helpers -----------------------------------------------------------------------

    def _mirrored(self) -> bool:
        return orientation.rows_grow_down(self.options.orientation, self.scene.file_orientation)

    def shown_cell(self, cell: Tuple[int, int]) -> Tuple[int, int]:
        """A base cell in the coordinates the current orientation shows."""
        return orientation.shown_cell(cell, self.scene.grid.height, self.options.orientation,
                                      self.scene.file_orientation)

    def _status_changed(self) -> None:
        parts = []
        if self.clock is not None and self.clock.makespan > 0:
            parts += ["playing" if self.clock.playing else "paused",
                      "{:g} steps/s".format(round(self.clock.speed, 2)),
                      "loop" if self.clock.loop else "no loop"]
        parts.append(orientation.DESCRIPTIONS[self.options.orientation])
        self.header.set_status(SEPARATOR.join(parts), self.scene.makespan)
        self._show_controls()

    def _fill_conflicts(self) -> None:
        h = self.scene.grid.height
        labels = [e.label(h, self.options.orientation, self.scene.file_orientation) for e in self.entries]
        self.conflict_list.fill(labels, self.scene.following, self.scene.rotations, self.scene.plan is not None)

    def _guarded(self, fn: Callable[[], None]) -> Callable[[], None]:
        def run() -> None:
            try:
                fn()
            except Exception as err:
                log.exception("%s failed", getattr(fn, "__name__", "action"))
                self.status.set("error: {}".format(err))
        return run

    def _report(self, exc: type, value: BaseException, tb: object) -> None:
        log.error("Tk callback failed", exc_info=(exc, value, tb))  # type: ignore[arg-type]
        self.status.set("error: {}".format(value))

    def _clock_changed(self) -> None:
        self.refresh()
        self._status_changed()

    def _seek_from_slider(self, t: float) -> None:
        if self.clock is not None:
            self.clock.pause()
            self.clock.seek(t)
            self._clock_changed()

    def _speed_from_slider(self, speed: float) -> None:
        if self.clock is not None:
            self.clock.speed = speed
            self._status_changed()

    def _loop_from_button(self) -> None:
        if self.clock is not None and self.controls is not None:
            self.clock.loop = self.controls.loop.get()
            self._status_changed()
