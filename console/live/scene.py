"""The console's `Scene` for what a manager runs, and a placeholder until one answers.

The manager's `RunSetup` message carries the map (rows, top first), the fleet
(robot ids and their robot_definitions.txt colours) and the plan in base-grid
cells; the console's `Scene` is what the map layers draw. Agent i of the plan is
the robot `plan.robots[i]`. The plan comes from the manager, which checked it,
so it is not validated again here.
"""
from __future__ import annotations

from pathlib import PurePath

from fleet_common.control import RunSetup
from fleet_common.grid import Grid
from fleet_common.plan import Plan
from fleet_common.robots import colour_to_rgb

from ..palette import distinct_colours, hex_colour
from ..scene import Scene

__all__ = ["scene_from_manager", "placeholder_scene"]


def scene_from_manager(message: RunSetup, endpoint: str) -> Scene:
    grid = Grid.from_rows(list(message.rows), blocked="@", name=message.map_name)
    plan = Plan(message.plan.positions)
    ids = list(message.plan.robots)
    spare = distinct_colours(len(ids))
    by_id = {}
    for r in message.robots:
        try:
            by_id[r.id] = hex_colour(colour_to_rgb(r.colour))
        except ValueError:
            pass  # a colour this machine's Tk does not know: a distinct one instead
    name = PurePath(message.plan.name).name if message.plan.name else "plan {}".format(message.plan.id)
    diameter, margin, cell = message.robot_size
    info = [name, "{} robots".format(len(ids)),
            "soc {}".format(int(plan.soc)), "makespan {}".format(plan.makespan),
            message.map_name, "robots {:g} m on {:g} m cells".format(diameter, cell),
            "manager {}".format(endpoint)]
    return Scene(grid, [tuple(int(v) for v in c) for c in plan.positions[0]],
                 [tuple(int(v) for v in c) for c in plan.positions[-1]], plan,
                 colours=[by_id.get(rid, spare[i]) for i, rid in enumerate(ids)],
                 names=["robot {}".format(rid) for rid in ids], info=info,
                 title="{} on {}".format(name, endpoint), robot_diameter=min(1.0, diameter / cell),
                 file_orientation=message.orientation)


def placeholder_scene(endpoint: str) -> Scene:
    """An empty floor to show until the manager sends its scene."""
    grid = Grid.from_rows(["." * 12] * 10, name="no map yet")
    return Scene(grid, [], [], None, colours=[], names=[],
                 info=["waiting for the manager at {}".format(endpoint)], title=endpoint, file_orientation="base")
