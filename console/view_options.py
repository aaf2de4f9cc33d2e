"""ViewOptions: what the user chose to see; the views read it, keys change it."""
from __future__ import annotations

from dataclasses import dataclass
from typing import Optional

from .orientation import LAB, of_file, other

#: Line modes, in the order the `v` key cycles through them (mapf-visualizer's order).
LINE_GOAL = "goal"
LINE_PATH = "path"
LINE_NONE = "none"
LINE_MODES = (LINE_GOAL, LINE_PATH, LINE_NONE)
LINE_LABELS = {LINE_GOAL: "line to goal", LINE_PATH: "remaining path", LINE_NONE: "no lines"}


@dataclass
class ViewOptions:
    goals: bool = True
    lines: str = LINE_GOAL
    ids: bool = False
    #: the lab's floor-marker node ids instead of cell ids (lab map only)
    node_ids: bool = False
    grid_lines: bool = True
    orientation: str = LAB
    #: the orientation follows each file opened (its own coordinates) until the user picks one
    follow_file: bool = True
    #: the highlighted agent (clicked or picked from the list), if any
    selected: Optional[int] = None
    #: show the selected agent only (mapf-IR's single-agent mode)
    only_selected: bool = False
    #: keep the selected agent in sight: the view follows it (PlanViz's follow mode)
    follow: bool = False

    def cycle_lines(self) -> None:
        self.lines = LINE_MODES[(LINE_MODES.index(self.lines) + 1) % len(LINE_MODES)]

    def toggle_orientation(self) -> None:
        self.orientation = other(self.orientation)
        self.follow_file = False

    def file_opened(self, file_orientation: str) -> None:
        """A file (or a manager's plan) is shown: use its own coordinates, unless chosen."""
        if self.follow_file:
            self.orientation = of_file(file_orientation)

    def select_next(self, num_agents: int, delta: int) -> None:
        """Select the next (delta 1) or previous (-1) agent, wrapping around."""
        if num_agents == 0:
            return
        if self.selected is None:
            self.selected = 0 if delta > 0 else num_agents - 1
        else:
            self.selected = (self.selected + delta) % num_agents

    def shows_agent(self, agent: int) -> bool:
        return not self.only_selected or self.selected is None or agent == self.selected
