"""The plan player in a real Tk window on Xvfb (started here, stopped by pid).

These press the keys and click the widgets a user would, then read back where
the canvas items are. Expected pixel positions are computed from the plan with
the layout rule the viewport documents (cell size, map corner, rows from the
top), not by calling the code under test to place them.
"""
from __future__ import annotations

import threading
import time
import tkinter as tk
from pathlib import Path
from typing import Tuple

import numpy as np
import pytest

from console.fleet_state import state_at
from console.keys import KEYS
from console.scene import Scene, scene_from_solution
from console.sources import QueueSource
from console.ui.app import PlayerApp
from console.view_options import ViewOptions
from fleet_common.formats import make_solution, map_from_grid, read_solution, write_map, write_solution
from fleet_common.grid import Grid
from fleet_common.plan import Plan
from fleet_common.validate import validate_plan

ECBS = "solutions/ecbs_random-32-32-20_30agents_1.txt"


def open_player(root: tk.Tk, scene: Scene, **kw: object) -> PlayerApp:
    app = PlayerApp(root, scene, canvas_size=(800, 600), playing=False, **kw)
    root.update()
    app.canvas.focus_force()
    root.update()
    return app


def press(app: PlayerApp, key: str, times: int = 1) -> None:
    for _ in range(times):
        app.canvas.event_generate("<KeyPress-%s>" % key)
    app.root.update()


def disc_centres(app: PlayerApp) -> np.ndarray:
    out = []
    for item in app.agents.disc_items:
        x0, y0, x1, y1 = app.canvas.coords(item)
        out.append(((x0 + x1) / 2, (y0 + y1) / 2))
    return np.array(out)


def expected_centres(app: PlayerApp, cells: np.ndarray, rows_down: bool = False) -> np.ndarray:
    """Cell centres by the documented rule: corner (ox, oy), `cell` pixels a cell."""
    v, h = app.map.view, app.scene.grid.height
    rows = cells[:, 1] if rows_down else h - 1 - cells[:, 1]
    return np.column_stack([v.ox + (cells[:, 0] + 0.5) * v.cell, v.oy + (rows + 0.5) * v.cell])


def conflict_solution(tmp_path: Path) -> Path:
    grid = Grid(np.ones((3, 5), dtype=bool))
    write_map(map_from_grid(grid), str(tmp_path / "tiny.map"))
    plan = Plan.from_paths([[(0, 1), (1, 1), (2, 1)], [(2, 1), (1, 1), (0, 1)],
                            [(0, 0), (1, 0), (1, 0)], [(1, 0), (0, 0), (0, 0)]])
    sol = make_solution(grid, "tiny.map", plan, plan.starts, plan.goals, "hand", True, 0)
    write_solution(sol, str(tmp_path / "conflicts.txt"))
    return tmp_path / "conflicts.txt"


def test_step_to_10_puts_every_agent_on_its_planned_cell(root: tk.Tk, shared_data: Path) -> None:
    scene = scene_from_solution(shared_data / ECBS)
    app = open_player(root, scene)
    items_before = app.canvas.find_all()
    press(app, "Right", 10)
    assert app.clock.time == 10.0
    # the same canvas items, moved: nothing was deleted and drawn again
    assert app.canvas.find_all() == items_before
    centres = disc_centres(app)
    np.testing.assert_allclose(centres, expected_centres(app, scene.plan.positions[10]), atol=0.11)
    assert "t = 10.00 / 43" in app.header.text()
    assert app.controls.time.get() == pytest.approx(10.0)
    press(app, "Left")
    np.testing.assert_allclose(disc_centres(app), expected_centres(app, scene.plan.positions[9]), atol=0.11)


def test_playing_moves_agents_smoothly_between_cells(root: tk.Tk, shared_data: Path) -> None:
    scene = scene_from_solution(shared_data / ECBS)
    app = open_player(root, scene)
    app.clock.speed = 8.0
    press(app, "p")
    deadline = time.monotonic() + 5
    while app.clock.time < 2.0 and time.monotonic() < deadline:
        root.update()
        time.sleep(0.01)
    press(app, "space")  # pause
    t = app.clock.time
    assert 2.0 <= t < 43 and not app.clock.playing
    want = expected_centres(app, state_at(scene.plan, t).positions)
    np.testing.assert_allclose(disc_centres(app), want, atol=0.11)


def test_orientation_toggle_on_a_mapf_ir_file_keeps_the_picture_and_flips_coordinates(
        root: tk.Tk, shared_data: Path) -> None:
    scene = scene_from_solution(shared_data / ECBS)
    app = open_player(root, scene)
    before = disc_centres(app)
    x, y = scene.starts[0]
    file_y = scene.grid.height - 1 - y
    # a window opens in the file's own coordinates: what the file, `validate` and the manager say
    app._hovered(*before[0])
    assert "cell ({}, {})".format(x, file_y) in app.status.get()
    assert "origin top-left" in app.header.text()
    axes_before = app.canvas.coords(app.axes.y_arrow)
    press(app, "m")
    # mapf-IR draws its file top-down, as the lab view draws the flipped base grid: same picture
    np.testing.assert_allclose(disc_centres(app), before)
    app._hovered(*before[0])
    assert "cell ({}, {})".format(x, y) in app.status.get()
    assert "origin bottom-left" in app.header.text()
    axes_after = app.canvas.coords(app.axes.y_arrow)
    assert axes_before[3] > axes_before[1] and axes_after[3] < axes_after[1]  # y arrow now points up
    press(app, "m")
    app._hovered(*before[0])
    assert "cell ({}, {})".format(x, file_y) in app.status.get()


def test_orientation_toggle_mirrors_a_base_frame_file(root: tk.Tk, shared_data: Path, tmp_path: Path) -> None:
    sol = read_solution(str(shared_data / ECBS), map_dirs=None)
    base_file = tmp_path / "base.txt"
    write_solution(sol, str(base_file), orientation="base")
    scene = scene_from_solution(base_file)
    assert scene.file_orientation == "base"
    app = open_player(root, scene)
    press(app, "Right", 10)
    lab = disc_centres(app)
    press(app, "m")
    mirrored = disc_centres(app)
    v, h = app.map.view, scene.grid.height
    np.testing.assert_allclose(mirrored[:, 0], lab[:, 0])
    np.testing.assert_allclose(mirrored[:, 1], 2 * v.oy + h * v.cell - lab[:, 1], atol=0.11)
    np.testing.assert_allclose(mirrored, expected_centres(app, scene.plan.positions[10], rows_down=True),
                               atol=0.11)


def test_conflicts_are_listed_marked_and_a_click_jumps_there(root: tk.Tk, tmp_path: Path) -> None:
    scene = scene_from_solution(conflict_solution(tmp_path))
    app = open_player(root, scene)
    items = app.conflict_list.items()
    assert len(items) == 2 and "swap" in items[0] and "vertex" in items[1]
    # the file's own coordinates, as `fleetctl validate` says them: rows from the top of 3 rows
    assert "(1, 1)" in items[1] and items[0].endswith("at (1, 2)")
    report = validate_plan(scene.plan, scene.grid, show=scene.grid.flip_y)
    assert "(1, 2)" in str([f for f in report.errors if f.kind == "swap-conflict"][0])
    press(app, "m")  # the lab's coordinates: rows from the bottom
    assert app.conflict_list.items()[0].endswith("at (1, 0)")
    press(app, "m")
    assert "Conflicts and errors (2)" in app.conflict_list.title.cget("text")
    app.conflict_list.listbox.selection_set(1)
    app.conflict_list.listbox.event_generate("<<ListboxSelect>>")
    root.update()
    assert app.clock.time == 1.0 and app.options.selected == 0
    shown = app.conflicts.shown()
    assert [e.finding.kind for e in shown] == ["vertex-conflict"]
    marker = app.conflicts.items[app.conflicts.entries.index(shown[0])]
    assert app.canvas.itemcget(marker, "state") == "normal"
    x0, y0, x1, y1 = app.canvas.coords(marker)
    np.testing.assert_allclose([(x0 + x1) / 2, (y0 + y1) / 2], expected_centres(app, np.array([[1, 1]]))[0])
    press(app, "c")  # next conflict wraps to the swap, in the middle of the move
    assert app.clock.time == 0.5
    assert [e.finding.kind for e in app.conflicts.shown()] == ["swap-conflict"]
    assert app.canvas.itemcget(marker, "state") == "hidden"


def test_clicking_an_agent_highlights_it_and_a_shows_it_alone(root: tk.Tk, shared_data: Path) -> None:
    scene = scene_from_solution(shared_data / ECBS)
    app = open_player(root, scene)
    x, y = disc_centres(app)[7]
    app.canvas.event_generate("<ButtonPress-1>", x=int(x), y=int(y))
    app.canvas.event_generate("<ButtonRelease-1>", x=int(x), y=int(y))
    root.update()
    assert app.options.selected == 7
    assert app.agent_list.listbox.curselection() == (7,)
    assert float(app.canvas.itemcget(app.agents.disc_items[7], "width")) >= 2
    assert 7 in app.agents.tail_items  # its remaining path is drawn
    press(app, "a")
    states = [app.canvas.itemcget(i, "state") for i in app.agents.disc_items]
    assert states[7] == "normal" and states.count("hidden") == 29
    press(app, "plus")
    assert app.options.selected == 8
    assert app.canvas.itemcget(app.agents.disc_items[8], "state") == "normal"
    press(app, "Escape")
    assert app.options.selected is None and not app.options.only_selected
    assert all(app.canvas.itemcget(i, "state") == "normal" for i in app.agents.disc_items)


def test_goal_line_and_id_toggles(root: tk.Tk, shared_data: Path) -> None:
    scene = scene_from_solution(shared_data / ECBS)
    app = open_player(root, scene)
    goal = app.agents.goal_items[0]
    assert app.canvas.itemcget(goal, "state") == "normal"
    press(app, "g")
    assert app.canvas.itemcget(goal, "state") == "hidden"
    line = app.agents.line_items[0]
    assert app.canvas.coords(line)[2:] == pytest.approx(list(expected_centres(app, np.array([scene.goals[0]]))[0]))
    press(app, "v")  # remaining path: a polyline through the turns ahead, ending on the goal
    assert app.options.lines == "path"
    tails = app.agents.tail_items
    assert len(tails) >= 25
    goals = expected_centres(app, np.array(scene.goals))
    for i, item in tails.items():
        assert app.canvas.coords(item)[-2:] == pytest.approx(list(goals[i]), abs=0.11)
    press(app, "v")
    assert app.canvas.itemcget(line, "state") == "hidden"
    press(app, "f")
    assert [app.canvas.itemcget(i, "text") for i in app.agents.id_items[:3]] == ["0", "1", "2"]
    press(app, "G")
    assert not app.map.grid_lines


def test_zoom_and_pan_keep_agents_on_their_cells(root: tk.Tk, shared_data: Path) -> None:
    scene = scene_from_solution(shared_data / ECBS)
    app = open_player(root, scene)
    cell = app.map.view.cell
    press(app, "i", 2)
    app.canvas.event_generate("<Shift-KeyPress-Right>")
    root.update()
    assert app.map.view.cell == pytest.approx(cell * 1.25 ** 2)
    assert app.clock.time == 0.0  # Shift+Right pans, it does not step
    np.testing.assert_allclose(disc_centres(app), expected_centres(app, scene.plan.positions[0]), atol=0.11)
    press(app, "0")
    assert app.map.view.cell == cell


def test_live_states_from_another_thread_reach_the_canvas(root: tk.Tk, shared_data: Path) -> None:
    scene = scene_from_solution(shared_data / ECBS)
    source = QueueSource()
    app = open_player(root, scene, source=source)
    assert app.controls is None  # the manager drives the time, not the player's buttons

    def network() -> None:  # stands in for the live console's receiving thread
        for version, t in enumerate((1.0, 2.5, 5.0), 1):
            source.put(state_at(scene.plan, t, version))

    thread = threading.Thread(target=network)
    thread.start()
    thread.join()
    deadline = time.monotonic() + 3
    while (app.state is None or app.state.version < 3) and time.monotonic() < deadline:
        root.update()
        time.sleep(0.01)
    np.testing.assert_allclose(disc_centres(app), expected_centres(app, scene.plan.positions[5]), atol=0.11)


def test_help_menu_lists_every_key(root: tk.Tk, shared_data: Path) -> None:
    app = open_player(root, scene_from_solution(shared_data / ECBS))
    bar = app.menubar
    labels = [bar.entrycget(i, "label") for i in range(bar.index("end") + 1)]
    assert labels[-1] == "Help"
    help_menu = root.nametowidget(bar.entrycget(labels.index("Help"), "menu"))
    help_menu.invoke(0)
    root.update()
    windows = [w for w in root.winfo_children() if isinstance(w, tk.Toplevel)]
    text = windows[0].winfo_children()[0].get("1.0", "end")
    for key in KEYS:
        assert key.shown in text and key.help in text


def test_save_view_writes_the_canvas_as_png(root: tk.Tk, shared_data: Path, tmp_path: Path) -> None:
    from PIL import Image

    app = open_player(root, scene_from_solution(shared_data / ECBS))
    app.save_png(str(tmp_path / "view.png"))
    with Image.open(tmp_path / "view.png") as image:
        assert image.size == (800, 600)


def canvas_size(app: PlayerApp) -> Tuple[int, int]:
    return app.canvas.winfo_width(), app.canvas.winfo_height()


def test_instance_shows_agents_on_starts_and_disables_playing(root: tk.Tk, shared_data: Path) -> None:
    from console.scene import scene_from_instance

    scene = scene_from_instance(shared_data / "instances" / "random-32-32-20_30agents_1.txt")
    app = open_player(root, scene, options=ViewOptions())
    assert canvas_size(app) == (800, 600)
    np.testing.assert_allclose(disc_centres(app), expected_centres(app, np.array(scene.starts)), atol=0.11)
    press(app, "Right")
    assert app.clock.time == 0.0
    assert "disabled" in app.controls.time.state()


def test_speed_loop_reset_and_the_time_slider(root: tk.Tk, shared_data: Path) -> None:
    app = open_player(root, scene_from_solution(shared_data / ECBS))
    speed = app.clock.speed
    press(app, "Up", 2)
    assert app.clock.speed == pytest.approx(speed * 2)
    assert "{:g} steps/s".format(speed * 2) in app.controls.speed_label.cget("text")
    press(app, "l")
    assert not app.clock.loop and not app.controls.loop.get()
    app.controls.time.set(7.0)  # the user drags the time-step slider
    root.update()
    assert app.clock.time == pytest.approx(7.0)
    press(app, "r")
    assert app.clock.time == 0.0
    press(app, "End")
    assert app.clock.time == 43.0


def test_headings_are_drawn_as_a_tick_towards_where_the_robot_faces(root: tk.Tk, tmp_path: Path) -> None:
    from fleet_common.plan import Orientation

    grid = Grid(np.ones((4, 4), dtype=bool))
    write_map(map_from_grid(grid), str(tmp_path / "four.map"))
    plan = Plan(np.array([[[1, 1]], [[2, 1]], [[2, 2]]]),
                np.array([[Orientation.X_PLUS], [Orientation.X_PLUS], [Orientation.Y_PLUS]]))
    write_solution(make_solution(grid, "four.map", plan, plan.starts, plan.goals, "hand", True, 0),
                   str(tmp_path / "headings.txt"))
    app = open_player(root, scene_from_solution(tmp_path / "headings.txt"))
    x0, y0, x1, y1 = app.canvas.coords(app.agents.heading_items[0])
    assert x1 > x0 and y1 == pytest.approx(y0)  # facing +x: to the right
    press(app, "End")
    x0, y0, x1, y1 = app.canvas.coords(app.agents.heading_items[0])
    assert y1 < y0 and x1 == pytest.approx(x0)  # facing +y: up the screen in the lab view
