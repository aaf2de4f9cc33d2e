"""AdminPanel: the operator's controls on the left of the live console (thesis fig. 5.5).

Top to bottom: the connection to the manager (in red when it is lost), the
run (state, clock, arrivals), the run buttons, the strategy, reroute mode
(off, propose, auto) and position source selectors, the manager's last answer, and the robot list: id in the
robot's colour, link, pose source and age, an enabled box, the current
action, whom it waits for. Greyed robots stay in the list, greyed, with why.

Every control only asks (`on_action(action, args)`, which sends a request);
what the panel shows comes from the manager's state, so a box ticked here
shows the manager's view as soon as it answers, and a refused request
changes nothing but the answer line. A run button the manager would refuse
now (the State's `allowed`) is greyed, and the pointer resting on it shows
why in a note below it (`HoverTip`; the State's `why_not`, the sentence the
manager would answer with): a note by the pointer is where the operator is
looking, and it leaves the answer line to the manager's answers, so that a
reason read while hovering never passes for an answer to a request. Pressed
all the same, a greyed button asks, and the answer line says it too (a
manager of old says why only then). The answer line is cleared when the run
moves on to another phase, so an old refusal never reads as a new one.
"""
from __future__ import annotations

import tkinter as tk
from dataclasses import dataclass
from tkinter import ttk
from typing import Any, Callable, Dict, List, Optional, Sequence

from fleet_common.control import RUN_ACTIONS, RunInfo
from fleet_common.execution.reroute import MODES as REROUTE_MODES, SCOPES as REROUTE_SCOPES

from ..live.describe import RobotRow
from ..live.feed import CONNECTED, LOST, LinkStatus, Reply
from ..live.model import reply_text
from .hover_tip import HoverTip
from .table import scrolled_table

Action = Callable[..., None]

ENABLED, DISABLED = "\u2611", "\u2610"
FONT = ("DejaVu Sans", -12)
BOLD = ("DejaVu Sans", -13, "bold")
#: Wide enough for what they say: "drive to (12, 10) (#19)", "2, 7 (cell)"
COLUMNS = (("link", "link", 40), ("pose", "pose", 84), ("on", "on", 28), ("action", "action", 150),
           ("waits", "waits for", 84))


@dataclass(frozen=True)
class RunControl:
    """One of the run's controls: a request `action` (of `fleet_common.control.ACTIONS`) without
    arguments, its button's `label`, and its entry in the Run menu (None: only a button)."""

    action: str
    label: str
    menu: Optional[str]


#: The run's controls, in the order of the buttons (four a row) and of the Run menu.
RUN_CONTROLS = (
    RunControl("start", "Start", "Start"), RunControl("pause", "Pause", "Pause"),
    RunControl("step", "Step", "Step"), RunControl("stop", "Stop", "Stop"),
    RunControl("halt", "Halt", "Halt every robot"), RunControl("replan", "Replan", "Replan"),
    RunControl("accept", "Accept", None), RunControl("reject", "Reject", None),
    RunControl("to_starts", "To starts", "Go to starts: every robot drives to its start"),
    RunControl("reset", "Reset", "Reset: the run again, robots back to their starts first"),
)
BUTTONS_A_ROW = 4


def usable(action: str, run: Optional[RunInfo], connected: bool) -> bool:
    """Whether the control of `action` may be pressed: connected, and the manager would do it
    (accept and reject: a proposal waits)."""
    if not connected or run is None:
        return False
    if action in ("accept", "reject"):
        return run.proposal is not None
    return run.allowed is None or action not in RUN_ACTIONS or action in run.allowed


def why_greyed(action: str, run: Optional[RunInfo], connected: bool) -> str:
    """Why the control of `action` is greyed, in a line ("" when it may be pressed)."""
    if usable(action, run, connected):
        return ""
    if not connected:
        return "not connected to the manager"
    if run is None:
        return "no state from the manager yet"
    if action in ("accept", "reject"):
        return "no proposal to answer"
    why = (run.why_not or {}).get(action)
    return why or "the manager would refuse it now (press it to ask why)"


class AdminPanel(ttk.Frame):
    def __init__(self, master: tk.Misc, on_action: Action, on_pick: Callable[[Optional[int]], None]) -> None:
        super().__init__(master, padding=(6, 4))
        self.on_action = on_action
        self.on_pick = on_pick
        self.connection = ttk.Label(self, font=BOLD, wraplength=330, justify=tk.LEFT)
        self.connection.pack(anchor=tk.W, fill=tk.X)
        self.run = ttk.Label(self, font=FONT, wraplength=330, justify=tk.LEFT)
        self.run.pack(anchor=tk.W, fill=tk.X, pady=(2, 4))
        self.buttons: Dict[str, ttk.Button] = {}
        for first in range(0, len(RUN_CONTROLS), BUTTONS_A_ROW):
            bar = ttk.Frame(self)
            bar.pack(fill=tk.X)
            for control in RUN_CONTROLS[first:first + BUTTONS_A_ROW]:
                b = ttk.Button(bar, text=control.label, width=7, takefocus=0,
                               command=lambda a=control.action: self._button(a))
                b.pack(side=tk.LEFT, padx=1, pady=1)
                # before the button's own binding, while its state is the one clicked on
                b.bind("<ButtonRelease-1>", lambda e, a=control.action: self._greyed(a, e))
                self.buttons[control.action] = b
        self._proposal: Optional[int] = None
        self._connected = False
        self._run: Optional[RunInfo] = None  # what the buttons were greyed for
        self.tips = {action: HoverTip(b, lambda a=action: why_greyed(a, self._run, self._connected))
                     for action, b in self.buttons.items()}
        self._answered: Optional[tuple] = None  # the run's phase when the answer shown came
        for button in self.buttons.values():
            button.state(["disabled"])  # until a manager says what it would do
        self._build_selectors()
        self.answer = ttk.Label(self, font=FONT, wraplength=330, justify=tk.LEFT)
        self.answer.pack(anchor=tk.W, fill=tk.X, pady=(4, 4))
        self._rows: Dict[int, RobotRow] = {}     # what each row shows
        self._row_of: Optional[Callable[[int], RobotRow]] = None  # what a row should show
        self._order: List[int] = []              # robot ids, top row first
        self._writing = False
        self._build_list()

    # -- building ----------------------------------------------------------------------

    def _build_selectors(self) -> None:
        box = ttk.Frame(self)
        box.pack(fill=tk.X, pady=(6, 0))
        ttk.Label(box, text="strategy").grid(row=0, column=0, sticky=tk.W)
        self.strategy = tk.StringVar(self)
        self.strategy_box = ttk.Combobox(box, textvariable=self.strategy, state="readonly", width=8,
                                         takefocus=0)
        self.strategy_box.grid(row=0, column=1, sticky=tk.W, padx=4)
        self.strategy_box.bind("<<ComboboxSelected>>", lambda e: self._strategy())
        ttk.Label(box, text="lookahead").grid(row=0, column=2, sticky=tk.W)
        self.lookahead = tk.StringVar(self, value="1")
        spin = ttk.Spinbox(box, from_=1, to=20, width=3, textvariable=self.lookahead, takefocus=0,
                           command=self._strategy)
        spin.grid(row=0, column=3, sticky=tk.W, padx=4)
        ttk.Label(box, text="reroute").grid(row=1, column=0, sticky=tk.W, pady=(4, 0))
        self.reroute = tk.StringVar(self, value="off")
        self.reroute_box = ttk.Combobox(box, textvariable=self.reroute, state="readonly", width=8,
                                        takefocus=0, values=list(REROUTE_MODES))
        self.reroute_box.grid(row=1, column=1, sticky=tk.W, padx=4, pady=(4, 0))
        self.reroute_box.bind("<<ComboboxSelected>>", lambda e: self._reroute())
        ttk.Label(box, text="scope").grid(row=1, column=2, sticky=tk.W, pady=(4, 0))
        self.scope = tk.StringVar(self, value="held")  # whom a reroute may give new paths
        self.scope_box = ttk.Combobox(box, textvariable=self.scope, state="readonly", width=5,
                                      takefocus=0, values=list(REROUTE_SCOPES))
        self.scope_box.grid(row=1, column=3, sticky=tk.W, padx=4, pady=(4, 0))
        self.scope_box.bind("<<ComboboxSelected>>", lambda e: self._scope())
        # the plan waiting for Start, plans loaded from then on and the held scope's reroutes' plans
        # trimmed of moves that bring nobody in sooner (scope all trims its own always)
        self.trim = tk.BooleanVar(self, value=False)
        ttk.Checkbutton(box, text="trim", variable=self.trim, takefocus=0, command=self._trim).grid(
            row=1, column=4, sticky=tk.W, pady=(4, 0))
        row = 2
        ttk.Label(box, text="positions").grid(row=row, column=0, sticky=tk.W, pady=(4, 0))
        self.source = tk.StringVar(self, value="robot")
        for k, (text, value) in enumerate((("Robot", "robot"), ("Vicon", "vicon"))):
            ttk.Radiobutton(box, text=text, value=value, variable=self.source, takefocus=0,
                            command=lambda: self.on_action("source", source=self.source.get())).grid(
                row=row, column=1 + k, sticky=tk.W, pady=(4, 0))

    def _build_list(self) -> None:
        ttk.Label(self, text="Robots (click the box to enable / disable)", font=FONT).pack(anchor=tk.W)
        self.tree = scrolled_table(self, COLUMNS, "Robots.Treeview", FONT, 20, 8, "action", tree_column="id",
                                   on_scroll=self._write_visible)
        self.tree.column("#0", width=50, stretch=False)
        self.tree.column("on", anchor=tk.CENTER)
        self.tree.tag_configure("grey", foreground="#8a8a86")
        self.tree.tag_configure("late", background="#fff2b8")
        self.tree.tag_configure("waiting", background="#ffe1e1")
        self.tree.bind("<ButtonRelease-1>", self._clicked)
        self._swatches: List[tk.PhotoImage] = []

    def set_fleet(self, robot_ids: Sequence[int], colours: Sequence[str], strategies: Sequence[str]) -> None:
        """A new scene: one row per robot, a swatch of its colour beside its id."""
        self.tree.delete(*self.tree.get_children())
        self._rows = {}
        self._order = list(robot_ids)
        self._row_of = None
        self._swatches = []
        for rid, colour in zip(robot_ids, colours):
            swatch = tk.PhotoImage(master=self, width=12, height=12)
            swatch.put(colour, to=(0, 0, 12, 12))
            self._swatches.append(swatch)
            self.tree.insert("", tk.END, iid=str(rid), text=" {}".format(rid), image=swatch)
        self.strategy_box.configure(values=list(strategies))

    # -- showing -----------------------------------------------------------------------

    def show_connection(self, connection: LinkStatus) -> None:
        colour = {CONNECTED: "#1d6b22", LOST: "#c8101a"}.get(connection.status, "#8a5a00")
        text = "MANAGER LOST: " + connection.text if connection.status == LOST else connection.text
        self.connection.configure(text=text, foreground=colour)
        self._connected = connection.status == CONNECTED
        if not self._connected:
            self.grey(None)

    def show_run(self, run: Optional[RunInfo]) -> None:
        if run is None:
            self.run.configure(text="no run yet")
            return
        parts = ["run {}{}".format(run.state, ": " + run.reason if run.reason else ""),
                 "clock {:.1f} s, plan step {:.1f}".format(run.clock, run.run_steps),
                 "arrived {} of {}, collisions {}, closest {}".format(
                     run.arrived, run.robots, run.collisions,
                     "-" if run.min_distance is None else "{:.2f} cells".format(run.min_distance))]
        if run.replanning:
            parts.append("replanning...")
        self.run.configure(text="\n".join(parts))
        self.grey(run)
        phase = (run.state, run.purpose, run.plan_id)
        if self._answered is not None and phase != self._answered:
            self.show_reply(None)  # the run moved on: that answer is history (the event list keeps it)
        self._writing = True
        try:
            if self.strategy.get() != run.strategy:
                self.strategy.set(run.strategy)
            if self.reroute.get() != run.reroute:
                self.reroute.set(run.reroute)
            if self.scope.get() != run.reroute_scope:
                self.scope.set(run.reroute_scope)
            if self.trim.get() != run.trim:
                self.trim.set(run.trim)
            # Tk's own name of the focus: focus_get() raises KeyError while a menu or a drop-down
            # list has the focus (Tk's clones of them are no tkinter widgets), which froze this panel
            if not str(self.tk.call("focus")).endswith("spinbox"):
                self.lookahead.set(str(run.lookahead))
        finally:
            self._writing = False

    def grey(self, run: Optional[RunInfo]) -> None:
        """Grey the run buttons the manager would refuse now (all of them without a manager), a
        note saying why shown on the one the pointer rests on; Accept and Reject answer the
        proposal that made them usable."""
        self._proposal = None if run is None else run.proposal
        self._run = run
        for action, button in self.buttons.items():
            button.state(["!disabled"] if usable(action, run, self._connected) else ["disabled"])
            self.tips[action].refresh()

    def show_rows(self, row_of: Callable[[int], RobotRow]) -> None:
        """Rows from `row_of(robot id)`: only those in view are made and written if they changed
        (300 rows a refresh would cost more than the map); the others when they scroll in."""
        self._row_of = row_of
        self._write_visible()

    def _write_visible(self) -> None:
        ids = self._order
        if not ids:
            return
        top, bottom = self.tree.yview()
        first = max(0, int(top * len(ids)) - 2)
        last = min(len(ids), int(bottom * len(ids) + 0.999) + 2)
        for rid in ids[first:last]:
            r = self._row_of(rid) if self._row_of is not None else None
            if r is None or self._rows.get(rid) == r:
                continue
            self._rows[rid] = r
            tags = ("grey",) if r.grey else ("waiting",) if r.blocked else ("late",) if r.behind else ()
            self.tree.item(str(rid), tags=tags, values=(
                r.link, r.grey if r.grey else r.pose, ENABLED if r.enabled else DISABLED, r.action, r.waiting))

    def show_source(self, source: str) -> None:
        if self.source.get() != source:
            self.source.set(source)

    def show_reply(self, reply: Optional[Reply], run: Optional[RunInfo] = None) -> None:
        """The manager's answer to this console's last request (None: clear the line)."""
        if reply is None:
            self._answered = None
            self.answer.configure(text="")
            return
        # a refusal holds while the run stays in the phase it was refused in
        self._answered = None if run is None or reply.ok else (run.state, run.purpose, run.plan_id)
        self.answer.configure(text="manager: " + reply_text(reply) if reply.sent else reply_text(reply),
                              foreground="#1d6b22" if reply.ok else "#c8101a")

    def mark(self, robot_id: Optional[int]) -> None:
        """Show `robot_id` as the selected row (no callback)."""
        if robot_id is None or not self.tree.exists(str(robot_id)):
            self.tree.selection_set(())
            return
        self.tree.selection_set((str(robot_id),))
        self.tree.see(str(robot_id))

    # -- asking ------------------------------------------------------------------------

    def _button(self, action: str) -> None:
        if action in ("accept", "reject"):
            if self._proposal is not None:
                self.on_action(action, proposal=self._proposal)
            return
        self.on_action(action)

    def _greyed(self, action: str, event: Any) -> None:
        """A greyed run button pressed (released over it): asked all the same, for the manager's
        answer saying why it will not (a greyed button's own binding does nothing)."""
        button = self.buttons[action]
        over = 0 <= event.x < button.winfo_width() and 0 <= event.y < button.winfo_height()
        if over and action in RUN_ACTIONS and self._connected and button.instate(["disabled"]):
            self.on_action(action)

    def _strategy(self) -> None:
        if self._writing or not self.strategy.get():
            return
        args: Dict[str, Any] = {"name": self.strategy.get()}
        if self.strategy.get() == "adg":
            try:
                args["lookahead"] = max(1, int(self.lookahead.get()))
            except ValueError:
                pass
        self.on_action("strategy", **args)

    def _reroute(self) -> None:
        if not self._writing and self.reroute.get():
            self.on_action("reroute", mode=self.reroute.get())

    def _scope(self) -> None:
        # the scope alone: the mode box may show a State older than the operator's last pick
        if not self._writing and self.scope.get():
            self.on_action("reroute", scope=self.scope.get())

    def _trim(self) -> None:
        if not self._writing:
            self.on_action("reroute", trim=bool(self.trim.get()))

    def _clicked(self, event: "tk.Event[ttk.Treeview]") -> None:
        iid = self.tree.identify_row(event.y)
        if not iid:
            return
        rid = int(iid)
        if self.tree.identify_column(event.x) == "#3":  # the enabled box
            row = self._rows.get(rid)
            self.on_action("disable" if row is None or row.enabled else "enable", robot=rid)
        self.on_pick(rid)
