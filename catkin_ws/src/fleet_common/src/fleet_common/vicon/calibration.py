"""Calibrating Vicon -> base grid from robots standing on known cells.

A correspondence is a base-grid cell and where Vicon saw a robot standing on
it (millimetres). A correspondences file holds one a line, `#` comments:

    # cell_x  cell_y  vicon_x_mm  vicon_y_mm  [label]
    3  4  2812.5  5120.0  turtlebot1

`calibrate` fits the least-squares similarity (rotation, uniform scale,
translation: `fleet_common.frames.fit_similarity`) from at least MIN_PAIRS
pairs (three fix a similarity; a fourth lets the residuals show a mistake) and
gives each point's residual and the RMS in centimetres on the floor (Vicon
millimetres are metric; the fitted scale turns cell residuals back into them).
"""
from __future__ import annotations

import math
import re
from dataclasses import dataclass
from pathlib import Path
from typing import List, Optional, Sequence, Tuple, Union

import numpy as np

from ..errors import TransformError
from ..frames import fit_similarity
from ..limits import VICON_MAX_PAIRS_BYTES
from ..transform2d import Transform2D

__all__ = ["Correspondence", "Calibration", "calibrate", "parse_correspondences",
           "read_correspondences", "format_correspondences", "MIN_PAIRS", "DEFAULT_MAX_RMS_CM"]

MIN_PAIRS = 4
#: Above this RMS (cm) a calibration is refused (a wrong pair or a moved camera).
DEFAULT_MAX_RMS_CM = 2.0
_COLUMNS = "cell_x cell_y vicon_x_mm vicon_y_mm [label]"
_TOKEN = re.compile(r"\S+")


@dataclass(frozen=True)
class Correspondence:
    cell: Tuple[float, float]    # base grid
    vicon: Tuple[float, float]   # millimetres
    label: str = ""
    line: int = 0

    def describe(self) -> str:
        where = "line {}".format(self.line) if self.line else ""
        return " ".join(p for p in (self.label, where) if p) or "cell ({:g}, {:g})".format(
            *self.cell)


@dataclass(frozen=True)
class Calibration:
    """A fitted vicon -> base transform and how well it fits its points."""

    transform: Transform2D
    pairs: Tuple[Correspondence, ...]
    residuals_cm: Tuple[float, ...]
    rms_cm: float

    @property
    def mm_per_cell(self) -> float:
        return 1.0 / math.sqrt(abs(float(np.linalg.det(self.transform.matrix[:2, :2]))))

    @property
    def rotation_deg(self) -> float:
        return math.degrees(self.transform.apply_heading(0.0))

    def worst(self) -> Correspondence:
        return self.pairs[int(np.argmax(self.residuals_cm))]


def calibrate(pairs: Sequence[Correspondence]) -> Calibration:
    """The least-squares similarity mapping the Vicon points onto their cells."""
    if len(pairs) < MIN_PAIRS:
        raise TransformError("calibration needs at least {} correspondences (robots on "
                             "known cells), got {}".format(MIN_PAIRS, len(pairs)))
    vicon = np.array([p.vicon for p in pairs], dtype=float)
    cells = np.array([p.cell for p in pairs], dtype=float)
    transform, _ = fit_similarity(vicon, cells, "vicon", "base")
    cells_per_mm = math.sqrt(abs(float(np.linalg.det(transform.matrix[:2, :2]))))
    off_cells = np.linalg.norm(transform.apply(vicon) - cells, axis=1)
    residuals = off_cells / cells_per_mm / 10.0  # mm -> cm
    rms = float(np.sqrt(np.mean(residuals ** 2)))
    return Calibration(transform, tuple(pairs), tuple(float(r) for r in residuals), rms)


def parse_correspondences(text: str, path: Optional[str] = None) -> List[Correspondence]:
    """The correspondences in `text`; TransformError naming the line and column if malformed."""
    out: List[Correspondence] = []
    for number, line in enumerate(text.splitlines(), 1):
        fields = [(m.start() + 1, m.group()) for m in _TOKEN.finditer(line.split("#", 1)[0])]
        if not fields:
            continue
        if len(fields) not in (4, 5):
            raise TransformError("expected {} fields ({}), found {}".format(
                "4 or 5", _COLUMNS, len(fields)), path, number)
        values = []
        for i, (column, token) in enumerate(fields[:4]):
            try:
                value = float(token)
            except ValueError:
                value = math.nan
            if not math.isfinite(value):
                raise TransformError("bad {} {!r}: expected a finite number".format(
                    _COLUMNS.split()[i], token), path, number, column)
            values.append(value)
        label = fields[4][1] if len(fields) == 5 else ""
        out.append(Correspondence((values[0], values[1]), (values[2], values[3]), label, number))
    return out


def read_correspondences(path: Union[str, Path]) -> List[Correspondence]:
    try:
        with open(path, "rb") as f:
            data = f.read(VICON_MAX_PAIRS_BYTES + 1)
    except OSError as err:
        raise TransformError("cannot read: {}".format(err.strerror), str(path)) from err
    if len(data) > VICON_MAX_PAIRS_BYTES:
        raise TransformError("larger than {} bytes: not a correspondences file".format(
            VICON_MAX_PAIRS_BYTES), str(path))
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as err:
        raise TransformError("not UTF-8 text (byte {})".format(err.start), str(path)) from None
    return parse_correspondences(text, str(path))


def format_correspondences(pairs: Sequence[Correspondence]) -> str:
    lines = ["# Vicon calibration correspondences (fleetctl vicon calibrate)",
             "# " + _COLUMNS]
    for p in pairs:
        lines.append("{:g} {:g} {:.2f} {:.2f}{}".format(
            p.cell[0], p.cell[1], p.vicon[0], p.vicon[1], " " + p.label if p.label else ""))
    return "\n".join(lines) + "\n"
