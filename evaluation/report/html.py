"""The report page: one HTML file with everything inside it (no network, no files beside it
needed), and each chart also written as a PNG next to it for papers."""
from __future__ import annotations

import base64
import html
from dataclasses import dataclass, field
from pathlib import Path
from typing import List, Sequence, Tuple, Union

from .figures import Chart

_STYLE = """
body { font-family: DejaVu Sans, Arial, sans-serif; margin: 1.5em auto; max-width: 70em; color: #222; }
h1 { font-size: 1.5em; } h2 { font-size: 1.2em; margin-top: 1.6em; border-bottom: 1px solid #ccc; }
table { border-collapse: collapse; font-size: 0.85em; margin: 0.5em 0; }
td, th { border: 1px solid #ccc; padding: 0.2em 0.5em; text-align: right; }
th { background: #f0f0f0; } td.l, th.l { text-align: left; }
figure { margin: 1em 0; } figcaption { font-size: 0.85em; color: #555; max-width: 60em; }
img { max-width: 100%; } .meta { color: #555; font-size: 0.9em; }
"""


@dataclass
class Table:
    header: Sequence[str]
    rows: Sequence[Sequence[object]]
    left: int = 1  # leading columns aligned left (labels)


Block = Union[Chart, Table, str]


@dataclass
class Page:
    title: str
    meta: List[str] = field(default_factory=list)
    sections: List[Tuple[str, List[Block]]] = field(default_factory=list)

    def add(self, heading: str, *blocks: Block) -> None:
        self.sections.append((heading, list(blocks)))

    @property
    def charts(self) -> List[Chart]:
        return [b for _, blocks in self.sections for b in blocks if isinstance(b, Chart)]


def _table(t: Table) -> str:
    def cell(tag: str, i: int, v: object) -> str:
        text = "{:.3f}".format(v) if isinstance(v, float) else str(v)
        return "<{0}{1}>{2}</{0}>".format(tag, ' class="l"' if i < t.left else "", html.escape(text))
    head = "".join(cell("th", i, h) for i, h in enumerate(t.header))
    body = "".join("<tr>" + "".join(cell("td", i, v) for i, v in enumerate(r)) + "</tr>" for r in t.rows)
    return "<table><tr>{}</tr>{}</table>".format(head, body)


def render(page: Page) -> str:
    parts = ["<!DOCTYPE html>", '<html lang="en"><head><meta charset="utf-8">',
             "<title>{}</title><style>{}</style></head><body>".format(html.escape(page.title), _STYLE),
             "<h1>{}</h1>".format(html.escape(page.title))]
    parts += ['<p class="meta">{}</p>'.format(html.escape(m)) for m in page.meta]
    for heading, blocks in page.sections:
        parts.append("<h2>{}</h2>".format(html.escape(heading)))
        for b in blocks:
            if isinstance(b, Chart):
                parts.append('<figure><img alt="{}" src="data:image/png;base64,{}"><figcaption>{}</figcaption>'
                             '</figure>'.format(html.escape(b.title), base64.b64encode(b.png).decode("ascii"),
                                                html.escape(b.caption or b.title)))
            elif isinstance(b, Table):
                parts.append(_table(b))
            else:
                parts.append("<p>{}</p>".format(html.escape(b)))
    parts.append("</body></html>")
    return "\n".join(parts)


def write_report(page: Page, out: Path) -> List[Path]:
    """`out` (the HTML) and one PNG per chart beside it (`<stem>-<chart>.png`); the files written."""
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(render(page), encoding="utf-8")
    written = [out]
    for chart in page.charts:
        png = out.with_name("{}-{}.png".format(out.stem, chart.name))
        png.write_bytes(chart.png)
        written.append(png)
    return written
