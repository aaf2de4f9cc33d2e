"""The File menu's work: open a plan, an instance or a map; solve the instance shown.

A mixin of `PlayerApp`, like `PlayerActions` (written against `window.PlayerWindow`). Reading (a big plan is also
validated) and solving (thesis ch. 7: in-app planning with the built-in
solvers) run as background `Jobs`; the window keeps playing and answering
keys meanwhile, and the result comes back on the Tk thread, where
`open_scene` shows it (or the status line says why not). The file dialog is
the only part that needs a person; `open_path` and `solve` are what it and
the Solve menu call.
"""
from __future__ import annotations

import logging
import tkinter as tk
from pathlib import Path
from tkinter import filedialog
from typing import Any, Callable, Dict, Optional, Tuple

from fleet_common.formats.solution import make_solution
from fleet_common.planning import SOLVER_NAMES, SolveResult, solve

from ..scene import INSTANCE, MAP, SOLUTION, Scene, scene_from_instance, scene_from_map, scene_from_plan, \
    scene_from_solution
from .window import PlayerWindow

log = logging.getLogger(__name__)

#: Time limit of a solve started from the console (seconds).
SOLVE_SECONDS = 30.0

#: Per kind of file: what the dialog calls it, its usual names, and its reader.
OPENERS: Dict[str, Tuple[str, str, Callable[[Path], Scene]]] = {
    SOLUTION: ("plan (mapf-IR solution)", "*.txt", scene_from_solution),
    INSTANCE: ("instance (mapf-IR problem)", "*.txt", scene_from_instance),
    MAP: ("map", "*.map", scene_from_map),
}


class FileActions:
    def do_open_plan(self: "PlayerWindow") -> None:
        self._ask_for_file(SOLUTION)

    def do_open_instance(self: "PlayerWindow") -> None:
        self._ask_for_file(INSTANCE)

    def do_open_map(self: "PlayerWindow") -> None:
        self._ask_for_file(MAP)

    def _ask_for_file(self: "PlayerWindow", kind: str) -> None:
        what, pattern, _ = OPENERS[kind]
        path = filedialog.askopenfilename(parent=self.root, title="Open a " + what,
                                          filetypes=[(what, pattern), ("all files", "*")])
        if path:
            self.open_path(kind, Path(path))

    def open_path(self: "PlayerWindow", kind: str, path: Path) -> bool:
        """Read `path` (a SOLUTION, INSTANCE or MAP) in the background, then show it; False if busy."""
        reader = OPENERS[kind][2]
        return self._background("reading {}".format(path.name), lambda: reader(path))

    def solve(self: "PlayerWindow", solver: str) -> bool:
        """Plan the instance shown with built-in `solver` in the background, then play the plan."""
        scene = self.scene
        if scene.kind != INSTANCE:
            self.status.set("open an instance to solve (File menu)")
            return False

        def work() -> Any:
            result = solve(solver, scene.grid, scene.starts, scene.goals, deadline=SOLVE_SECONDS)
            if result.plan is None:
                return result
            plan = result.plan
            sol = make_solution(scene.grid, scene.map_file, plan, scene.starts, scene.goals, result.solver, True,
                                round(result.comp_time_ms), instance=scene.title)
            sol.orientation = scene.file_orientation
            solved = scene_from_plan(scene.grid, plan, scene.goals, title="{} ({})".format(scene.title, solver),
                                     info=["solver {} (built in)".format(solver), "solved", "soc {}".format(plan.soc),
                                           "makespan {}".format(plan.makespan),
                                           "comp_time {:.0f} ms".format(result.comp_time_ms),
                                           "{} agents".format(plan.num_agents), scene.title])
            solved.file_orientation = scene.file_orientation
            solved.map_file, solved.solution = scene.map_file, sol
            return solved

        return self._background("solving {} with {} (up to {:g} s)".format(scene.title, solver, SOLVE_SECONDS), work)

    def _background(self: "PlayerWindow", what: str, work: Callable[[], Any]) -> bool:
        if not self.jobs.start(what, work, self._finished):
            self.status.set("busy {}: wait until it is done".format(self.jobs.running))
            return False
        self.status.set(what + " ...")
        return True

    def _finished(self: "PlayerWindow", result: Any, error: Optional[BaseException]) -> None:
        if error is not None:
            log.error("background job failed", exc_info=error)
            self.status.set("error: {}".format(error))
        elif isinstance(result, SolveResult):
            self.status.set(result.summary())
        else:
            self.open_scene(result)
            self.status.set("opened {}{}".format(result.title, "; File -> save the plan keeps it"
                                                 if result.solution is not None else ""))

    def _add_solve_menu(self: "PlayerWindow", menu: tk.Menu) -> None:
        """"Solve this instance with" after the Open entries, usable while an instance is shown."""
        sub = tk.Menu(menu, tearoff=False)
        for name in SOLVER_NAMES:
            sub.add_command(label=name, command=self._guarded(lambda n=name: self.solve(n)))
        index = sum(1 for k in OPENERS)
        menu.insert_cascade(index, label="Solve this instance with", menu=sub,
                            state=tk.NORMAL if self.scene.kind == INSTANCE else tk.DISABLED)
        self.solve_menu = sub
