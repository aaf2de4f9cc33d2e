"""The console as a new user meets it on the lab: robots by id, floor-marker node ids, a header
that tells a broken plan from a solved one, and the File menu (open a plan, an instance or a
map; solve the instance with a built-in solver in the background). Real Tk on Xvfb."""
from __future__ import annotations

import threading
import time
import tkinter as tk
from pathlib import Path
from typing import Callable

import numpy as np

import console.ui.file_actions as file_actions
from console.scene import INSTANCE, MAP, SOLUTION, scene_from_instance, scene_from_solution
from console.ui.app import PlayerApp
from fleet_common.lab import lab_instance_path, lab_map_path, node_table
from fleet_common.planning import solve
from fleet_common.validate import validate_plan
from test_console_player import conflict_solution, open_player, press

ECBS = "solutions/ecbs_random-32-32-20_30agents_1.txt"


def pump(app: PlayerApp, until: Callable[[], bool], seconds: float = 60.0) -> None:
    """Let Tk run (its after() loop drains background results) until `until()` or the time is up."""
    deadline = time.monotonic() + seconds
    while not until() and time.monotonic() < deadline:
        app.root.update()
        time.sleep(0.01)


def canvas_texts(app: PlayerApp, tag: str) -> list:
    return [app.canvas.itemcget(i, "text") for i in app.canvas.find_withtag(tag)]


def test_lab_robots_are_listed_by_their_id_alone(root: tk.Tk) -> None:
    app = open_player(root, scene_from_instance(lab_instance_path()))
    # not "0  robot 1": the agent index beside the robot's id reads as two different numbers
    assert app.agent_list.items() == ["\u25cf robot {}".format(i) for i in range(1, 6)]
    app.agent_list.listbox.selection_set(2)
    app.agent_list.listbox.event_generate("<<ListboxSelect>>")
    root.update()
    status = app.status.get()
    start = app.scene.starts[2]
    in_file = app.scene.grid.flip_y(start)  # lab_instance.txt counts rows from the top, as mapf-IR
    assert status.startswith("robot 3: start ({}, {}) node {}".format(*in_file, node_table().node_at(start)))
    assert "agent" not in status


def test_the_lab_map_shows_floor_marker_node_ids(root: tk.Tk) -> None:
    app = open_player(root, scene_from_instance(lab_instance_path()))
    press(app, "n")
    labels = set(canvas_texts(app, "cellid"))
    assert labels == {str(i) for i in node_table().ids()}  # 427 ... where the robots' tags are
    x, y = app.map.view.to_canvas(1, 8)
    app._hovered(x, y)
    assert "node 427" in app.status.get()
    press(app, "n")
    press(app, "f")
    assert "427" not in canvas_texts(app, "cellid")  # f: cell ids, as mapf-IR numbers cells


def test_node_ids_are_for_the_lab_map_only(root: tk.Tk, shared_data: Path) -> None:
    app = open_player(root, scene_from_solution(shared_data / ECBS))
    press(app, "n")
    assert not app.options.node_ids and "only the lab map" in app.status.get()


def test_a_plan_with_conflicts_says_so_in_the_header(root: tk.Tk, tmp_path: Path) -> None:
    app = open_player(root, scene_from_solution(conflict_solution(tmp_path)))
    first = app.header.text().splitlines()[0]
    assert "INVALID: 2 conflicts or errors (listed)" in first and "solved" not in first


def test_file_menu_opens_plans_instances_and_maps(root: tk.Tk, shared_data: Path) -> None:
    app = open_player(root, scene_from_solution(shared_data / ECBS))
    menu = app.menus["File"]
    labels = [menu.entrycget(i, "label") for i in range(menu.index("end") + 1) if menu.type(i) != "separator"]
    assert labels[:4] == ["open a plan (mapf-IR solution) ...", "open an instance (then solve it) ...",
                          "open a map ...", "Solve this instance with"]
    assert menu.entrycget(3, "state") == "disabled"  # a plan is shown: nothing to solve
    assert app.open_path(MAP, lab_map_path())
    pump(app, lambda: app.scene.kind == MAP)
    assert app.scene.num_agents == 0 and app.scene.title == "lab.map"
    assert app.agent_list.items() == [] and app.menus["File"].entrycget(3, "state") == "disabled"
    assert app.open_path(SOLUTION, shared_data / ECBS)
    pump(app, lambda: app.scene.kind == SOLUTION)
    assert app.scene.num_agents == 30 and app.clock.makespan == 43
    press(app, "Right", 3)
    assert app.clock.time == 3.0  # the new plan plays in the same window
    assert app.open_path(SOLUTION, shared_data / "maps" / "arena.map")
    pump(app, lambda: app.jobs.running is None)
    assert app.status.get().startswith("error: ") and "arena.map" in app.status.get()
    assert app.scene.num_agents == 30  # a bad file changes nothing


def test_an_instance_is_solved_in_the_background_while_the_window_answers(root: tk.Tk, monkeypatch) -> None:
    gate = threading.Event()
    threads = []

    def gated_solve(*args, **kwargs):  # the real solver, once the test lets it go
        threads.append(threading.current_thread())
        gate.wait(30)
        return solve(*args, **kwargs)

    monkeypatch.setattr(file_actions, "solve", gated_solve)
    app = open_player(root, scene_from_instance(lab_instance_path()))
    assert app.scene.kind == INSTANCE and app.menus["File"].entrycget(3, "state") == "normal"
    solve_menu = app.solve_menu
    solve_menu.invoke([solve_menu.entrycget(i, "label") for i in range(4)].index("lacam"))
    assert app.jobs.running and "solving lab_instance.txt with lacam" in app.status.get()
    goals = app.options.goals
    press(app, "g")  # the solver is stuck at the gate, and still the window answers
    assert app.options.goals is not goals
    assert threads and threads[0] is not threading.main_thread()
    assert not app.solve("pibt") and app.status.get().startswith("busy solving")
    gate.set()
    pump(app, lambda: app.scene.plan is not None)
    scene = app.scene
    assert scene.info[0] == "solver lacam (built in)" and scene.names[0] == "robot 1"
    assert validate_plan(scene.plan, scene.grid, goals=scene.goals, strict_rotations=True).ok
    assert np.array_equal(scene.plan.positions[0], np.array(scene_from_instance(lab_instance_path()).starts))
    assert app.clock.playing  # it plays at once


def test_the_header_counts_rotations_of_a_solved_plan(tmp_path: Path) -> None:
    from fleet_common.formats import make_solution, map_from_grid, write_map, write_solution
    from fleet_common.grid import Grid
    from fleet_common.plan import Plan

    grid = Grid(np.ones((4, 4), dtype=bool))
    write_map(map_from_grid(grid), str(tmp_path / "g.map"))
    square = [(1, 1), (2, 1), (2, 2), (1, 2)]
    plan = Plan.from_paths([[square[i], square[(i + 1) % 4]] for i in range(4)])
    write_solution(make_solution(grid, "g.map", plan, plan.starts, plan.goals, "hand", True, 0),
                   str(tmp_path / "r.txt"))
    assert scene_from_solution(tmp_path / "r.txt").info[1] == "solved, 1 rotation (robots need them repaired)"


def test_a_plan_solved_here_is_saved_as_a_solution_in_the_instances_own_coordinates(
        root: tk.Tk, tmp_path: Path) -> None:
    from fleet_common.formats.solution import read_solution

    app = open_player(root, scene_from_instance(lab_instance_path()))
    # an instance has no plan: nothing is called valid
    assert app.conflict_list.title.cget("text") == "No plan to check: solve the instance (File menu)"
    app.do_save_plan()
    assert app.status.get().startswith("no plan solved here to save")
    assert app.solve("cbs")
    pump(app, lambda: app.scene.plan is not None)
    assert app.conflict_list.title.cget("text").startswith("No conflicts: the plan is valid")
    app.save_plan(str(tmp_path / "solved.txt"))
    text = (tmp_path / "solved.txt").read_text()
    assert "map_file=lab.map" in text and "solver=cbs" in text and "instance=lab_instance.txt" in text
    saved = read_solution(str(tmp_path / "solved.txt"), map_dirs=[lab_map_path().parent])
    assert np.array_equal(saved.plan.positions, app.scene.plan.positions)
    assert saved.starts == scene_from_instance(lab_instance_path()).starts  # the same cells, read back
    assert saved.orientation == "mapf-ir" and "1,5" in text.split("solution=")[1].splitlines()[1]


def test_find_an_agent_go_to_a_time_and_follow_an_agent(root: tk.Tk, shared_data: Path) -> None:
    scene = scene_from_solution(shared_data / ECBS)
    app = open_player(root, scene)
    assert app.go_to_time("12.5") and app.clock.time == 12.5 and not app.clock.playing
    assert not app.go_to_time("99") and "from 0 to 43" in app.status.get()
    assert not app.go_to_time("soon") and app.clock.time == 12.5
    for _ in range(4):
        app.do_zoom_in()
    assert app.find_agent("17") and app.options.selected == 17
    x, y = app.state.positions[17]
    assert app.map.view.shows(x, y)  # brought into view
    assert app.find_agent("agent 3") and app.options.selected == 3
    assert not app.find_agent("robot 99") and app.options.selected == 3
    # follow: as the agent moves on, the view keeps it in sight
    app.find_agent("5")
    press(app, "t")
    assert app.options.follow
    seen = []
    for t in range(0, 44, 2):
        app.go_to_time(str(t))
        root.update()
        x, y = app.state.positions[5]
        seen.append(app.map.view.shows(x, y))
    assert all(seen)
    press(app, "t")
    assert not app.options.follow
