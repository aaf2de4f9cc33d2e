"""Coordinate frames and the transforms between them, kept as data (YAML).

Frames (ARCHITECTURE.md): "mapf-ir" (cells, top-left, y down), "base" (cells,
bottom-left, y up; the reference), "robot" (metres), "vicon" (millimetres).
A transforms file maps a name to one transform, written either readably
(applied in this order: mirror y, scale, rotate counter-clockwise, translate):

    base_to_robot:
      source: base          # the frame it reads
      target: robot         # the frame it writes
      scale: 0.7            # target units per source unit; or [sx, sy]; positive
      rotation_deg: 0       # optional, default 0
      translation: [0.7, 2.1]   # in target units, added last; default [0, 0]
      flip_y: false         # optional: mirror y first (y -> -y)

or as the top rows of the homogeneous matrix (x' = a x + b y + tx, ...):

    vicon_to_base:
      source: vicon
      target: base
      matrix: [[0.00143, 0.0, 3.2], [0.0, 0.00143, -1.5]]

Inverses need no entry: `find_transform` chains entries and their inverses.
Errors are `TransformError`s naming the file, line and column.
`fit_similarity` calibrates a frame from measured point pairs (Umeyama 1991);
`write_transform` puts the result into a file, keeping its other entries and comments.
"""
from __future__ import annotations

import math
import os
import re
from collections import deque
from pathlib import Path
from typing import Any, Dict, Iterable, List, Mapping, Optional, Tuple, Union

import numpy as np
import yaml

from .errors import TransformError
from .limits import excerpt
from .transform2d import FRAMES, Transform2D, check_frame, readable
from .yaml_lines import load_marked, read_yaml_text, where

__all__ = [
    "FRAMES", "Transform2D", "mapf_ir_to_base", "similarity", "scale_translate",
    "find_transform", "parse_transforms", "load_transforms", "dump_transforms",
    "fit_similarity", "check_frame", "set_transform", "write_transform",
]

_HEADER = (
    "# Coordinate transforms: name -> {source, target, scale, rotation_deg, translation,\n"
    "# flip_y} (applied as: mirror y, scale, rotate counter-clockwise, translate) or\n"
    "# {source, target, matrix}. Frames: " + ", ".join(sorted(FRAMES)) + ".\n"
)


def similarity(scale: float, theta: float, tx: float, ty: float,
               source: str, target: str) -> Transform2D:
    """Uniform `scale`, then rotation by `theta` radians counter-clockwise, then (tx, ty)."""
    return readable(scale, math.degrees(theta), (tx, ty), False, source, target)


def scale_translate(scale: Union[float, Tuple[float, float]], tx: float, ty: float,
                    source: str, target: str) -> Transform2D:
    """Scale (one factor or (sx, sy)), then translate; e.g. base cells -> robot metres."""
    return readable(scale, 0.0, (tx, ty), False, source, target)


def mapf_ir_to_base(height: int) -> Transform2D:
    """mapf-IR cells (top-left, y down) -> base cells: (x, y) -> (x, height - 1 - y)."""
    return readable(1.0, 0.0, (0.0, height - 1.0), True, "mapf-ir", "base")


def find_transform(transforms: Iterable[Transform2D], source: str, target: str) -> Transform2D:
    """source -> target by chaining the given transforms and their inverses (shortest chain)."""
    edges: Dict[str, List[Transform2D]] = {}
    given = list(transforms)
    for t in given:
        edges.setdefault(t.source, []).append(t)
        edges.setdefault(t.target, []).append(t.inverse())
    found = {source: Transform2D.identity(check_frame(source))}
    queue = deque([source])
    while queue:
        here = queue.popleft()
        for step in edges.get(here, []):
            if step.target not in found:
                found[step.target] = found[here].then(step)
                queue.append(step.target)
    if check_frame(target) not in found:
        raise TransformError("no transform from {} to {} (have: {})".format(
            source, target, ", ".join(t.name() for t in given) or "none"))
    return found[target]


# ---- YAML ------------------------------------------------------------------

def parse_transforms(text: str, path: Optional[str] = None) -> Dict[str, Transform2D]:
    """name -> transform from YAML text (an empty document holds none)."""
    data = load_marked(text, path, TransformError)
    if data is None:
        return {}
    if not isinstance(data, Mapping):
        raise TransformError("expected a mapping of transform names to transforms, got {}".format(
            type(data).__name__), path, *where(data))
    out: Dict[str, Transform2D] = {}
    for name, entry in data.items():
        if not isinstance(name, str):
            raise TransformError("transform name must be text, got {}".format(excerpt(name)),
                                 path, *where(data, name))
        if not isinstance(entry, Mapping):
            raise TransformError("transform {} must be a mapping (source, target, ...), "
                                 "got {}".format(excerpt(name), excerpt(entry)), path,
                                 *where(data, name))
        out[name] = Transform2D.from_dict(entry, path)
    return out


def load_transforms(path: Union[str, Path]) -> Dict[str, Transform2D]:
    return parse_transforms(read_yaml_text(str(path), TransformError), str(path))


def dump_transforms(transforms: Mapping[str, Transform2D],
                    path: Union[str, Path, None] = None) -> str:
    """YAML text for `transforms` (readable form where possible); written to `path` if given."""
    body = {name: t.to_dict() for name, t in transforms.items()}
    text = _HEADER + yaml.safe_dump(body, sort_keys=False, default_flow_style=None)
    if path is not None:
        Path(path).write_text(text, encoding="utf-8")
    return text


def set_transform(text: str, name: str, transform: Transform2D, note: str = "",
                  path: Optional[str] = None) -> str:
    """Transforms-file `text` with entry `name` replaced by `transform` (added at the end
    if absent), every other entry and comment kept; `note` becomes a comment inside it."""
    before = parse_transforms(text, path)
    block = yaml.safe_dump({name: transform.to_dict()}, sort_keys=False,
                           default_flow_style=None)
    if note:
        head, rest = block.split("\n", 1)
        block = head + "\n" + "".join("  # {}\n".format(n) for n in note.splitlines()) + rest
    lines = text.splitlines(keepends=True)
    key = re.compile(r"{}\s*:".format(re.escape(name)))
    start = next((i for i, line in enumerate(lines) if key.match(line)), None)
    if start is None:
        lines += ([] if not lines or lines[-1].endswith("\n") else ["\n"]) + [block]
    else:
        end = start + 1  # the entry: its key line and the indented (or blank) lines after it
        while end < len(lines) and (lines[end][:1] in (" ", "\t") or not lines[end].strip()):
            end += 1
        while end > start + 1 and not lines[end - 1].strip():
            end -= 1
        lines[start:end] = [block]
    out = "".join(lines)
    kept = {k: v for k, v in before.items() if k != name}
    try:
        after = parse_transforms(out, path)
    except TransformError:
        after = {}
    if {k: v for k, v in after.items() if k != name} != kept or name not in after or not \
            after[name].is_close(transform, atol=1e-12 * float(np.abs(transform.matrix).max())):
        # a layout this line-based edit does not understand (flow style, quoted keys)
        return dump_transforms({**kept, name: transform})
    return out


def write_transform(path: Union[str, Path], name: str, transform: Transform2D,
                    note: str = "") -> None:
    """Replace or add entry `name` in transforms file `path` (see set_transform), atomically."""
    path = Path(path)
    text = read_yaml_text(str(path), TransformError) if path.exists() else ""
    new = set_transform(text, name, transform, note, str(path))
    temporary = path.with_name(path.name + ".tmp")
    try:
        temporary.write_text(new, encoding="utf-8")
        os.replace(str(temporary), str(path))
    except OSError as err:
        raise TransformError("cannot write: {}".format(err.strerror), str(path)) from err


# ---- calibration -------------------------------------------------------------

def _check_points(points: np.ndarray, which: str) -> None:
    extent = max(float(np.ptp(points, axis=0).max()), 1e-300)
    gaps = np.linalg.norm(points[:, None, :] - points[None, :, :], axis=2)
    gaps[np.tril_indices(len(points))] = np.inf
    i, j = np.unravel_index(int(np.argmin(gaps)), gaps.shape)
    if gaps[i, j] <= 1e-9 * extent:
        raise TransformError("{} points {} and {} coincide: every pair must be a distinct "
                             "place".format(which, i, j))
    spread = np.linalg.svd(points - points.mean(axis=0), compute_uv=False)
    if spread[1] <= 1e-3 * spread[0]:
        raise TransformError("{} points are (nearly) collinear: measure points spread in both "
                             "directions, not along one line".format(which))


def fit_similarity(src_points: Any, dst_points: Any, source: str,
                   target: str) -> Tuple[Transform2D, float]:
    """Least-squares similarity (rotation, uniform scale, translation; no mirror) mapping
    `src_points` onto `dst_points`, and its RMS residual in target units.

    Umeyama's closed form: centre both sets, take the SVD of their covariance;
    the rotation is U S V^T (S flips the last axis if that would be a mirror),
    the scale is trace(D S) / source variance, the translation matches the means.
    """
    src = np.asarray(src_points, dtype=float)
    dst = np.asarray(dst_points, dtype=float)
    for arr, which in ((src, "source"), (dst, "target")):
        if arr.ndim != 2 or arr.shape[1] != 2:
            raise TransformError("{} points must be an (N, 2) array, got shape {}".format(
                which, arr.shape))
        if not np.all(np.isfinite(arr)):
            raise TransformError("{} points contain non-finite values".format(which))
    if len(src) != len(dst):
        raise TransformError("got {} source points but {} target points: give pairs".format(
            len(src), len(dst)))
    if len(src) < 3:
        raise TransformError("a similarity fit needs at least 3 point pairs, got {}".format(
            len(src)))
    _check_points(src, "source")
    _check_points(dst, "target")
    mean_src, mean_dst = src.mean(axis=0), dst.mean(axis=0)
    centred_src, centred_dst = src - mean_src, dst - mean_dst
    variance = float((centred_src ** 2).sum()) / len(src)
    u, d, vt = np.linalg.svd(centred_dst.T @ centred_src / len(src))
    signs = np.array([1.0, 1.0 if np.linalg.det(u) * np.linalg.det(vt) >= 0 else -1.0])
    rotation = u @ np.diag(signs) @ vt
    scale = float(d @ signs) / variance
    if scale <= 1e-12 * float(d[0]) / variance:
        raise TransformError("the target points are a mirror image of the source points: "
                             "no rotation and scale maps one onto the other")
    matrix = np.eye(3)
    matrix[:2, :2] = scale * rotation
    matrix[:2, 2] = mean_dst - scale * rotation @ mean_src
    fitted = Transform2D(matrix, source, target)
    residual = float(np.sqrt(np.mean(np.sum((fitted.apply(src) - dst) ** 2, axis=1))))
    return fitted, residual
