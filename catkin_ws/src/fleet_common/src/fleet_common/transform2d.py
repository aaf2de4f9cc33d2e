"""An affine 2-D transform between two named coordinate frames, as data.

A `Transform2D` is a 3x3 homogeneous matrix plus the names of the frame it
reads (`source`) and the frame it writes (`target`). `a.then(b)` is "a, then
b" and refuses to chain frames that do not meet. The readable form used in
YAML files (see `fleet_common.frames`) is, applied in this order:

    flip_y (y -> -y), scale (sx, sy), rotate rotation_deg counter-clockwise, translate

which covers every transform the lab needs (grid flips, cell size, Vicon
similarity); anything else (shear) is written as a matrix.
"""
from __future__ import annotations

import math
from typing import Any, Dict, List, Mapping, Optional, Sequence, Tuple, Union

import numpy as np

from .errors import TransformError
from .limits import excerpt
from .yaml_lines import where

#: The frames FleetControl knows (ARCHITECTURE.md): name -> what it is.
FRAMES: Dict[str, str] = {
    "mapf-ir": "mapf-IR grid: cells, origin top-left, y down (file readers/writers only)",
    "base": "base grid: cells, origin bottom-left, y up (the reference frame)",
    "robot": "robot frame: metres, the base grid shifted and scaled (about 0.7 m a cell)",
    "vicon": "Vicon frame: millimetres, fixed by the cameras",
}

Point = Tuple[float, float]
_READABLE_KEYS = ("scale", "rotation_deg", "translation", "flip_y")
_KEYS = ("source", "target", "matrix") + _READABLE_KEYS
ScaleLike = Union[float, Tuple[float, float]]


def check_frame(name: object, role: str = "frame") -> str:
    if not isinstance(name, str) or name not in FRAMES:
        raise TransformError("unknown {} {}: expected one of {}".format(
            role, excerpt(name), ", ".join(sorted(FRAMES))))
    return name


class Transform2D:
    """Maps points of frame `source` to frame `target`: p' = A p + t (matrix [[A, t], [0, 1]])."""

    __slots__ = ("matrix", "source", "target")

    def __init__(self, matrix: Any, source: str, target: str) -> None:
        m = np.array(matrix, dtype=float)
        if m.shape == (2, 3):
            m = np.vstack([m, [0.0, 0.0, 1.0]])
        if m.shape != (3, 3):
            raise TransformError("a transform matrix is 3x3 (or its top 2x3), got shape {}".format(
                m.shape))
        if not np.all(np.isfinite(m)):
            raise TransformError("transform matrix has non-finite entries")
        if not np.array_equal(m[2], [0.0, 0.0, 1.0]):
            raise TransformError("not an affine transform: the last matrix row must be 0 0 1")
        linear = m[:2, :2]
        stretch = np.linalg.svd(linear, compute_uv=False)
        if stretch[1] <= 1e-12 * stretch[0]:  # also catches all zeros (0 <= 0)
            raise TransformError("transform is singular (not invertible): {}".format(
                linear.tolist()))
        m.setflags(write=False)
        self.matrix = m
        self.source = check_frame(source, "source frame")
        self.target = check_frame(target, "target frame")

    @classmethod
    def identity(cls, frame: str) -> "Transform2D":
        return cls(np.eye(3), frame, frame)

    def apply(self, points: Any) -> Any:
        """One point (x, y) -> (x', y') floats, or an (N, 2) array -> (N, 2) array."""
        arr = np.asarray(points, dtype=float)
        linear, shift = self.matrix[:2, :2], self.matrix[:2, 2]
        if arr.shape == (2,):
            x, y = linear @ arr + shift
            return (float(x), float(y))
        if arr.ndim == 2 and arr.shape[1] == 2:
            return arr @ linear.T + shift
        raise ValueError("expected a point (x, y) or an (N, 2) array, got shape {}".format(
            arr.shape))

    def inverse(self) -> "Transform2D":
        inv = np.linalg.inv(self.matrix)
        inv[2] = (0.0, 0.0, 1.0)  # exact, so the result is affine again
        return Transform2D(inv, self.target, self.source)

    def then(self, other: "Transform2D") -> "Transform2D":
        """This transform followed by `other` (source -> self.target == other.source -> ...)."""
        if self.target != other.source:
            raise TransformError("cannot compose {} with {}: {!r} output is not {!r} input".format(
                self.name(), other.name(), self.target, other.source))
        return Transform2D(other.matrix @ self.matrix, self.source, other.target)

    def name(self) -> str:
        return "{}->{}".format(self.source, self.target)

    def is_close(self, other: "Transform2D", atol: float = 1e-9) -> bool:
        return (self.source, self.target) == (other.source, other.target) and bool(
            np.allclose(self.matrix, other.matrix, rtol=1e-9, atol=atol))

    def parts(self) -> Optional[Tuple[Point, float, Point, bool]]:
        """((sx, sy), rotation_deg, (tx, ty), flip_y) of the readable form, None if sheared."""
        linear = self.matrix[:2, :2]
        flip = bool(np.linalg.det(linear) < 0)
        unflipped = linear @ np.diag([1.0, -1.0]) if flip else linear
        sx = float(np.hypot(*unflipped[:, 0]))
        c, s = unflipped[:, 0] / sx
        sy = float(unflipped[:, 1] @ (-s, c))
        if np.abs(unflipped[:, 1] - sy * np.array([-s, c])).max() > 1e-9 * max(sx, abs(sy)):
            return None
        tx, ty = self.matrix[:2, 2]
        return (sx, sy), math.degrees(math.atan2(s, c)), (float(tx), float(ty)), flip

    def to_dict(self) -> Dict[str, Any]:
        """Plain data for YAML: the readable form when it fits, else the top matrix rows."""
        out: Dict[str, Any] = {"source": self.source, "target": self.target}
        parts = self.parts()
        if parts is None:
            out["matrix"] = [[_clean(v) for v in row] for row in self.matrix[:2].tolist()]
            return out
        (sx, sy), rotation, (tx, ty), flip = parts
        same = math.isclose(sx, sy, rel_tol=1e-12)
        out["scale"] = _clean(sx) if same else [_clean(sx), _clean(sy)]
        out["rotation_deg"] = _clean(rotation)
        out["translation"] = [_clean(tx), _clean(ty)]
        out["flip_y"] = flip
        return out

    @classmethod
    def from_dict(cls, data: Any, path: Optional[str] = None) -> "Transform2D":
        """Inverse of `to_dict`. Errors name `path` and, for data read by
        `yaml_lines.load_marked`, the line and column."""
        if not isinstance(data, Mapping):
            raise _fail("expected a mapping with source, target and either matrix or "
                        "{}, got {}".format("/".join(_READABLE_KEYS), excerpt(data)), path, data)
        for key in data:
            if key not in _KEYS:
                raise _fail("unknown key {}: expected {}".format(excerpt(key), ", ".join(_KEYS)),
                            path, data, key)
        frames = []
        for key, role in (("source", "reads"), ("target", "writes")):
            if key not in data:
                raise _fail("missing key {!r}: the frame it {}, one of {}".format(
                    key, role, ", ".join(sorted(FRAMES))), path, data)
            try:
                frames.append(check_frame(data[key], key + " frame"))
            except TransformError as err:
                raise _fail(err.message, path, data, key) from None
        given = [key for key in _READABLE_KEYS if key in data]
        if "matrix" in data and given:
            raise _fail("give either matrix or {}, not both".format("/".join(_READABLE_KEYS)),
                        path, data, given[0])
        key = "matrix" if "matrix" in data else (given[0] if given else None)
        try:
            if "matrix" in data:
                return cls(_matrix(data, path), frames[0], frames[1])
            return readable(*_readable_parts(data, path), source=frames[0], target=frames[1])
        except TransformError as err:
            if err.path is not None:
                raise
            raise _fail(err.message, path, data, key) from None

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Transform2D):
            return NotImplemented
        return (self.source, self.target) == (other.source, other.target) and bool(
            np.array_equal(self.matrix, other.matrix))

    def __hash__(self) -> int:
        return hash((self.source, self.target, self.matrix.tobytes()))

    def __repr__(self) -> str:
        return "Transform2D({}, {})".format(self.name(), self.matrix[:2].tolist())


def readable(scale: ScaleLike = 1.0, rotation_deg: float = 0.0,
             translation: Sequence[float] = (0.0, 0.0), flip_y: bool = False,
             source: str = "base", target: str = "base") -> Transform2D:
    """The transform of the readable form: flip y, scale, rotate, translate (in that order)."""
    sx, sy = (scale, scale) if isinstance(scale, (int, float)) else scale
    theta = math.radians(rotation_deg)
    c, s = math.cos(theta), math.sin(theta)
    linear = np.array([[c, -s], [s, c]]) @ np.diag([sx, sy])
    if flip_y:
        linear = linear @ np.diag([1.0, -1.0])
    m = np.eye(3)
    m[:2, :2] = linear
    m[:2, 2] = translation
    return Transform2D(m, source, target)


def _clean(value: float) -> float:
    # 15 significant digits: 0.7 stays 0.7 in files instead of 0.7000000000000001.
    return float("{:.15g}".format(value)) + 0.0




def _fail(message: str, path: Optional[str], data: Any, key: Any = None) -> TransformError:
    """An error at `data[key]` (or at `data`), located by the YAML loader's marks if any."""
    return TransformError(message, path, *where(data, key))


def _number(value: Any, what: str, path: Optional[str], data: Any, key: Any) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise _fail("{} must be a finite number, got {}".format(what, excerpt(value)), path, data,
                    key)
    return float(value)


def _numbers(value: Any, count: int, what: str, path: Optional[str], data: Any,
             key: Any) -> List[float]:
    if not isinstance(value, list) or len(value) != count:
        raise _fail("{} must be a list of {} numbers, got {}".format(what, count, excerpt(value)),
                    path, data, key)
    return [_number(v, what, path, value, i) for i, v in enumerate(value)]


def _matrix(data: Mapping[str, Any], path: Optional[str]) -> List[List[float]]:
    rows = data["matrix"]
    if not isinstance(rows, list) or len(rows) not in (2, 3):
        raise _fail("matrix must be 2 or 3 rows of 3 numbers ([a, b, tx], [c, d, ty], [0, 0, 1])",
                    path, data, "matrix")
    return [_numbers(row, 3, "matrix row {}".format(i + 1), path, rows, i)
            for i, row in enumerate(rows)]


def _readable_parts(data: Mapping[str, Any], path: Optional[str]) -> Tuple[Any, ...]:
    scale = data.get("scale", 1.0)
    if isinstance(scale, list):
        sx, sy = _numbers(scale, 2, "scale", path, data, "scale")
    else:
        sx = sy = _number(scale, "scale", path, data, "scale")
    if sx <= 0 or sy <= 0:
        raise _fail("scale must be positive (mirror with flip_y), got {}".format(excerpt(scale)),
                    path, data, "scale")
    rotation = _number(data.get("rotation_deg", 0.0), "rotation_deg", path, data, "rotation_deg")
    translation = _numbers(data.get("translation", [0.0, 0.0]), 2, "translation", path, data,
                           "translation")
    flip = data.get("flip_y", False)
    if not isinstance(flip, bool):
        raise _fail("flip_y must be true or false, got {}".format(excerpt(flip)), path, data,
                    "flip_y")
    return (sx, sy), rotation, translation, flip
