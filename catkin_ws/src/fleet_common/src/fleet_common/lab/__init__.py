"""The CIIRC laboratory, embedded as the default environment (thesis figs. 3.8, 5.8).

A 13 x 14 base grid: x = column 0..12 from the left, y = row 0..13 from the
bottom (Y = 2.1 m) to the top (Y = 11.2 m); one bar-code node per free cell,
0.7 m apart. Files in this folder:

- `lab.map`          the grid in mapf-IR map format (rows top to bottom, '@' = no node)
- `nodes.yaml`       every node: id, base cell, robot-frame position in metres
- `frames.yaml`      base -> robot transform (Vicon is calibrated at the lab)
- `lab_instance.txt` the default 5-robot demo, a mapf-IR instance (top-left origin)
"""
from __future__ import annotations

import functools
from pathlib import Path
from typing import Dict

from ..frames import load_transforms
from ..transform2d import Transform2D
from ..yaml_lines import read_yaml_text
from .node_table import NodeTable, parse_node_table

__all__ = [
    "LAB_DIR", "NodeTable", "lab_map_path", "lab_instance_path", "lab_nodes_path",
    "lab_frames_path", "lab_transforms", "base_to_robot", "node_table",
]

LAB_DIR = Path(__file__).resolve().parent


def lab_map_path() -> Path:
    return LAB_DIR / "lab.map"


def lab_instance_path() -> Path:
    return LAB_DIR / "lab_instance.txt"


def lab_nodes_path() -> Path:
    return LAB_DIR / "nodes.yaml"


def lab_frames_path() -> Path:
    return LAB_DIR / "frames.yaml"


def lab_transforms() -> Dict[str, Transform2D]:
    """name -> transform from `frames.yaml` (a fresh dict each call)."""
    return load_transforms(lab_frames_path())


def base_to_robot() -> Transform2D:
    """Base cells -> robot-frame metres, as the robots use it."""
    return lab_transforms()["base_to_robot"]


@functools.lru_cache(maxsize=None)
def node_table() -> NodeTable:
    """The lab's nodes (read once; the table is not changed by its users)."""
    path = lab_nodes_path()
    return parse_node_table(read_yaml_text(str(path)), str(path), base_to_robot())
