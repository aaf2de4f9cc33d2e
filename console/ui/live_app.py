"""LiveApp: the console window of a running fleet, fed by the manager's state stream.

The player's window (`PlayerApp`: the same canvas, map view, keys, menus'
view entries, Ctrl+S) with the plan clock replaced by a `LiveSource`, which
drains the network thread's feed once a frame; so Tk runs on this thread
only and never waits on the network. Around the map: the admin panel on the
left (fig. 5.5), the robot panel and the event list on the right (fig. 5.6).

The scene can change while the window is open (a replan accepted, another
plan loaded, the robots' way to the starts, another manager): the map and
its layers are then built again for it, keeping the selected robot.
Buttons, boxes and menu entries only send requests through the link
(`ask`); the picture changes when the manager's state says so, and every
answer, refusals included, is shown in the admin panel, the status line and
the event list. Run buttons and menu entries the manager would refuse are
greyed, and say why (a note on the button the pointer rests on, the reason's
beginning in the menu entry). The File menu opens plans and instances for the fleet
(`LiveFiles`); F11 switches to the presentation view for visitors
(`Presentation`). Positions are written in the coordinates the view shows:
the plan file's own unless the operator switched (m).
"""
from __future__ import annotations

import time
import tkinter as tk
from tkinter import ttk
from typing import Any, Callable, List, Optional, Tuple

from .. import orientation
from ..fleet_state import FleetState
from ..live.describe import blocked_chain, details, greyed, row
from ..live.feed import CONNECTED, LOST, LiveFeed
from ..live.model import LiveModel, LiveSource, reply_text
from ..live.picture import WaitMarks, picture
from ..live.scene import placeholder_scene
from ..recent import RecentFiles
from ..view_options import ViewOptions
from .admin_panel import AdminPanel
from .app import PlayerApp
from .banner import Banner
from .event_list import EventList
from .live_actions import LiveActions
from .live_files import LiveFiles
from .map_view import HEADER_HEIGHT, MapView
from .overlays import SEPARATOR, AxesLayer, CellIdLayer, HeaderBand
from .presentation import LARGE, Bands, Presentation, run_words
from .proposal_layer import ProposalLayer
from .robot_layer import RobotLayer
from .robot_panel import RobotPanel
from .wait_layer import WaitLayer

#: Seconds between refreshes of the panels' texts (the map follows every state).
PANEL_PERIOD = 0.25
#: How the manager's reason ends while a proposal awaits the operator; the header's proposal part
#: says it already, so the reason beside it goes without it.
ASKED = ": accept or reject it"
#: The feed is looked at every 15 ms (a poll that finds nothing costs well under a
#: millisecond), so a state waits half as long for its frame as at the player's 33 ms.
POLL_MS = 15


class LiveApp(LiveFiles, LiveActions, PlayerApp):
    """The live console on `root`; `ask(action, based_on=..., **args)` sends a request (the link's
    `request`); `recent` keeps the files opened (default: for this session only); `present`
    opens it in the presentation view."""

    frame_ms = POLL_MS

    def __init__(self, root: tk.Tk, feed: LiveFeed, model: LiveModel, ask: Callable[..., None],
                 options: Optional[ViewOptions] = None, canvas_size: Tuple[int, int] = (560, 600),
                 recent: Optional[RecentFiles] = None, present: bool = False) -> None:
        self.model = model
        self.recent = recent or RecentFiles()
        self.instance = self.solving = self.solved = None
        self.map: Optional[MapView] = None
        self.live = LiveSource(feed, model)
        self._ask = ask
        self.wait_marks = WaitMarks()
        #: called after every frame (recording, screenshots, closing when done)
        self.after_frame: List[Callable[[], None]] = []
        self._panels_due = 0.0
        self._panels_stale = True
        self._greyed_for: Any = None
        self._canvas_size = canvas_size
        super().__init__(root, placeholder_scene(model.endpoint), options, source=self.live,
                         canvas_size=canvas_size, playing=False)
        root.title("FleetControl console: manager at {}".format(model.endpoint))
        root.bind("<F11>", lambda e: self._guarded(self.do_presentation)())
        if present:
            self.presentation.set(True)

    # -- building ----------------------------------------------------------------------

    def _build(self, canvas_size: Tuple[int, int]) -> None:
        root = self.root
        self.status = tk.StringVar(root, value="")
        self.status_bar = ttk.Label(root, textvariable=self.status, anchor=tk.W, padding=(6, 2))
        self.controls = None
        self.admin = AdminPanel(root, self.ask, self._pick_robot)
        self.right = ttk.Frame(root, padding=(2, 2))
        self.robot_panel = RobotPanel(self.right, self.ask)
        self.robot_panel.pack(fill=tk.X)
        self.robot_panel.show(None, "", (), (), (), None)  # the legend, until a robot is picked
        self.events = EventList(self.right, self.jump_to_robot)
        self.events.pack(fill=tk.BOTH, expand=True)
        for widget, pack in self._operator_parts():
            widget.pack(**pack)
        self.map_area = ttk.Frame(root)
        self.map_area.pack(side=tk.LEFT, fill=tk.BOTH, expand=True)
        self.presentation = Presentation(root, self._operator_parts, self.map_area, lambda: self.map,
                                         self._presentation_changed)
        self._build_map(canvas_size)

    def _operator_parts(self) -> List[Tuple[tk.Widget, dict]]:
        """The operator's panels around the map, with how they are packed (in this order)."""
        return [(self.status_bar, dict(side=tk.BOTTOM, fill=tk.X)), (self.admin, dict(side=tk.LEFT, fill=tk.Y)),
                (self.right, dict(side=tk.RIGHT, fill=tk.Y))]

    def _build_map(self, size: Tuple[int, int]) -> None:
        scene = self.scene
        if self.map is not None:
            self.map.destroy()
        self.map = MapView(self.map_area, scene.grid.free, size[0], size[1], down=self._mirrored())
        self.map.pack(fill=tk.BOTH, expand=True)
        canvas = self.canvas = self.map.canvas
        self.cell_ids = CellIdLayer(canvas, scene.grid.free, scene.file_orientation)
        self.proposal = ProposalLayer(canvas, scene.colours)
        self.agents = RobotLayer(canvas, scene, self.model.robot_ids())  # type: ignore[assignment]
        self.waits = WaitLayer(canvas, self.agents)
        self.axes = AxesLayer(canvas, scene.file_orientation)
        self.header = HeaderBand(canvas, scene.info)
        self.banner = Banner(canvas)
        self.bands = Bands(canvas)
        self.bands.set_fleet(scene.colours, scene.names)
        self.layers = (self.cell_ids, self.proposal, self.agents, self.waits, self.axes, self.header,
                       self.banner, self.bands)
        self.map.on_view_change(self.relayout)
        self.map.on_click = self._clicked
        self.map.on_hover = self._hovered
        canvas.focus_set()
        self._show_banner()
        self._present_overlays()

    # -- the presentation view ---------------------------------------------------------

    def _presentation_changed(self) -> None:
        self._present_overlays()
        if self.map is not None:
            if not self.presentation.on:
                self.map.set_bands(HEADER_HEIGHT, 0, 0)
            self.relayout()
        self._show_presentation(True)

    def _present_overlays(self) -> None:
        """The visitors' bands instead of the operator's header and axes (and large robots)."""
        on = self.presentation.on
        c = self.canvas
        for item in (self.header.band, self.header.line1, self.header.line2):
            c.itemconfigure(item, state=tk.HIDDEN if on else tk.NORMAL)
        c.itemconfigure("axes", state=tk.HIDDEN if on else tk.NORMAL)
        self.agents.min_radius = LARGE if on else 0.0  # type: ignore[attr-defined]
        if on:
            self.bands.show()
        else:
            self.bands.hide()

    def _show_presentation(self, story: bool) -> None:
        if not self.presentation.on:
            return
        run = self.model.state.run if self.model.state is not None else None
        name = self.model.setup.plan.name if self.model.setup is not None else ""
        proposal = self.model.proposal.kind if self.model.proposal is not None else None
        self.bands.set_run(*run_words(run, name, proposal))
        if story:
            self.bands.set_story(self.model.story)

    def relayout(self) -> None:
        if self.map is not None and self.presentation.on:
            bands = self.bands.bands_for(self.map.view.canvas_h)
            view = self.map.view
            if (view.top, view.bottom, view.right) != bands:
                self.map.set_bands(*bands)  # fits the map again, and relayouts
                return
        super().relayout()

    def place(self, x: float, y: float) -> Tuple[float, float]:
        """A position in the coordinates the view shows (the plan file's, unless switched)."""
        return orientation.shown_point(x, y, self.scene.grid.height, self.options.orientation,
                                       self.scene.file_orientation)

    # -- the frame loop ----------------------------------------------------------------

    def refresh(self) -> None:
        now = time.monotonic()
        state = self.live.poll(now)
        changes = self.live.take()
        if "scene" in changes:
            self._scene_changed()
        if "proposal" in changes:
            self.proposal.show(self.model.proposal_plan)
            self._status_changed()
        if state is not None:
            self.show(state)
        if "connection" in changes:
            self._connection_changed()
        if state is not None or changes & {"story", "proposal"}:
            self._show_presentation("story" in changes)
        self._grey_controls()
        self.solving_progress()
        self._panels_stale = self._panels_stale or bool(changes)
        if changes - {"state"} or (self._panels_stale and now >= self._panels_due):
            self.update_panels(changes)
            self._panels_due = now + PANEL_PERIOD
            self._panels_stale = False
        for hook in list(self.after_frame):
            hook()

    def show(self, state: FleetState) -> None:
        pic = picture(self.model)
        pic.waits = self.wait_marks.lasting(pic.waits, time.monotonic())
        self.agents.set_picture(pic)  # type: ignore[attr-defined]
        self._status_changed()
        super().show(state)

    def _scene_changed(self) -> None:
        selected = self.selected_robot()
        size = self._canvas_size
        if self.map is not None and self.canvas.winfo_width() > 1:
            size = (self.canvas.winfo_width(), self.canvas.winfo_height())
        self.scene = self.model.scene or placeholder_scene(self.model.endpoint)
        self.options.file_opened(self.scene.file_orientation)
        self.state = None
        self.options.selected = None
        self._build_map(size)
        self.admin.set_fleet(self.model.robot_ids(), self.scene.colours,
                             self.model.setup.strategies if self.model.setup else ())
        self._connection_changed()
        self.relayout()
        if selected is not None and selected in self.model.agent_of:
            self.select(self.model.agent_of[selected])

    def _connection_changed(self) -> None:
        self.admin.show_connection(self.model.connection)
        self._show_banner()
        if self.state is not None:
            self.show(self.model.fleet_state())  # grey or un-grey everything now

    def _show_banner(self) -> None:
        c = self.model.connection
        if c.status == CONNECTED:
            self.banner.set("" if self.model.scene is not None else "connected; waiting for the scene")
        elif c.status == LOST:
            self.banner.set("manager lost: reconnecting to {}".format(self.model.endpoint), lost=True)
        else:
            self.banner.set(c.text)  # connecting, or why nothing answers

    def update_panels(self, changes: Any = ()) -> None:
        """Refresh the admin panel, the robot panel and the event list from the model."""
        m = self.model
        run = m.state.run if m.state is not None else None
        self.admin.show_run(run)
        by_id = {r.id: r for r in m.state.robots} if m.state is not None else {}
        self.admin.show_rows(lambda rid: row(rid, by_id.get(rid), m.connected, self.place))
        sources = {r.source for r in by_id.values()}
        if len(sources) == 1:
            self.admin.show_source(sources.pop())
        if "reply" in changes:
            self.admin.show_reply(m.last_reply, run)
            if m.last_reply is not None:
                self.status.set(reply_text(m.last_reply))
        self.events.sync(list(m.lines))
        self._show_robot()

    def _grey_controls(self) -> None:
        """The run's buttons and menu entries greyed, saying why, as soon as what the manager allows
        changes (not at the panels' pace: a button must not be pressable a quarter second too long)."""
        run = self.model.state.run if self.model.state is not None else None
        key = (self.model.connected, None if run is None else (run.allowed, run.proposal, run.why_not))
        if key != self._greyed_for:
            self._greyed_for = key
            self.admin.grey(run)
            self.grey_run_menu()

    def _show_robot(self) -> None:
        m, rid = self.model, self.selected_robot()
        r = m.robot(rid) if rid is not None else None
        if rid is None or r is None:
            self.robot_panel.show(rid, "", (), (), (), None if rid is None else "no state yet")
            return
        robots = {x.id: x for x in m.state.robots} if m.state is not None else {}
        events = [line for line in m.lines if line.robot == rid]
        self.robot_panel.show(rid, self.scene.colours[m.agent_of[rid]], details(r, m.state.run, self.place),
                              blocked_chain(robots, rid, place=self.place), events, greyed(r, m.connected))

    def _status_changed(self) -> None:
        run = self.model.state.run if self.model.state is not None else None
        if run is None:
            status = self.model.connection.text
        else:
            reason = run.reason
            if self.model.proposal is not None and reason.endswith(ASKED):
                reason = reason[:-len(ASKED)]  # the proposal's own part leads with what to do
            parts = [run.state + (": " + reason if reason else ""),
                     "clock {:.1f} s".format(run.clock),
                     "arrived {}/{}".format(run.arrived, run.robots),
                     "strategy {}".format(run.strategy + (" (lookahead {})".format(run.lookahead)
                                                          if run.strategy == "adg" else ""))]
            proposal = self.model.proposal
            # the line says who goes round whom; what to do comes first, as a long line is cut at its end
            if proposal is not None and proposal.kind == "reroute":
                parts.insert(0, "REROUTE PROPOSAL {} (dashed; accept or reject): {}".format(
                    proposal.id, proposal.message))
            elif proposal is not None:
                parts.insert(0, "REPLAN PROPOSAL {} (dashed): accept or reject".format(proposal.id))
            if run.reroute != "off":
                parts.append("reroute {}{}{}".format(run.reroute, ", every robot" if run.reroute_scope == "all" else "",
                                                     ", trimmed" if run.trim else ""))
            elif run.trim:
                parts.append("plans trimmed")
            status = SEPARATOR.join(parts)
        self.header.set_status(status, self.scene.makespan, self.model.plan_start())

    def _fill_conflicts(self) -> None:
        pass  # a live run has no validator findings to list
