"""The player's actions: picking from the lists and the canvas, and one method
`do_<action>` per entry of `console.keys.KEYS`.

A mixin of `PlayerApp` so that the key table, the menus and the tests reach
every action by name (`app.actions["step_forward"]()`); the window provides the
clock, the options, the map view and the lists (`window.PlayerWindow` lists what
the actions use of it).
"""
from __future__ import annotations

import math
from tkinter import filedialog, simpledialog
from typing import Callable, Optional, Tuple

from ..conflicts import next_entry
from ..sources import PlanClock
from ..view_options import LINE_LABELS
from . import capture
from .help_window import show_keys
from .map_view import PAN_STEP, ZOOM_STEP
from .overlays import MIN_ID_CELL
from .window import PlayerWindow

SPEED_STEP = math.sqrt(2.0)


class PlayerActions:
    # -- picking: the lists and the mouse ---------------------------------------------

    def select(self: "PlayerWindow", agent: Optional[int]) -> None:
        self.options.selected = agent
        self.agent_list.mark(agent)
        self.relayout()
        if agent is not None:
            s = self.scene
            self.status.set("{}: start {}, goal {}".format(
                s.names[agent], self._place(s.starts[agent]), self._place(s.goals[agent])))

    def _place(self: "PlayerWindow", cell: Tuple[int, int]) -> str:
        """A cell as the view shows it, with its floor-marker node on the lab map."""
        node = self.scene.node_ids.get((int(cell[0]), int(cell[1])))
        return "{}{}".format(self.shown_cell(cell), "" if node is None else " node {}".format(node))

    def jump_to_conflict(self: "PlayerWindow", index: int) -> None:
        entry = self.entries[index]
        self.conflict_list.mark(index)
        self.conflicts.pick(entry)
        if entry.jump_time is not None and self.clock is not None:
            self.clock.pause()
            self.clock.seek(entry.jump_time)
        if entry.cell is not None and not self.map.view.shows(*entry.cell):
            self.map.view.centre_on(*entry.cell)
            self.map.changed()
        self.select(entry.agents[0] if entry.agents else None)
        self.status.set("{}: {}".format(entry.finding.kind, entry.label(
            self.scene.grid.height, self.options.orientation, self.scene.file_orientation)))
        self._clock_changed()

    def _pick_agent(self: "PlayerWindow", index: Optional[int]) -> None:
        self.select(index)

    def _pick_conflict(self: "PlayerWindow", index: Optional[int]) -> None:
        if index is not None:
            self.jump_to_conflict(index)

    def _clicked(self: "PlayerWindow", px: float, py: float) -> None:
        agent = self.agents.agent_at(px, py)
        if agent is not None:
            self.select(None if agent == self.options.selected else agent)
        else:
            self._hovered(px, py)

    def _hovered(self: "PlayerWindow", px: float, py: float) -> None:
        x, y = self.map.view.to_cell(px, py)
        grid = self.scene.grid
        if not grid.in_bounds((x, y)):
            return
        sx, sy = self.shown_cell((x, y))
        text = "cell ({}, {})  id {}  {}".format(sx, sy, sy * grid.width + sx,
                                                  "free" if grid.is_free((x, y)) else "blocked")
        node = self.scene.node_ids.get((x, y))
        if node is not None:
            text += "  node {}".format(node)
        agent = self.agents.agent_at(px, py)
        if agent is not None:
            text += "   {}".format(self.scene.names[agent])
        self.status.set(text)

    # -- keys and menus ------------------------------------------------------------------

    def _with_clock(self: "PlayerWindow", fn: Callable[[PlanClock], None]) -> None:
        if self.clock is not None:
            fn(self.clock)
            self._clock_changed()

    def do_play_pause(self: "PlayerWindow") -> None:
        self._with_clock(lambda c: c.toggle())

    def do_loop(self: "PlayerWindow") -> None:
        self._with_clock(lambda c: setattr(c, "loop", not c.loop))

    def do_reset(self: "PlayerWindow") -> None:
        self._with_clock(lambda c: c.reset())

    def do_step_forward(self: "PlayerWindow") -> None:
        self._with_clock(lambda c: c.step(1))

    def do_step_back(self: "PlayerWindow") -> None:
        self._with_clock(lambda c: c.step(-1))

    def do_first(self: "PlayerWindow") -> None:
        self._with_clock(lambda c: (c.pause(), c.seek(0)))

    def do_last(self: "PlayerWindow") -> None:
        self._with_clock(lambda c: (c.pause(), c.seek(c.makespan)))

    def do_faster(self: "PlayerWindow") -> None:
        self._with_clock(lambda c: setattr(c, "speed", c.speed * SPEED_STEP))

    def do_slower(self: "PlayerWindow") -> None:
        self._with_clock(lambda c: setattr(c, "speed", c.speed / SPEED_STEP))

    def do_goals(self: "PlayerWindow") -> None:
        self.options.goals = not self.options.goals
        self.relayout()

    def do_lines(self: "PlayerWindow") -> None:
        self.options.cycle_lines()
        self.relayout()
        self.status.set(LINE_LABELS[self.options.lines])

    def do_ids(self: "PlayerWindow") -> None:
        self.options.ids = not self.options.ids
        self.relayout()
        if self.options.ids and self.map.view.cell < MIN_ID_CELL:
            self.status.set("cell ids show when cells are {:g} px or more: zoom in (i)".format(MIN_ID_CELL))

    def do_node_ids(self: "PlayerWindow") -> None:
        if not self.scene.node_ids:
            self.status.set("node ids: only the lab map has floor markers")
            return
        self.options.node_ids = not self.options.node_ids
        self.relayout()
        if self.options.node_ids and self.map.view.cell < MIN_ID_CELL:
            self.status.set("node ids show when cells are {:g} px or more: zoom in (i)".format(MIN_ID_CELL))

    def do_grid(self: "PlayerWindow") -> None:
        self.options.grid_lines = not self.options.grid_lines
        self.map.set_grid_lines(self.options.grid_lines)

    def do_orientation(self: "PlayerWindow") -> None:
        self.options.toggle_orientation()
        if self._mirrored() != self.map.view.down:
            self.map.set_mirrored(self._mirrored())  # relayouts through on_view_change
        else:
            self.relayout()
        self._fill_conflicts()
        self._status_changed()

    def do_zoom_in(self: "PlayerWindow") -> None:
        self.map.zoom(ZOOM_STEP)

    def do_zoom_out(self: "PlayerWindow") -> None:
        self.map.zoom(1 / ZOOM_STEP)

    def do_fit(self: "PlayerWindow") -> None:
        self.map.fit()

    def do_pan_left(self: "PlayerWindow") -> None:
        self.map.pan(PAN_STEP, 0)

    def do_pan_right(self: "PlayerWindow") -> None:
        self.map.pan(-PAN_STEP, 0)

    def do_pan_up(self: "PlayerWindow") -> None:
        self.map.pan(0, PAN_STEP)

    def do_pan_down(self: "PlayerWindow") -> None:
        self.map.pan(0, -PAN_STEP)

    def do_next_agent(self: "PlayerWindow") -> None:
        self.options.select_next(self.scene.num_agents, 1)
        self.select(self.options.selected)

    def do_prev_agent(self: "PlayerWindow") -> None:
        self.options.select_next(self.scene.num_agents, -1)
        self.select(self.options.selected)

    def do_only_selected(self: "PlayerWindow") -> None:
        if self.options.selected is None and self.scene.num_agents:
            self.options.selected = 0
        self.options.only_selected = not self.options.only_selected
        self.select(self.options.selected)

    def do_clear_selection(self: "PlayerWindow") -> None:
        self.options.only_selected = False
        self.select(None)

    def do_follow(self: "PlayerWindow") -> None:
        if self.options.selected is None and not self.options.follow:
            self.status.set("select an agent first (click it, or +), then t follows it")
            return
        self.options.follow = not self.options.follow
        self.status.set("following {}".format(self.scene.names[self.options.selected])
                        if self.options.follow and self.options.selected is not None else "not following")
        if self.state is not None:
            self.show(self.state)

    def do_find_agent(self: "PlayerWindow") -> None:
        text = simpledialog.askstring("Find an agent", "Agent or robot id:", parent=self.root)
        if text:
            self.find_agent(text)

    def find_agent(self: "PlayerWindow", text: str) -> bool:
        """Select the agent named `text` ("robot 3", "agent 7", or the number alone, as the agent
        list names it) and bring it into view; False (and the status says why) if none is."""
        wanted = text.strip().lower()
        number = wanted.split()[-1] if wanted else ""
        names = [n.lower() for n in self.scene.names]
        agent = next((i for i, n in enumerate(names) if n == wanted or n.split()[-1] == number), None)
        if agent is None:
            self.status.set("no agent {!r} here ({})".format(text, names[0] + " ... " + names[-1] if names
                                                             else "no agents"))
            return False
        self.options.only_selected = False
        self.select(agent)
        if self.state is not None:
            x, y = (float(v) for v in self.state.positions[agent])
            if not self.map.view.shows(x, y):
                self.map.view.centre_on(x, y)
                self.map.changed()
        return True

    def do_go_to_time(self: "PlayerWindow") -> None:
        if self.clock is None:
            return
        text = simpledialog.askstring("Go to a time step", "Time step (0 to {}):".format(self.clock.makespan),
                                      parent=self.root)
        if text:
            self.go_to_time(text)

    def go_to_time(self: "PlayerWindow", text: str) -> bool:
        """Pause at time step `text` (fractions move agents between cells); False if not a time."""
        clock = self.clock
        try:
            t = float(text)
        except ValueError:
            t = math.nan
        if clock is None or not (math.isfinite(t) and 0 <= t <= clock.makespan):
            self.status.set("a time step is a number from 0 to {}, not {!r}".format(
                clock.makespan if clock is not None else 0, text))
            return False
        self._with_clock(lambda c: (c.pause(), c.seek(t)))
        return True

    def do_save_plan(self: "PlayerWindow") -> None:
        if self.scene.solution is None:
            self.status.set("no plan solved here to save: open an instance and solve it (File menu)")
            return
        path = filedialog.asksaveasfilename(parent=self.root, defaultextension=".txt",
                                            filetypes=[("mapf-IR solution", "*.txt")], title="Save the plan as")
        if path:
            self.save_plan(path)

    def save_plan(self: "PlayerWindow", path: str) -> None:
        """The plan solved here as a mapf-IR solution file (in its instance's orientation)."""
        from fleet_common.formats.solution import write_solution

        if self.scene.solution is None:
            raise ValueError("no plan was solved in this window")
        write_solution(self.scene.solution, path)
        self.status.set("saved {}".format(path))

    def do_next_conflict(self: "PlayerWindow") -> None:
        k = next_entry(self.entries, self._now(), 1)
        if k is not None:
            self.jump_to_conflict(k)

    def do_prev_conflict(self: "PlayerWindow") -> None:
        k = next_entry(self.entries, self._now(), -1)
        if k is not None:
            self.jump_to_conflict(k)

    def _now(self: "PlayerWindow") -> float:
        return self.state.time if self.state is not None else 0.0

    def do_save_png(self: "PlayerWindow") -> None:
        path = filedialog.asksaveasfilename(parent=self.root, defaultextension=".png",
                                            filetypes=[("PNG image", "*.png")], title="Save view as PNG")
        if path:
            # let the dialog's window vanish from the screen before reading the pixels
            self.root.after(200, self._guarded(lambda: self.save_png(path)))

    def save_png(self: "PlayerWindow", path: str) -> None:
        capture.grab(self.canvas, path)
        self.status.set("saved {}".format(path))

    def do_help(self: "PlayerWindow") -> None:
        show_keys(self.root)

    def do_quit(self: "PlayerWindow") -> None:
        self.close()
