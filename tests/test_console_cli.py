"""`fleetctl console` from the command line: --screenshot PNGs read back pixel by pixel, errors.

The PNG is what the canvas showed; each agent's disc must have its colour at
the centre of the cell the plan puts it in at --at.
"""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path
from typing import Dict, List, Optional

import numpy as np
from PIL import Image

from console.scene import scene_from_instance, scene_from_solution
from console.ui.map_view import HEADER_HEIGHT
from console.viewport import Viewport
from fleet_common.lab import lab_instance_path
from fleet_common.robots import colour_to_rgb

FLEETCTL = str(Path(sys.executable).parent / "fleetctl")
ECBS = "solutions/ecbs_random-32-32-20_30agents_1.txt"


def fleetctl(args: List[str], display: Optional[str]) -> subprocess.CompletedProcess:
    env: Dict[str, str] = {k: v for k, v in os.environ.items() if k != "DISPLAY"}
    if display is not None:
        env["DISPLAY"] = display
    return subprocess.run([FLEETCTL, "console"] + args, capture_output=True, text=True, timeout=60, env=env)


def pixels_at_cells(png: Path, grid_w: int, grid_h: int, cells: np.ndarray) -> List[tuple]:
    with Image.open(png) as image:
        rgb = image.convert("RGB")
        view = Viewport(grid_w, grid_h, rgb.width, rgb.height, top=HEADER_HEIGHT)
        return [rgb.getpixel((int(x), int(y))) for x, y in view.to_canvas_array(cells).tolist()]


def test_screenshot_has_each_agents_colour_at_its_cell_centre(display: str, shared_data: Path,
                                                               tmp_path: Path) -> None:
    png = tmp_path / "t10.png"
    result = fleetctl(["--replay", str(shared_data / ECBS), "--screenshot", str(png), "--at", "10"], display)
    assert result.returncode == 0, result.stderr
    scene = scene_from_solution(shared_data / ECBS)
    with Image.open(png) as image:
        assert result.stdout.strip() == "{}: time step 10 of 43, {}x{} pixels".format(png, *image.size)
    got = pixels_at_cells(png, scene.grid.width, scene.grid.height, scene.plan.positions[10])
    assert got == [colour_to_rgb(c) for c in scene.colours]
    # and not by chance: at t=0 most agents stood elsewhere
    at_start = pixels_at_cells(png, scene.grid.width, scene.grid.height, scene.plan.positions[0])
    assert sum(a != b for a, b in zip(at_start, got)) > 20


def test_screenshot_without_a_display_renders_on_a_private_xvfb(tmp_path: Path) -> None:
    png = tmp_path / "lab.png"
    result = fleetctl(["--replay", str(lab_instance_path()), "--screenshot", str(png)], None)
    assert result.returncode == 0, result.stderr
    scene = scene_from_instance(lab_instance_path())
    got = pixels_at_cells(png, scene.grid.width, scene.grid.height, np.array(scene.starts))
    # the lab's robots, in robot_definitions.txt's colours: red, green (Tk's is 0,128,0), blue,
    # orange, magenta
    assert got == [(255, 0, 0), (0, 128, 0), (0, 0, 255), (255, 165, 0), (255, 0, 255)]


def test_a_map_smaller_than_the_side_panel_is_pictured_in_the_canvas_it_got(
        shared_data: Path, tmp_path: Path) -> None:
    # a 6x4 map asks for a canvas lower than the panel beside it: the window makes the canvas
    # taller, and the picture is that canvas (it used to fail, "the screen is too small")
    solution = shared_data / "solutions" / "cbs_makespan-soc-pareto.txt"
    png = tmp_path / "small.png"
    result = fleetctl(["--replay", str(solution), "--screenshot", str(png), "--at", "3"], None)
    assert result.returncode == 0, result.stderr
    scene = scene_from_solution(solution)
    with Image.open(png) as image:
        assert result.stdout.strip() == "{}: time step 3 of 12, {}x{} pixels".format(png, *image.size)
    got = pixels_at_cells(png, scene.grid.width, scene.grid.height, scene.plan.positions[3])
    assert got == [colour_to_rgb(c) for c in scene.colours]


def test_unreadable_solution_names_file_and_line(tmp_path: Path, shared_data: Path) -> None:
    bad = tmp_path / "bad.txt"
    lines = (shared_data / ECBS).read_text().splitlines()
    row = next(i for i, ln in enumerate(lines) if ln.startswith("3:"))
    lines[row] = "3:(1,2),(oops"
    bad.write_text("\n".join(lines) + "\n")
    result = fleetctl(["--replay", str(bad), "--screenshot", str(tmp_path / "x.png")], None)
    assert result.returncode == 2
    assert result.stderr.startswith("{}:{}:".format(bad, row + 1))
    assert not (tmp_path / "x.png").exists()


def test_a_window_without_a_display_says_what_to_do(shared_data: Path) -> None:
    result = fleetctl(["--replay", str(shared_data / ECBS)], None)
    assert result.returncode == 2
    assert "cannot open a window" in result.stderr and "--screenshot" in result.stderr
    assert len(result.stderr.splitlines()) == 1


def test_wrong_kind_of_file_and_agent_out_of_range_are_refused(shared_data: Path) -> None:
    result = fleetctl(["--replay", str(shared_data / "maps" / "arena.map")], None)
    assert result.returncode == 2 and "takes a mapf-IR solution or instance" in result.stderr
    result = fleetctl(["--replay", str(shared_data / ECBS), "--agent", "30"], None)
    assert result.returncode == 2 and "agents 0..29" in result.stderr
