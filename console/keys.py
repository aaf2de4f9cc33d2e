"""The player's keyboard shortcuts: one table for the bindings, the menus and Help.

Keys follow mapf-IR's and mapf-visualizer's players where they have one (p, l,
r, v, f, g, G, a, +, -, i, o, arrows), so a student switching tools keeps
their fingers: arrows step one time step here instead of one speed-sized
step, space plays instead of taking a screenshot (Ctrl+S saves a PNG), and
Esc clears the selection instead of quitting (q quits).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Dict, List, Tuple


@dataclass(frozen=True)
class Key:
    action: str
    #: Tk event patterns that trigger the action
    sequences: Tuple[str, ...]
    #: how Help and the menus write the key
    shown: str
    help: str
    group: str


FILE, PLAY, VIEW, AGENTS, CONFLICTS, HELP = "File", "Play", "View", "Agents", "Conflicts", "Help"

KEYS: Tuple[Key, ...] = (
    Key("play_pause", ("<p>", "<space>"), "p, Space", "play / pause", PLAY),
    Key("loop", ("<l>",), "l", "loop on / off", PLAY),
    Key("reset", ("<r>",), "r", "reset to time step 0", PLAY),
    Key("step_forward", ("<Right>",), "Right", "one time step forward", PLAY),
    Key("step_back", ("<Left>",), "Left", "one time step back", PLAY),
    Key("first", ("<Home>",), "Home", "first time step", PLAY),
    Key("last", ("<End>",), "End", "last time step", PLAY),
    Key("faster", ("<Up>",), "Up", "faster", PLAY),
    Key("slower", ("<Down>",), "Down", "slower", PLAY),
    Key("go_to_time", ("<Control-g>",), "Ctrl+G", "go to a time step ...", PLAY),
    Key("goals", ("<g>",), "g", "goal markers on / off", VIEW),
    Key("lines", ("<v>",), "v", "lines: to goal, remaining path, none", VIEW),
    Key("ids", ("<f>",), "f", "agent and cell ids on / off", VIEW),
    Key("node_ids", ("<n>",), "n", "lab map: floor-marker node ids on / off", VIEW),
    Key("grid", ("<G>",), "G", "grid lines on / off", VIEW),
    Key("orientation", ("<m>",), "m", "orientation: lab / mapf-IR", VIEW),
    Key("zoom_in", ("<i>",), "i", "zoom in (or the mouse wheel)", VIEW),
    Key("zoom_out", ("<o>",), "o", "zoom out", VIEW),
    Key("fit", ("<Key-0>",), "0", "fit the whole map", VIEW),
    Key("pan_left", ("<Shift-Left>",), "Shift+Left", "pan left (or drag)", VIEW),
    Key("pan_right", ("<Shift-Right>",), "Shift+Right", "pan right", VIEW),
    Key("pan_up", ("<Shift-Up>",), "Shift+Up", "pan up", VIEW),
    Key("pan_down", ("<Shift-Down>",), "Shift+Down", "pan down", VIEW),
    Key("next_agent", ("<plus>", "<KP_Add>"), "+", "select the next agent", AGENTS),
    Key("prev_agent", ("<minus>", "<KP_Subtract>"), "-", "select the previous agent", AGENTS),
    Key("only_selected", ("<a>",), "a", "show the selected agent only", AGENTS),
    Key("clear_selection", ("<Escape>",), "Esc", "clear the selection", AGENTS),
    Key("follow", ("<t>",), "t", "follow the selected agent (the view keeps it in sight) on / off", AGENTS),
    Key("find_agent", ("<Control-f>",), "Ctrl+F", "find an agent by its id ...", AGENTS),
    Key("next_conflict", ("<c>",), "c", "jump to the next conflict", CONFLICTS),
    Key("prev_conflict", ("<C>",), "C", "jump to the previous conflict", CONFLICTS),
    Key("open_plan", ("<Control-o>",), "Ctrl+O", "open a plan (mapf-IR solution) ...", FILE),
    Key("open_instance", (), "", "open an instance (then solve it) ...", FILE),
    Key("open_map", (), "", "open a map ...", FILE),
    Key("save_png", ("<Control-s>",), "Ctrl+S", "save the view as PNG", FILE),
    Key("save_plan", (), "", "save the plan solved here as a mapf-IR solution ...", FILE),
    Key("help", ("<F1>", "<question>"), "F1, ?", "keyboard shortcuts", HELP),
    Key("quit", ("<q>", "<Control-q>"), "q, Ctrl+Q", "quit", FILE),
)

#: Mouse gestures, for Help.
MOUSE: Tuple[Tuple[str, str], ...] = (
    ("click an agent", "select (highlight) it; click it again to clear"),
    ("click a conflict", "in the list: jump to its time step"),
    ("drag", "pan the map"),
    ("wheel", "zoom at the mouse"),
)

#: Menu order.
GROUPS = (FILE, PLAY, VIEW, AGENTS, CONFLICTS, HELP)


def by_action() -> Dict[str, Key]:
    return {k.action: k for k in KEYS}


def help_lines() -> List[str]:
    """The Help text: every key and mouse gesture, grouped."""
    lines: List[str] = []
    for group in GROUPS:
        lines.append(group)
        for k in KEYS:
            if k.group == group:
                lines.append("  {:<12s} {}".format(k.shown, k.help))
    lines.append("Mouse")
    for gesture, what in MOUSE:
        lines.append("  {:<16s} {}".format(gesture, what))
    return lines
