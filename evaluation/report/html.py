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
tr.operator td { background: #eef3ff; } tr.replan td { background: #fff3d6; font-weight: bold; }
"""

#: Shows only the rows of a filterable table that hold the word typed and match the robot and
#: the kind chosen (runs in the browser; the page needs no network).
_FILTER = """<script>
function filterRows(id) {
  var word = document.getElementById(id + '-word').value.toLowerCase();
  var robot = document.getElementById(id + '-robot').value;
  var kind = document.getElementById(id + '-kind').value;
  var rows = document.getElementById(id).getElementsByTagName('tr');
  for (var i = 1; i < rows.length; i++) {
    var r = rows[i];
    var ok = (!word || r.textContent.toLowerCase().indexOf(word) >= 0)
      && (!robot || r.getAttribute('data-robot') === robot)
      && (!kind || r.getAttribute('data-kind') === kind || r.className === kind);
    r.style.display = ok ? '' : 'none';
  }
}
</script>"""


@dataclass
class Table:
    header: Sequence[str]
    rows: Sequence[Sequence[object]]
    left: int = 1  # leading columns aligned left (labels)
    #: a filterable table: its id, and per row (robot, kind, class); a word, a robot and a kind
    #: (or a class: "operator", "replan") chosen above it show only the rows that match
    name: str = ""
    tags: Sequence[Tuple[str, str, str]] = ()


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
    if not t.name:
        body = "".join("<tr>" + "".join(cell("td", i, v) for i, v in enumerate(r)) + "</tr>" for r in t.rows)
        return "<table><tr>{}</tr>{}</table>".format(head, body)
    rows = []
    for r, (robot, kind, css) in zip(t.rows, t.tags):
        rows.append('<tr data-robot="{}" data-kind="{}"{}>{}</tr>'.format(
            html.escape(robot), html.escape(kind), ' class="{}"'.format(html.escape(css)) if css else "",
            "".join(cell("td", i, v) for i, v in enumerate(r))))
    robots = sorted({robot for robot, _, _ in t.tags if robot}, key=lambda v: (len(v), v))
    kinds = sorted({kind for _, kind, _ in t.tags} | {css for _, _, css in t.tags if css})
    call = "filterRows('{}')".format(t.name)
    controls = ('<p>Show: <input id="{0}-word" placeholder="a word" oninput="{1}"> '
                '<select id="{0}-robot" onchange="{1}"><option value="">every robot</option>{2}</select> '
                '<select id="{0}-kind" onchange="{1}"><option value="">every kind</option>{3}</select></p>').format(
        t.name, call, "".join('<option value="{0}">robot {0}</option>'.format(html.escape(r)) for r in robots),
        "".join('<option value="{0}">{0}</option>'.format(html.escape(k)) for k in kinds))
    return '{}{}<table id="{}"><tr>{}</tr>{}</table>'.format(_FILTER, controls, t.name, head, "".join(rows))


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
