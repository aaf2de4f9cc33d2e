"""What the console windows offer their action mixins: the parts each action reaches.

`PlayerActions` and `FileActions` are mixins of `PlayerApp`, `LiveActions` of
`LiveApp`: the key table, the menus and the tests reach every action by name
on the window. The actions are written against these interfaces, not against
the window classes, so an action module imports the view parts it uses and
never the window that mixes it in (no import circle; the windows satisfy them).
"""
from __future__ import annotations

import tkinter as tk
from typing import Any, Callable, Dict, List, Optional, Tuple

try:
    from typing import Protocol
except ImportError:  # pragma: no cover  (3.8 has it; the console runs on the lab PC)
    Protocol = object  # type: ignore

from ..conflicts import ConflictEntry
from ..fleet_state import FleetState
from ..jobs import Jobs
from ..live.model import LiveModel
from ..scene import Scene
from ..sources import PlanClock
from ..view_options import ViewOptions
from .admin_panel import AdminPanel
from .agent_layer import AgentLayer
from .conflict_layer import ConflictLayer
from .lists import AgentList, ConflictList
from .map_view import MapView

__all__ = ["PlayerWindow", "LiveWindow"]


class PlayerWindow(Protocol):
    """The player's window, as its actions see it (`PlayerApp`)."""

    root: tk.Tk
    options: ViewOptions
    scene: Scene
    state: Optional[FleetState]
    clock: Optional[PlanClock]
    entries: List[ConflictEntry]
    status: tk.StringVar
    actions: Dict[str, Callable[[], None]]
    jobs: Jobs
    map: MapView
    canvas: tk.Canvas
    agents: AgentLayer
    conflicts: ConflictLayer
    agent_list: AgentList
    conflict_list: ConflictList
    menubar: tk.Menu
    solve_menu: tk.Menu

    # the window's own
    def open_scene(self, scene: Scene) -> None: ...
    def relayout(self) -> None: ...
    def close(self) -> None: ...
    def shown_cell(self, cell: Tuple[int, int]) -> Tuple[int, int]: ...
    def _mirrored(self) -> bool: ...
    def _status_changed(self) -> None: ...
    def _clock_changed(self) -> None: ...
    def _fill_conflicts(self) -> None: ...
    def _guarded(self, fn: Callable[[], None]) -> Callable[[], None]: ...

    # the actions, as they call each other
    def select(self, agent: Optional[int]) -> None: ...
    def jump_to_conflict(self, index: int) -> None: ...
    def save_png(self, path: str) -> None: ...
    def open_path(self, kind: str, path: Any) -> bool: ...
    def solve(self, solver: str) -> bool: ...
    def _place(self, cell: Tuple[int, int]) -> str: ...
    def _hovered(self, px: float, py: float) -> None: ...
    def _with_clock(self, fn: Callable[[PlanClock], None]) -> None: ...
    def _now(self) -> float: ...
    def _background(self, what: str, work: Callable[[], Any]) -> bool: ...
    def _finished(self, result: Any, error: Optional[BaseException]) -> None: ...


class LiveWindow(PlayerWindow, Protocol):
    """The live console's window, as its actions see it (`LiveApp`)."""

    model: LiveModel
    admin: AdminPanel
    #: sends a request to the manager (the link's `request`)
    _ask: Callable[..., None]

    def _show_robot(self) -> None: ...

    # the actions, as they call each other
    def selected_robot(self) -> Optional[int]: ...
    def ask(self, action: str, **args: Any) -> None: ...
    def save_window(self, path: str) -> None: ...
    def _save_window(self) -> None: ...
