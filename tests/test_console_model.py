"""The console's model without a display: clock, states, viewport, orientation, picture, scene.

Everything here is what the Tk views draw from; if it is right, the window only
has to put items where these functions say (tests/test_console_player.py).
"""
from __future__ import annotations

import threading
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, strategies as st

from console import background, orientation
from console.conflicts import conflict_entries, next_entry
from console.fleet_state import FleetState, state_at
from console.keys import KEYS, help_lines
from console.palette import agent_colours, distinct_colours
from console.scene import scene_from_instance, scene_from_plan, scene_from_solution
from console.sources import MAX_SPEED, PlanClock, QueueSource
from console.view_options import LINE_MODES, ViewOptions
from console.viewport import Viewport
from fleet_common.formats import make_solution, map_from_grid, write_map, write_solution
from fleet_common.grid import Grid
from fleet_common.lab import lab_instance_path
from fleet_common.plan import Orientation, Plan
from fleet_common.robots import colour_to_rgb, read_robot_definitions

ECBS = "solutions/ecbs_random-32-32-20_30agents_1.txt"


def line_plan() -> Plan:
    # agent 0 walks right along y=0; agent 1 waits, then walks up
    return Plan.from_paths([[(0, 0), (1, 0), (2, 0), (3, 0)], [(5, 5), (5, 5), (5, 6)]])


def conflict_files(tmp_path: Path) -> Path:
    """A 5 x 3 map and a solution with one vertex and one swap conflict."""
    grid = Grid(np.ones((3, 5), dtype=bool))
    write_map(map_from_grid(grid), str(tmp_path / "tiny.map"))
    plan = Plan.from_paths([
        [(0, 1), (1, 1), (2, 1)],  # 0 and 1 meet on (1, 1) at t=1
        [(2, 1), (1, 1), (0, 1)],
        [(0, 0), (1, 0), (1, 0)],  # 2 and 3 swap (0, 0) and (1, 0) between t=0 and t=1
        [(1, 0), (0, 0), (0, 0)],
    ])
    sol = make_solution(grid, "tiny.map", plan, plan.starts, plan.goals, "hand", True, 0)
    write_solution(sol, str(tmp_path / "conflicts.txt"))
    return tmp_path / "conflicts.txt"


# -- clock and states -------------------------------------------------------------------

def test_state_between_steps_is_linear_interpolation() -> None:
    state = state_at(line_plan(), 1.25)
    assert state.step == 1
    assert state.positions.tolist() == [[1.25, 0.0], [5.0, 5.25]]
    assert state_at(line_plan(), 99).positions.tolist() == [[3, 0], [5, 6]]  # clamped: at goals


def test_headings_turn_the_short_way() -> None:
    plan = Plan(np.array([[[0, 0]], [[0, 0]]]), np.array([[Orientation.X_PLUS], [Orientation.Y_MINUS]]))
    # from 0 deg to 270 deg: a quarter turn clockwise, through 315, not through 135
    assert state_at(plan, 0.5).headings.tolist() == [315.0]


def test_playing_moves_by_speed_times_wall_time() -> None:
    clock = PlanClock(line_plan(), speed=2.0, playing=True)
    assert clock.poll(100.0).time == 0.0  # the first poll starts the clock
    assert clock.poll(100.5).time == pytest.approx(1.0)
    clock.pause()
    assert clock.poll(107.0) is None  # paused and unchanged: nothing to redraw
    assert clock.time == pytest.approx(1.0)


def test_loop_holds_the_goals_for_one_step_then_starts_again() -> None:
    clock = PlanClock(line_plan(), speed=1.0, loop=True, playing=True)
    clock.poll(0.0)
    assert clock.poll(3.5).time == 3.0  # past the end: the last configuration holds
    assert clock.poll(4.25).time == pytest.approx(0.25)
    clock.loop = False
    assert clock.poll(9.0).time == 3.0
    assert not clock.playing  # without loop the player stops at the end


def test_step_goes_to_whole_time_steps_and_pauses() -> None:
    clock = PlanClock(line_plan(), playing=True)
    clock.seek(1.4)
    clock.step(1)
    assert (clock.time, clock.playing) == (2.0, False)
    clock.step(-1)
    assert clock.time == 1.0
    clock.seek(1.4)
    clock.step(-1)
    assert clock.time == 1.0
    clock.step(-5)
    assert clock.time == 0.0
    clock.step(10)
    assert clock.time == 3.0


def test_speed_stays_in_range() -> None:
    clock = PlanClock(line_plan(), speed=1000)
    assert clock.speed == MAX_SPEED


def test_queue_source_drains_a_bounded_batch_and_keeps_the_newest() -> None:
    source = QueueSource(max_per_poll=100)
    cells = np.zeros((2, 2))

    def produce() -> None:
        for v in range(1, 251):
            source.put(FleetState(float(v), cells, version=v))

    worker = threading.Thread(target=produce)
    worker.start()
    worker.join()
    assert source.poll(0).version == 100  # at most 100 states per tick
    assert source.poll(0).version == 200
    source.put(FleetState(0.0, cells, version=150))  # outdated: dropped
    assert source.poll(0).version == 250
    assert source.poll(0) is None
    assert source.current().version == 250


# -- viewport, orientation, picture -----------------------------------------------------

def test_fit_shows_the_whole_map_centred_below_the_header() -> None:
    view = Viewport(32, 16, 800, 600, top=40)
    x0, y0, x1, y1 = view.map_box()
    assert x0 >= 0 and x1 <= 800 and y0 >= 40 and y1 <= 600
    assert abs((x0 + x1) / 2 - 400) <= 1
    assert view.to_canvas(0, 0)[1] > view.to_canvas(0, 15)[1]  # lab view: y grows up the screen


@given(st.integers(0, 49), st.integers(0, 29), st.booleans(), st.floats(0.3, 5.0))
def test_cell_under_a_cells_centre_is_that_cell(x: int, y: int, down: bool, zoom: float) -> None:
    view = Viewport(50, 30, 900, 700, top=42, down=down)
    view.zoom(zoom, 123, 456)
    assert view.to_cell(*view.to_canvas(x, y)) == (x, y)


def test_zoom_keeps_the_point_under_the_mouse() -> None:
    view = Viewport(50, 30, 900, 700)
    before = view.to_cell(300, 200)
    view.zoom(3.0, 300, 200)
    assert view.to_cell(300, 200) == before
    assert view.cell > 3 * 10


def test_mirroring_flips_rows_inside_the_same_rectangle() -> None:
    view = Viewport(10, 6, 400, 300)
    box = view.map_box()
    up = view.to_canvas_array(np.array([[2, 0], [2, 5]]))
    view.set_down(True)
    assert view.map_box() == box
    down = view.to_canvas_array(np.array([[2, 0], [2, 5]]))
    assert down[:, 0].tolist() == up[:, 0].tolist()
    assert down[:, 1].tolist() == up[::-1, 1].tolist()


def test_mapf_ir_view_shows_the_files_own_coordinates(shared_data: Path) -> None:
    scene = scene_from_solution(shared_data / ECBS)
    text = (shared_data / ECBS).read_text()
    first = text.split("starts=(", 1)[1].split(")", 1)[0]
    in_file = tuple(int(v) for v in first.split(","))
    h = scene.grid.height
    assert orientation.shown_cell(scene.starts[0], h, orientation.MAPF_IR, scene.file_orientation) == in_file
    lab = orientation.shown_cell(scene.starts[0], h, orientation.LAB, scene.file_orientation)
    assert lab == (in_file[0], h - 1 - in_file[1])
    # the picture stays: mapf-IR's visualizer draws the file as the lab view draws the base grid
    assert not orientation.rows_grow_down(orientation.MAPF_IR, scene.file_orientation)
    assert orientation.rows_grow_down(orientation.MAPF_IR, "base")
    assert not orientation.rows_grow_down(orientation.LAB, "base")


def test_map_picture_has_obstacles_where_the_grid_does() -> None:
    free = np.ones((6, 10), dtype=bool)
    free[0, 2] = False  # bottom row, third column
    view = Viewport(10, 6, 400, 300)
    pixels = background.render(free, view)
    for down in (False, True):
        view.set_down(down)
        pixels = background.render(free, view, grid_lines=False)
        bx, by = (int(v) for v in view.to_canvas(2, 0))
        fx, fy = (int(v) for v in view.to_canvas(3, 0))
        assert tuple(pixels[by, bx]) == background.BLOCKED
        assert tuple(pixels[fy, fx]) == background.FREE
    assert tuple(pixels[0, 0]) == background.OUTSIDE
    with_lines = background.render(free, view, grid_lines=True)
    x0, y0 = int(view.ox), int(view.oy)
    assert tuple(with_lines[y0 + 5, x0]) == background.GRID_LINE
    assert background.to_ppm(pixels).startswith(b"P6\n400 300\n255\n")


# -- scene, colours, conflicts, keys -----------------------------------------------------

def test_solution_scene_has_the_header_figures_and_no_conflicts(shared_data: Path) -> None:
    scene = scene_from_solution(shared_data / ECBS)
    assert scene.num_agents == 30 and scene.makespan == 43
    assert scene.info[:5] == ["solver ECBS-1.100000", "solved", "soc 681", "makespan 43", "comp_time 3 ms"]
    assert scene.findings == []
    assert len(set(scene.colours)) == 30
    assert scene.names[0] == "agent 0"


def test_failed_run_and_instance_show_agents_on_their_starts(shared_data: Path) -> None:
    failed = scene_from_solution(shared_data / "solutions" / "cbs_arena300_1_timeout.txt")
    assert failed.plan is None and "NOT solved (failed run)" in failed.info
    inst = scene_from_instance(shared_data / "instances" / "random-32-32-20_30agents_1.txt")
    assert inst.plan is None and inst.num_agents == 30 and inst.makespan == 0


def test_lab_robots_get_their_colours_from_robot_definitions() -> None:
    scene = scene_from_instance(lab_instance_path())
    robots = read_robot_definitions()
    assert scene.colours == ["#{:02x}{:02x}{:02x}".format(*colour_to_rgb(r.colour)) for r in robots]
    assert scene.colours[0] == "#ff0000" and scene.names[0] == "robot 1"


def test_other_agents_get_distinct_colours_that_stand_out_from_the_map() -> None:
    colours = distinct_colours(300)
    assert len(set(colours[:60])) == 60
    rgb = [colour_to_rgb(c) for c in colours]
    for bg in (background.FREE, background.BLOCKED):
        assert min(sum(abs(a - b) for a, b in zip(c, bg)) for c in rgb) > 60
    assert agent_colours(3, read_robot_definitions()[:2]) == distinct_colours(3)  # too few robots


def test_conflicts_are_listed_in_time_order_with_where_to_jump(tmp_path: Path) -> None:
    scene = scene_from_solution(conflict_files(tmp_path))
    entries = conflict_entries(scene.findings)
    kinds = [e.finding.kind for e in entries]
    assert kinds == ["swap-conflict", "vertex-conflict"]
    swap, vertex = entries
    assert swap.jump_time == 0.5 and swap.agents == (2, 3)
    lo, hi = swap.window  # shown while the two pass each other, not once they stand apart
    assert 0.0 < lo < 0.01 and 0.99 < hi < 1.0
    assert vertex.jump_time == 1.0 and vertex.cell == (1, 1) and vertex.agents == (0, 1)
    h = scene.grid.height
    assert vertex.label(h, orientation.LAB, scene.file_orientation).split() == \
        ["t=1", "vertex", "0,", "1", "at", "(1,", "1)"]
    assert next_entry(entries, 0.5, 1) == 1
    assert next_entry(entries, 1.0, 1) == 0  # wraps around
    assert next_entry(entries, 0.0, -1) == 1


def test_every_key_is_bound_once_and_listed_in_help() -> None:
    sequences = [s for k in KEYS for s in k.sequences]
    assert len(sequences) == len(set(sequences))
    assert len({k.action for k in KEYS}) == len(KEYS)
    text = "\n".join(help_lines())
    for k in KEYS:
        assert "{:<12s} {}".format(k.shown, k.help) in text
    for needed in ("play_pause", "loop", "reset", "faster", "step_forward", "step_back", "only_selected",
                   "goals", "lines", "ids", "zoom_in", "grid", "orientation", "next_conflict", "save_png"):
        assert needed in {k.action for k in KEYS}


def test_line_modes_cycle_like_mapf_visualizer() -> None:
    options = ViewOptions()
    seen = []
    for _ in LINE_MODES:
        seen.append(options.lines)
        options.cycle_lines()
    assert seen == ["goal", "path", "none"] and options.lines == "goal"
    options.select_next(5, -1)
    assert options.selected == 4
    options.select_next(5, 1)
    assert options.selected == 0


def test_path_corners_keep_turns_and_the_end_and_say_which_is_next() -> None:
    from console.path_corners import PathCorners

    plan = Plan.from_paths([
        [(0, 0), (1, 0), (2, 0), (2, 0), (2, 1), (2, 2), (1, 2)],  # right, wait, up, left
        [(5, 5), (5, 6), (5, 5), (5, 6)],  # shuttles: every cell a corner
        [(9, 9)],  # never moves
    ])
    corners = PathCorners(plan)
    assert corners.ahead(0, 0, 10).tolist() == [[2, 0], [2, 2], [1, 2]]
    assert corners.ahead(1, 0, 10).tolist() == [[5, 6], [5, 5], [5, 6]]
    assert corners.ahead(2, 0, 10).tolist() == [[9, 9]]
    k = corners.next_index(2.5)  # agent 0 waits on the corner (2, 0), reached at t=2
    assert k.tolist() == [1, 2, 1]
    assert corners.targets(k).tolist() == [[2, 2], [5, 6], [9, 9]]
    assert corners.ahead(0, 1, 1).tolist() == [[2, 2]]


def test_following_moves_and_rotations_are_counted_not_listed() -> None:
    ring = [(0, 0), (1, 0), (1, 1), (0, 1)]  # four agents turn once round a 2x2 square
    paths = [[ring[i], ring[(i + 1) % 4]] for i in range(4)]
    paths.append([(3, 0), (3, 1)])  # a fifth follows nobody
    scene = scene_from_plan(Grid(np.ones((3, 4), dtype=bool)), Plan.from_paths(paths))
    assert scene.findings == [] and scene.rotations == 1 and scene.following == 4
