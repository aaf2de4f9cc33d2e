"""One chart: its PNG, its title, and the numbers it plots (what tests check).

Figures are drawn on matplotlib's Agg canvas directly (no pyplot, no
display, no global state), at a size and resolution that keep the PNGs small.
"""
from __future__ import annotations

import io
from dataclasses import dataclass, field
from typing import Any, Dict, Tuple

from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

DPI = 90


@dataclass
class Chart:
    """A drawn figure: `name` (file-name safe), `title`, `png` bytes, and `data` it plots."""

    name: str
    title: str
    png: bytes
    data: Dict[str, Any] = field(default_factory=dict)
    caption: str = ""


def new_figure(size: Tuple[float, float] = (7.5, 4.2)) -> Figure:
    figure = Figure(figsize=size, dpi=DPI)
    FigureCanvasAgg(figure)
    return figure


def to_png(figure: Figure) -> bytes:
    out = io.BytesIO()
    figure.savefig(out, format="png", dpi=DPI, bbox_inches="tight", metadata={"Software": None})
    return out.getvalue()
