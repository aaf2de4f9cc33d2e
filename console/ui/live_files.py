"""The live console's File menu: open a plan or an instance for the fleet, solve it, save the report.

A mixin of `LiveApp` (written against `window.LiveWindow`), as `FileActions`
is of the player, whose `open_path`, `solve` and dialogs it replaces here:

- a plan (a mapf-IR solution) is read in the background, checked against the
  fleet the manager runs (`live.fit`: the same map, one agent per robot, which
  robot takes which agent) and sent to the manager as its content (`load`
  with the file's text: the manager never opens a path of this machine); the
  manager checks it again and answers in the panel;
- an instance is read and checked the same way and kept; File -> Solve with
  plans it with a built-in solver in the background (the status line counts
  the seconds; File -> Cancel solving stops it), and the plan found is sent;
- File -> Open recent offers the last files opened (`console.recent`);
- File -> Save the run's report writes what this console saw as HTML
  (`live.report`) with the window's picture beside it.

Reading and solving never block the window: they are `Jobs`, whose results
come back on Tk's thread.
"""
from __future__ import annotations

import threading
import time
import tkinter as tk
from dataclasses import dataclass
from pathlib import Path
from tkinter import filedialog
from typing import Any, Optional

from fleet_common.formats.header import read_text
from fleet_common.formats.instance import Instance
from fleet_common.formats.mapsearch import default_map_dirs
from fleet_common.formats.problem_file import read_problem
from fleet_common.formats.solution import format_solution, make_solution
from fleet_common.planning import SOLVER_NAMES, solve
from fleet_common.planning.deadline import Deadline

from ..live.fit import fit
from ..live.model import ERROR, INFO
from ..live.report import report_html
from ..scene import INSTANCE, SOLUTION
from . import capture
from .file_actions import OPENERS, SOLVE_SECONDS
from .window import LiveWindow

__all__ = ["LiveFiles", "Opened", "Solving"]


@dataclass
class Opened:
    """A file read for the fleet: its name, what it holds, its text."""

    name: str
    problem: Any   # an Instance or a Solution
    text: str


@dataclass
class Solving:
    """The solve under way: what, since when, and how to stop it."""

    what: str
    since: float
    cancelled: threading.Event


class LiveFiles:
    # ---- opening ------------------------------------------------------------------------

    def do_open_plan(self: "LiveWindow") -> None:
        self._open_dialog(SOLUTION)

    def do_open_instance(self: "LiveWindow") -> None:
        self._open_dialog(INSTANCE)

    def _open_dialog(self: "LiveWindow", kind: str) -> None:
        what, pattern, _ = OPENERS[kind]
        path = filedialog.askopenfilename(parent=self.root, title="Open a " + what + " for the fleet",
                                          filetypes=[(what, pattern), ("all files", "*")])
        if path:
            self.open_path(kind, Path(path))

    def open_path(self: "LiveWindow", kind: str, path: Path) -> bool:
        """Read `path` (a plan or an instance) in the background, then check it against the fleet
        and send it (a plan) or keep it for solving (an instance); False if busy."""
        def work() -> Opened:
            text = read_text(str(path))
            return Opened(path.name, read_problem(path, default_map_dirs(), text), text)

        self.recent.add("instance" if kind == INSTANCE else "plan", path)
        self._fill_recent()
        return self._background("reading {}".format(path.name), work)

    def _opened(self: "LiveWindow", opened: Opened) -> None:
        setup = self.model.setup
        problem = opened.problem
        if setup is None or not self.model.connected:
            self.say("{}: not sent: no manager connected (its fleet decides what fits)".format(opened.name), ERROR)
            return
        fits = fit(opened.name, problem.grid, len(problem.starts), setup)
        if not fits.ok:
            self.say("{} does not fit the fleet: {}".format(opened.name, fits.reason), ERROR)
            return
        if isinstance(problem, Instance):
            self.instance = opened
            self.solve_menu_state(tk.NORMAL)
            self.say("instance {} fits the fleet ({}); solve it: File -> Solve with".format(
                opened.name, fits.reason))
            return
        if not problem.solved or problem.plan is None:
            self.say("{}: no plan in it (its solver did not solve the instance): open the instance and "
                     "solve it here".format(opened.name), ERROR)
            return
        self._send_plan(opened.name, opened.text, fits.reason)

    def _send_plan(self: "LiveWindow", name: str, text: str, fits: str) -> None:
        self.ask("load", text=text, name=name)
        self.say("sent {} to the manager ({})".format(name, fits))

    # ---- solving ------------------------------------------------------------------------

    def solve(self: "LiveWindow", solver: str) -> bool:
        """Plan the instance opened last with built-in `solver` in the background, then send it."""
        opened = self.instance
        if opened is None:
            self.say("open an instance first (File -> Open an instance)", ERROR)
            return False
        inst: Instance = opened.problem
        cancelled = threading.Event()

        def clock() -> float:  # a cancelled solve sees its deadline passed at once
            return time.monotonic() + (1e9 if cancelled.is_set() else 0.0)

        def work() -> Any:
            result = solve(solver, inst.grid, inst.starts, inst.goals, deadline=Deadline(SOLVE_SECONDS, clock))
            if cancelled.is_set():
                return "cancelled"
            if result.plan is None:
                return result
            sol = make_solution(inst.grid, inst.map_file or "", result.plan, inst.starts, inst.goals,
                                result.solver, True, round(result.comp_time_ms), instance=opened.name)
            sol.orientation = inst.orientation
            return (solver, sol, format_solution(sol), result.comp_time_ms)

        what = "solving {} with {}".format(opened.name, solver)
        if not self._background(what, work):
            return False
        self.solving = Solving(what, time.monotonic(), cancelled)
        self.cancel_menu_state(tk.NORMAL)
        return True

    def cancel_solving(self: "LiveWindow") -> None:
        if self.solving is not None:
            self.solving.cancelled.set()
            self.status.set("{}: cancelling ...".format(self.solving.what))

    def solving_progress(self: "LiveWindow") -> None:
        """The status line while a solve runs (called by the frame loop)."""
        if self.solving is not None:
            self.status.set("{}: {:.1f} s (up to {:g} s); File -> Cancel solving stops it".format(
                self.solving.what, time.monotonic() - self.solving.since, SOLVE_SECONDS))

    def _solved(self: "LiveWindow", result: Any) -> None:
        opened = self.instance
        self.solving = None
        self.cancel_menu_state(tk.DISABLED)
        if result == "cancelled":
            self.say("solving cancelled")
            return
        if not isinstance(result, tuple):
            self.say("no plan: {}".format(result.summary()), ERROR)
            return
        solver, sol, text, ms = result
        self.solved = sol
        name = "{} solved by {}".format(opened.name if opened else "instance", solver)
        self.say("{} found a plan in {:.0f} ms (soc {}, makespan {})".format(solver, ms, sol.plan.soc,
                                                                             sol.plan.makespan))
        setup = self.model.setup
        fits = fit(name, sol.grid, len(sol.starts), setup) if setup is not None else None
        if fits is None or not fits.ok:
            self.say("{}: not sent: {}".format(name, "no manager connected" if fits is None else fits.reason), ERROR)
            return
        self._send_plan(name, text, fits.reason)

    # ---- the jobs' results --------------------------------------------------------------

    def _finished(self: "LiveWindow", result: Any, error: Optional[BaseException]) -> None:
        if error is not None:
            self.solving = None
            self.cancel_menu_state(tk.DISABLED)
            self.say("error: {}".format(error), ERROR)
        elif isinstance(result, Opened):
            self._opened(result)
        else:
            self._solved(result)

    # ---- the menus ----------------------------------------------------------------------

    def add_file_menu(self: "LiveWindow", bar: tk.Menu) -> tk.Menu:
        file = tk.Menu(bar, tearoff=False)
        file.add_command(label="Open a plan for the fleet ...", accelerator="Ctrl+O",
                         command=self._guarded(self.do_open_plan))
        file.add_command(label="Open an instance for the fleet ...", command=self._guarded(self.do_open_instance))
        self.recent_menu = tk.Menu(file, tearoff=False)
        file.add_cascade(label="Open recent", menu=self.recent_menu)
        self.solve_menu = tk.Menu(file, tearoff=False)
        for name in SOLVER_NAMES:
            self.solve_menu.add_command(label=name, command=self._guarded(lambda n=name: self.solve(n)))
        file.add_cascade(label="Solve the instance with", menu=self.solve_menu,
                         state=tk.NORMAL if self.instance is not None else tk.DISABLED)
        file.add_command(label="Cancel solving", command=self._guarded(self.cancel_solving), state=tk.DISABLED)
        file.add_separator()
        file.add_command(label="Save the run's report ...", command=self._guarded(self._save_report))
        file.add_command(label="save the view as PNG", accelerator="Ctrl+S", command=self.actions["save_png"])
        file.add_command(label="save the window as PNG", command=self._guarded(self._save_window))
        file.add_separator()
        file.add_command(label="quit", accelerator="q, Ctrl+Q", command=self.actions["quit"])
        self.file_menu = file
        self._fill_recent()
        return file

    def _fill_recent(self: "LiveWindow") -> None:
        menu = getattr(self, "recent_menu", None)
        if menu is None:
            return
        menu.delete(0, tk.END)
        for kind, path in self.recent.entries:
            menu.add_command(label="{} ({})".format(path.name, kind), command=self._guarded(
                lambda k=kind, p=path: self.open_path(INSTANCE if k == "instance" else SOLUTION, p)))
        if not self.recent.entries:
            menu.add_command(label="(none yet)", state=tk.DISABLED)

    def solve_menu_state(self: "LiveWindow", state: str) -> None:
        self.file_menu.entryconfigure("Solve the instance with", state=state)

    def cancel_menu_state(self: "LiveWindow", state: str) -> None:
        self.file_menu.entryconfigure("Cancel solving", state=state)

    # ---- the report ---------------------------------------------------------------------

    def save_report(self: "LiveWindow", path: Path) -> None:
        """The run's report as this console saw it: `path` (HTML) and its picture beside it."""
        picture = path.with_suffix(".png")
        try:
            capture.grab(self.root, picture)
        except Exception as err:  # no picture (the window is off the screen): the words stand
            self.say("report: no picture ({})".format(err), ERROR)
            picture = None  # type: ignore[assignment]
        path.write_text(report_html(self.model, picture.name if picture else None), encoding="utf-8")
        self.say("saved the run's report: {}".format(path))

    def _save_report(self: "LiveWindow") -> None:
        path = filedialog.asksaveasfilename(parent=self.root, defaultextension=".html",
                                            filetypes=[("HTML", "*.html")], title="Save the run's report")
        if path:
            self.root.after(200, self._guarded(lambda: self.save_report(Path(path))))

    def say(self: "LiveWindow", text: str, level: str = INFO) -> None:
        """A line of the console's own, in the event list and the status line."""
        self.model.say(text, level)
        self.status.set(text)

